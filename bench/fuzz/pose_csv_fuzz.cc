// The ImportPoseCsv importer (calib/import/importers.h), plain text or gzip as the input has it.
#include <cstdint>
#include <string>

#include "calib/import/importers.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  
  const std::string path = fuzz::WriteFile("poses.csv", data, size);
  calib::MemorySink sink;
  fuzz::Expect([&] { calib::ImportPoseCsv(path, "POSE", &sink); });
  return 0;
}
