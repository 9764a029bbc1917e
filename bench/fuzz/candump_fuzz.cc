// candump logs (calib/devices/canopen.h CandumpReader) through the CANopen decoder of the
// bundled bridge configs (config/bridges/*_can.yaml).
#include <cstdint>
#include <string>

#include "calib/devices/canopen.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::CanBridgeConfig configs[] = {
      calib::LoadCanBridgeConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/bridges/forklift_can.yaml"),
      calib::LoadCanBridgeConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/bridges/diff_robot_can.yaml")};
  const std::string path = fuzz::WriteFile("fuzz.candump", data, size);
  for (const auto& config : configs) {
    fuzz::Expect([&] {
      calib::CandumpReader reader(path);
      calib::CanopenDecoder decoder(config);
      calib::CanFrame frame;
      std::vector<agvcal::wheel_state_t> out;
      while (reader.Next(&frame)) decoder.Feed(frame, reader.path(), reader.place(), &out);
    });
  }
  return 0;
}
