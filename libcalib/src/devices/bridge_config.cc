#include "devices/bridge_config.h"

#include <string>
#include <utility>
#include <vector>

namespace calib::bridge_internal {

int64_t ReadInteger(const yaml::Reporter& reporter, const yaml::Field& field, int64_t min, int64_t max) {
  if (!field.value.IsScalar()) reporter.Fail(field, "expected an integer, got " + yaml::Describe(field.value));
  const std::string text = field.value.Scalar();
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(text, &used, 0);  // 0x.. hex, else decimal
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size())
    reporter.Fail(field, "expected an integer (decimal or 0x hex), got '" + text + "'");
  if (v < min || v > max)
    reporter.Fail(field, "must be within " + std::to_string(min) + ".." + std::to_string(max) +
                             ", got '" + text + "'");
  return v;
}

bool ReadBool(const yaml::Reporter& reporter, const yaml::Field& field) {
  const std::string text = field.value.IsScalar() ? field.value.Scalar() : "";
  if (text == "true") return true;
  if (text == "false") return false;
  reporter.Fail(field, "expected true or false, got " + yaml::Describe(field.value));
}

void ReadClockOptions(const yaml::Reporter& reporter, const yaml::CheckedMap& top, DeviceClockOptions* options) {
  const auto c = top.Find("clock");
  if (!c) return;
  const yaml::CheckedMap clock(reporter, *c, {"window_s", "min_span_s", "max_drift_ppm", "max_gap_s"});
  for (const auto& [key, target] : std::vector<std::pair<std::string, double*>>{
           {"window_s", &options->window_s},
           {"min_span_s", &options->min_span_s},
           {"max_drift_ppm", &options->max_drift_ppm},
           {"max_gap_s", &options->max_gap_s}}) {
    if (const auto f = clock.Find(key)) *target = yaml::ReadPositive(reporter, *f);
  }
}

}  // namespace calib::bridge_internal
