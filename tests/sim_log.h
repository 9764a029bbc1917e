#pragma once
// Test helpers shared by the tests that run the simulator into a recording file.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/sim/simulator.h"

namespace calib::test_support {

// A file of the source tree (config, logs), by its path relative to the repository.
inline std::string Source(const std::string& relative) { return std::string(AGVCAL_SOURCE_DIR) + "/" + relative; }

// A recording of the simulator in a temporary file, removed at the end of the test.
class SimLog {
 public:
  explicit SimLog(const SimConfig& config, const std::string& trajectory = "default")
      : path_(testing::TempDir() + "sim_log_" + std::to_string(counter_++) + ".log") {
    LogWriter writer(path_);
    OfflineRunOptions run;
    run.trajectory = trajectory;
    RunOffline(config, run, &writer);
    writer.Close();
  }
  ~SimLog() { std::remove(path_.c_str()); }
  SimLog(const SimLog&) = delete;
  SimLog& operator=(const SimLog&) = delete;
  const std::string& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  std::string path_;
};

}  // namespace calib::test_support
