#pragma once
// Numbers as a person reads them, at the terminal and in summary files: every number with its
// unit, angles in rad with degrees beside, lengths of a residual in mm, p-values with two
// significant digits (never "p = 0"), values rounded to their one-sigma uncertainty. One helper
// for every command, so the same quantity reads the same everywhere. Machine-readable files
// (RESULT.json, REPORT.json) keep their SI numbers unrounded and do not use these.

#include <string>

#if defined(__GNUC__)
#define CALIB_PRINTF_FORMAT(f, a) __attribute__((format(printf, f, a)))
#else
#define CALIB_PRINTF_FORMAT(f, a)
#endif

namespace calib {

// The SI unit of a robot-file or effect parameter key (spec/robot.md, spec/effects.md): "m",
// "rad", "s", "s²/m", "rad/s", "(relative)" (a fraction of the wheel radius: amplitude) or ""
// (dimensionless: gyro_scale). A dotted key ("lidar2d.yaw") is read by its last part.
std::string ParamUnit(const std::string& key);

// A p-value as a person reads it, two significant digits: "0.031", "3.1e-05", or "< 1e-12"
// below 1e-12 (where the tail is numerical noise), never 0; "n/a" when not a number. For
// table cells headed "p".
std::string PValueNumber(double p);
// The same in a sentence: "p = 0.031", "p < 1e-12".
std::string PValueText(double p);

// Decimals that show `sigma` with two significant digits (0.000040 -> 6); 0 for sigma >= 10,
// -1 when sigma is zero or not finite (no rounding to it).
int DecimalsForSigma(double sigma);

// `value` rounded to `sigma` (DecimalsForSigma), in fixed notation; without a usable sigma,
// `significant` significant digits. Always a plain decimal a YAML 1.1 or 1.2 reader takes
// as a float ("0.000040", "1.5", never "4e-05").
std::string RoundedToSigma(double value, double sigma, int significant = 6);

// printf into a string (at most 511 characters): for a fixed-width column or a format
// none of the helpers below gives. Every snprintf-to-string wrapper is this one.
std::string Formatted(const char* format, ...) CALIB_PRINTF_FORMAT(1, 2);

// `decimals` after the point, fixed notation: "12.35" (FixedDecimals(12.345, 2)).
std::string FixedDecimals(double value, int decimals);

// "1.2346 ± 0.0012": the value rounded to two significant digits of its sigma
// (DecimalsForSigma, RoundedToSigma) and the sigma. Sigma 0 or NaN: the value alone, six
// significant digits ("0.5"); an infinite sigma: "0.5 ± undetermined". A negative sigma:
// the value rounded to |sigma| without showing it (a change, a difference). "n/a" for a
// value that is not finite. No unit: EstimateText adds it.
std::string ValueWithSigma(double value, double sigma);

// `significant` significant digits, no exponent unless the number is tiny or huge.
std::string SignificantText(double value, int significant = 4);

// A value in `unit` (SI): "0.0123 m", "0.0012 rad (0.069 deg)", "0.0098 s²/m".
std::string QuantityText(double value, const std::string& unit, int significant = 4);

// An estimate and its one sigma (ValueWithSigma) with the unit; radians get degrees beside: "0.115213 ± 0.000040 m", "0.01200 ± 0.00012 rad (0.6875 ± 0.0069 deg)".
std::string EstimateText(double value, double sigma, const std::string& unit);

// A length in millimetres: "1.06 mm" (`decimals` after the point).
std::string MillimetresText(double metres, int decimals = 2);

// An angle in radians with degrees beside: "0.00123 rad (0.0705 deg)".
std::string AngleText(double radians, int significant = 3);

}  // namespace calib
