// The MCAP reader and the CDR decoders behind ImportRosbag2 (calib/import/importers.h), with a
// robot whose ros: block reads joint states, scans, IMU and drive commands.
#include <cstdint>
#include <string>

#include "calib/import/importers.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::RobotDescription robot = fuzz::Robot("ros/diff_robot");
  const std::string path = fuzz::WriteFile("fuzz.mcap", data, size);
  calib::MemorySink sink;
  fuzz::Expect([&] { calib::ImportRosbag2(path, robot, &sink); });
  return 0;
}
