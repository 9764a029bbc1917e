#pragma once
// The robot file's `ros:` block (RosTopics, docs/ros.md). Internal to libcalib.
#include "calib/core/robot.h"
#include "core/yaml_checked.h"

namespace calib::yaml {

// Throws InputError naming the file, line and key for an unknown key, a topic that is not a
// name, a wheel role the drive does not have or a joint used twice.
RosTopics ReadRosTopics(const Reporter& reporter, const Field& field, DriveType drive);

}  // namespace calib::yaml
