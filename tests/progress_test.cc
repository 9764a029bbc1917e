// core/progress.h: the time-left estimate and the ordered parallel loop.
#include "calib/core/progress.h"

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace calib {
namespace {

TEST(ProgressEstimate, TimeLeftFromTheStepsDone) {
  const ProgressEstimate e(9);
  EXPECT_LT(e.SecondsLeft(0, 3.0), 0.0);           // nothing done: no estimate
  EXPECT_DOUBLE_EQ(e.SecondsLeft(3, 6.0), 12.0);   // 2 s a step, 6 left
  EXPECT_DOUBLE_EQ(e.SecondsLeft(9, 20.0), 0.0);
  EXPECT_EQ(e.Label(0, 0.0), "1 of 9");
  EXPECT_EQ(e.Label(3, 6.0), "4 of 9, about 12 s left");
  EXPECT_EQ(e.Label(3, 60.0), "4 of 9, about 2 min left");  // 120 s
}

TEST(ProgressEstimate, QuietOnShortRuns) {
  const ProgressEstimate e(9, 5.0);
  EXPECT_EQ(e.Label(3, 1.2), "4 of 9");  // 3.6 s expected in all: no countdown
  EXPECT_EQ(e.Label(3, 1.8), "4 of 9, about 4 s left");  // 5.4 s expected
}

TEST(WorkerThreads, RequestedOrCapped) {
  EXPECT_EQ(WorkerThreads(3), 3);
  EXPECT_GE(WorkerThreads(0), 1);
  EXPECT_LE(WorkerThreads(0), 2);
  EXPECT_EQ(WorkerThreads(0, 1), 1);
}

TEST(ParallelFor, EveryJobOnceReportsInOrder) {
  for (int threads : {1, 2, 4}) {
    std::vector<int> out(50, 0);
    std::vector<std::size_t> reported;
    std::atomic<int> calls{0};
    ParallelFor(
        out.size(), threads,
        [&](std::size_t i) {
          ++calls;
          if (i % 7 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));  // uneven jobs
          out[i] += int(i) * 3;
        },
        [&](std::size_t i) { reported.push_back(i); });
    EXPECT_EQ(calls.load(), 50) << threads;
    for (std::size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i], int(i) * 3) << threads;
    ASSERT_EQ(reported.size(), out.size());
    for (std::size_t i = 0; i < reported.size(); ++i) EXPECT_EQ(reported[i], i);
  }
}

TEST(ParallelFor, RethrowsTheFirstErrorInJobOrder) {
  for (int threads : {1, 2}) {
    std::atomic<int> calls{0};
    try {
      ParallelFor(10, threads, [&](std::size_t i) {
        ++calls;
        if (i == 3) throw std::runtime_error("three");
        if (i == 8) throw std::logic_error("eight");
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "three");
    }
    EXPECT_EQ(calls.load(), 10) << "every job runs, the error waits for them";
  }
}

}  // namespace
}  // namespace calib
