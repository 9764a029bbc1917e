// KITTI Velodyne .bin files (calib/io/cloud_file.h ReadKittiBin).
#include <cstdint>

#include "calib/io/cloud_file.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = fuzz::WriteFile("fuzz.bin", data, size);
  fuzz::Expect([&] { calib::ReadCloudFile(path); });
  return 0;
}
