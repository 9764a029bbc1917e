#pragma once
// Shared by the libFuzzer targets (bench/fuzz/*_fuzz.cc, docs/bad-input.md): the readers take
// paths, so each input is written to a file in a private directory on tmpfs first; the expected
// outcome of bad input is calib::InputError (or UnobservableError). Anything else escaping a
// target (another exception, a crash, a sanitizer report, a hang) is a defect the fuzzer reports.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "calib/core/errors.h"
#include "calib/core/robot.h"

namespace fuzz {

// A directory of this process's own, on /dev/shm when there is one.
// Never destroyed: the exit handler that removes it runs after static destructors may have.
inline const std::string& Dir() {
  static const std::string& dir = *new std::string([] {
    const char* base = std::getenv("AGVCAL_FUZZ_TMP");
    std::string root = base ? base : (access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp");
    std::string path = root + "/agvcal-fuzz-" + std::to_string(getpid());
    std::string command = "mkdir -p '" + path + "'";
    if (std::system(command.c_str()) != 0) std::abort();
    std::atexit([] {
      std::string rm = "rm -rf '" + Dir() + "'";
      if (std::system(rm.c_str()) != 0) {
      }
    });
    return path;
  }());
  return dir;
}

// Writes `size` bytes to Dir()/name; returns the path.
inline std::string WriteFile(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = Dir() + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Runs `body`; the documented errors of bad input are the expected outcome.
template <typename Body>
void Expect(Body body) {
  try {
    body();
  } catch (const calib::InputError&) {
  } catch (const calib::UnobservableError&) {
  }
}

// A robot file of the checkout (config/robots/NAME.yaml).
inline calib::RobotDescription Robot(const std::string& name) {
  return calib::LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/" + name + ".yaml");
}

// Splits the input at the first "\n====\n": two files from one input.
inline void Split(const uint8_t* data, size_t size, std::string* first, std::string* second) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string mark = "\n====\n";
  const size_t at = text.find(mark);
  *first = text.substr(0, at);
  *second = at == std::string::npos ? std::string() : text.substr(at + mark.size());
}

}  // namespace fuzz
