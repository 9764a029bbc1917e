#include "calib/core/units.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <map>

namespace calib {
namespace {

constexpr double kDegPerRad = 57.295779513082320876;

}  // namespace

std::string Formatted(const char* format, ...) {
  char buffer[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  return buffer;
}

std::string FixedDecimals(double value, int decimals) { return Formatted("%.*f", decimals, value); }

std::string ValueWithSigma(double value, double sigma) {
  if (!std::isfinite(value)) return "n/a";
  const double s = std::abs(sigma);
  const int decimals = DecimalsForSigma(s);
  if (decimals < 0 || decimals > 15) return Formatted("%.6g", value) + (std::isinf(s) ? " ± undetermined" : "");
  if (sigma < 0) return RoundedToSigma(value, s);
  return RoundedToSigma(value, s) + " ± " + FixedDecimals(s, decimals);
}

std::string ParamUnit(const std::string& key) {
  const std::string k = key.substr(key.rfind('.') == std::string::npos ? 0 : key.rfind('.') + 1);
  static const std::map<std::string, std::string> kUnits = {
      // spec/robot.md
      {"track", "m"}, {"wheelbase", "m"}, {"a", "m"}, {"b", "m"}, {"x", "m"}, {"y", "m"}, {"z", "m"},
      {"yaw", "rad"}, {"pitch", "rad"}, {"roll", "rad"}, {"time_offset", "s"}, {"gyro_bias", "rad/s"},
      {"gyro_scale", ""}, {"distance", "m"},
      // spec/effects.md
      {"offset_s", "s"}, {"scan_period_s", "s"}, {"slip_per_accel", "s²/m"}, {"gain", "s"}, {"tau_s", "s"},
      {"width_rad", "rad"}, {"amplitude", "(relative)"}, {"phase", "rad"}, {"rate_rad_s", "rad/s"}, {"offset_rad", "rad"}};
  const auto it = kUnits.find(k);
  if (it != kUnits.end()) return it->second;
  auto ends_with = [&k](const std::string& tail) {
    return k.size() >= tail.size() && k.compare(k.size() - tail.size(), tail.size(), tail) == 0;
  };
  if (ends_with("_radius")) return "m";
  if (ends_with("steer_offset")) return "rad";
  return "";
}

std::string PValueNumber(double p) {
  if (!(p >= 1e-12)) return std::isnan(p) ? "n/a" : "< 1e-12";
  return Formatted("%.2g", p);
}

std::string PValueText(double p) {
  const std::string number = PValueNumber(p);
  return number[0] == '<' ? "p " + number : "p = " + number;
}

int DecimalsForSigma(double sigma) {
  if (!(sigma > 0) || !std::isfinite(sigma)) return -1;
  // Two significant digits of the sigma, after it is rounded (0.0000996 -> 0.00010).
  int decimals = 1 - static_cast<int>(std::floor(std::log10(sigma)));
  const double rounded = std::round(sigma * std::pow(10.0, decimals)) / std::pow(10.0, decimals);
  if (rounded >= std::pow(10.0, 2 - decimals)) --decimals;
  return decimals < 0 ? 0 : decimals;
}

std::string SignificantText(double value, int significant) {
  if (!std::isfinite(value)) return std::isnan(value) ? "nan" : (value > 0 ? "inf" : "-inf");
  if (value == 0) return "0";
  const int exponent = static_cast<int>(std::floor(std::log10(std::abs(value))));
  if (exponent < -6 || exponent >= 9) return Formatted("%.*e", significant - 1, value);
  const int decimals = std::max(0, significant - 1 - exponent);
  std::string text = FixedDecimals(value, decimals);
  if (text == "-0") text = "0";
  return text;
}

std::string RoundedToSigma(double value, double sigma, int significant) {
  const int decimals = DecimalsForSigma(sigma);
  if (decimals < 0 || decimals > 15 || !std::isfinite(value)) {
    std::string text = SignificantText(value, significant);
    // A YAML 1.1 reader takes "1e-07" as a string: keep a point in the mantissa.
    if (text.find('e') != std::string::npos && text.find('.') == std::string::npos)
      text.insert(text.find('e'), ".0");
    return text;
  }
  std::string text = FixedDecimals(value, decimals);
  if (text.find_first_not_of("-0.") == std::string::npos && text[0] == '-') text.erase(0, 1);  // no "-0.00"
  return text;
}

std::string QuantityText(double value, const std::string& unit, int significant) {
  std::string text = SignificantText(value, significant);
  if (!unit.empty()) text += " " + unit;
  if (unit == "rad") text += " (" + SignificantText(value * kDegPerRad, significant) + " deg)";
  return text;
}

std::string EstimateText(double value, double sigma, const std::string& unit) {
  std::string text = ValueWithSigma(value, sigma);
  if (!unit.empty()) text += " " + unit;
  if (unit == "rad") text += " (" + ValueWithSigma(value * kDegPerRad, sigma * kDegPerRad) + " deg)";
  return text;
}

std::string MillimetresText(double metres, int decimals) { return FixedDecimals(metres * 1e3, decimals) + " mm"; }

std::string AngleText(double radians, int significant) { return QuantityText(radians, "rad", significant); }

}  // namespace calib
