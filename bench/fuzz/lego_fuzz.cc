// The Lego robot importer (calib/import/importers.h ImportLego) and its reference file.
// Input: the motor file, "\n====\n", the scan file.
#include <cstdint>
#include <string>

#include "calib/import/importers.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::RobotDescription robot =
      calib::LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/datasets/lego_robot.yaml");
  std::string motors, scan;
  fuzz::Split(data, size, &motors, &scan);
  const std::string motors_path =
      fuzz::WriteFile("robot4_motors.txt", reinterpret_cast<const uint8_t*>(motors.data()), motors.size());
  const std::string scan_path =
      fuzz::WriteFile("robot4_scan.txt", reinterpret_cast<const uint8_t*>(scan.data()), scan.size());
  calib::MemorySink sink;
  fuzz::Expect([&] { calib::ImportLego(motors_path, scan_path, robot, &sink); });
  fuzz::Expect([&] { calib::ReadLegoReference(motors_path); });
  return 0;
}
