// The OptiOdom importer (calib/import/importers.h ImportOptiOdom), differential and tricycle.
// Input: the metadata file, "\n====\n", the run file.
#include <cstdint>
#include <string>

#include "calib/import/importers.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::RobotDescription robots[] = {
      calib::LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/datasets/optiodom_diff.yaml"),
      calib::LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/datasets/optiodom_tricycle.yaml")};
  std::string metadata, run;
  fuzz::Split(data, size, &metadata, &run);
  fuzz::WriteFile("r1_metadata.csv", reinterpret_cast<const uint8_t*>(metadata.data()), metadata.size());
  const std::string run_path = fuzz::WriteFile("r1_run-01.csv", reinterpret_cast<const uint8_t*>(run.data()), run.size());
  for (const auto& robot : robots) {
    calib::MemorySink sink;
    fuzz::Expect([&] { calib::ImportOptiOdom(run_path, robot, &sink); });
  }
  return 0;
}
