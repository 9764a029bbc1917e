// The ImportMines importer (calib/import/importers.h), plain text or gzip as the input has it.
#include <cstdint>
#include <string>

#include "calib/import/importers.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::RobotDescription robot = calib::LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/datasets/mines_rover.yaml");
  const std::string path = fuzz::WriteFile("exp1.dat", data, size);
  calib::MemorySink sink;
  fuzz::Expect([&] { calib::ImportMines(path, robot, &sink); });
  return 0;
}
