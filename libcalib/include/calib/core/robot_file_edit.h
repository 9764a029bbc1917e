#pragma once
// Writing calibrated values back into a robot file (spec/robot.md) the way a person would:
// the file's text is kept, comments, layout and units included, and only the numbers change,
// each in place (a key the file lacks is added beside its siblings, in the file's style).

#include <string>
#include <vector>

namespace calib {

// One calibrated value: `path` is the dotted key ("params.drive_radius", "lidar3d.pitch"),
// `value` and `std` in the robot file's units (SI, radians). The value is written rounded to
// its std (two significant digits of the std, units.h RoundedToSigma), the std under `std:`;
// a std that is not a positive finite number writes `significant` digits and no std.
struct RobotFileValue {
  std::string path;
  double value = 0;
  double std = 0;
  int significant = 6;
};

// The robot file `text` with `values` written in place, their stds under `std:` (merged with
// those already there), `source` under `source:`, and a first comment line "# Calibrated by
// agvcal <command> from <source>" followed by `details` (lines: what produced it, how much of the
// recording was fitted), each as a comment "#   ..." (replacing such a header if the file has
// one). The robot file's comment "# nominal values; calibration starts here" is dropped: the
// values are no longer nominal. `origin` names the file in errors (the text must be one YAML
// map, as LoadRobotFile checked).
std::string WriteCalibratedValues(const std::string& text, const std::string& origin,
                                  const std::vector<RobotFileValue>& values, const std::string& command,
                                  const std::string& source, const std::string& details = "");

// The same for the robot file at `path` (InputError if it cannot be read).
std::string WriteCalibratedRobotFile(const std::string& path, const std::vector<RobotFileValue>& values,
                                     const std::string& command, const std::string& source,
                                     const std::string& details = "");

// Sets the scalar at the dotted `path` of YAML `text` to `value_text` (already formatted), in
// place; missing maps on the way are created. Exposed for tests.
std::string SetYamlScalar(const std::string& text, const std::string& origin, const std::string& path,
                          const std::string& value_text);

}  // namespace calib
