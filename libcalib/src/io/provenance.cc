#include "calib/io/provenance.h"

#include <optional>

namespace calib {
namespace {

std::optional<Provenance>& Stored() {
  static std::optional<Provenance> provenance;
  return provenance;
}

}  // namespace

void SetRunProvenance(const Provenance& provenance) { Stored() = provenance; }

const Provenance* RunProvenance() { return Stored() ? &*Stored() : nullptr; }

std::vector<std::pair<std::string, std::string>> ProvenanceFields(const Provenance& p) {
  std::vector<std::pair<std::string, std::string>> fields;
  auto add = [&](const char* key, const std::string& value) {
    if (!value.empty()) fields.emplace_back(key, value);
  };
  add("command", p.command);
  add("directory", p.directory);
  add("robot_name", p.robot_name);
  add("robot_file", p.robot_file);
  add("recording", p.recording);
  add("recording_sha256", p.recording_sha256);
  add("agvcal_version", p.version);
  add("date", p.date);
  return fields;
}

std::string ProvenanceText(const std::string& prefix) {
  const Provenance* p = RunProvenance();
  if (!p) return "";
  std::string text;
  for (const auto& [key, value] : ProvenanceFields(*p)) text += prefix + key + ": " + value + "\n";
  return text;
}

std::string WithProvenance(const std::string& text) {
  const std::string provenance = ProvenanceText();
  return provenance.empty() ? text : provenance + "\n" + text;
}

}  // namespace calib
