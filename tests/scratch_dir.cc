// Linked into every unit test binary: each test process gets a temporary folder of its own,
// removed with everything in it when the process's tests are done. ctest runs every test case
// as its own process, in parallel and in any order (--schedule-random), so a file name fixed in
// /tmp would be shared by all of them; testing::TempDir() (and TMPDIR, for anything the code
// under test creates) points into this folder instead.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace {

class ScratchDirEnvironment : public testing::Environment {
 public:
  void SetUp() override {
    const char* base = getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/agvcal_test_XXXXXX";
    if (mkdtemp(pattern.data()) == nullptr) {
      GTEST_FAIL() << "cannot create a temporary folder from " << pattern;
    }
    dir_ = pattern;
    setenv("TEST_TMPDIR", dir_.c_str(), 1);
    setenv("TMPDIR", dir_.c_str(), 1);
  }
  void TearDown() override {
    if (dir_.empty()) return;
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

 private:
  std::string dir_;
};

[[maybe_unused]] testing::Environment* const kScratchDir =
    testing::AddGlobalTestEnvironment(new ScratchDirEnvironment);

}  // namespace
