#pragma once
// What produced an output: the command as run, the agvcal version, the date, the robot file and
// the recording with its SHA-256. A command sets it once (processes/common/provenance.h); every
// output written after that carries it: the top of each report page and summary.txt, the
// `provenance` object of RESULT.json and REPORT.json, the header of a written robot file.

#include <string>
#include <utility>
#include <vector>

namespace calib {

struct Provenance {
  std::string command;           // as run, each argument quoted where the shell needs it
  std::string directory;         // the working directory it ran in
  std::string version;           // agvcal's (git describe at build time)
  std::string date;              // UTC, ISO 8601
  std::string robot_name, robot_file;
  std::string recording, recording_sha256;
};

// The run's provenance; nullptr until set (library use and unit tests write outputs without it).
void SetRunProvenance(const Provenance& provenance);
const Provenance* RunProvenance();

// (key, value) pairs in reading order, empty values left out: the JSON object's keys and the
// page's rows.
std::vector<std::pair<std::string, std::string>> ProvenanceFields(const Provenance& provenance);

// The run's provenance as lines "key: value" prefixed with `prefix` (empty when not set).
std::string ProvenanceText(const std::string& prefix = "");

// `text` with the run's provenance above it (summary.txt).
std::string WithProvenance(const std::string& text);

}  // namespace calib
