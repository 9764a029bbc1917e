// The robot file (spec/robot.md, calib/core/robot.h ParseRobot).
#include <cstdint>
#include <string>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::Expect([&] { calib::ParseRobot(text, "fuzz.yaml"); });
  return 0;
}
