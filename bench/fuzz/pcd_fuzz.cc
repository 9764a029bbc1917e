// PCD files (calib/io/cloud_file.h ReadPcd): ascii, binary and binary_compressed (LZF).
#include <cstdint>

#include "calib/io/cloud_file.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = fuzz::WriteFile("fuzz.pcd", data, size);
  fuzz::Expect([&] { calib::ReadCloudFile(path); });
  return 0;
}
