// The hardware bridges' config files (calib/devices: CAN and SICK). First byte chooses which.
#include <cstdint>
#include <string>

#include "calib/devices/canopen.h"
#include "calib/devices/sick_cola.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (data[0] & 1)
    fuzz::Expect([&] { calib::ParseCanBridgeConfig(text, "fuzz.yaml"); });
  else
    fuzz::Expect([&] { calib::ParseSickBridgeConfig(text, "fuzz.yaml"); });
  return 0;
}
