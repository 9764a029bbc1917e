#pragma once
// The run's provenance (calib/io/provenance.h) from its command line: set once by each agvcal
// command before it writes anything.

#include <string>

#include "calib/core/robot.h"
#include "common/command_line.h"

namespace agvcal_process {

// The SHA-256 of a file's bytes, in hex; calib::InputError naming the file when unreadable.
std::string FileSha256(const std::string& path);

// Sets the run's provenance: `args.as_run`, the working directory, the version, the date (UTC;
// $SOURCE_DATE_EPOCH when set, so that a test can compare outputs byte for byte), `robot`
// (null: none) and `recording` ("" none) with its SHA-256.
void RecordProvenance(const CommandLine& args, const calib::RobotDescription* robot, const std::string& recording);

}  // namespace agvcal_process
