#pragma once
// Progress of a run made of steps of similar cost: "4 of 9, about 12 s left", the time left
// estimated from the mean duration of the steps done so far; and independent jobs spread
// over a few threads with their results kept in the jobs' order.

#include <chrono>
#include <cstddef>
#include <functional>
#include <string>

namespace calib {

// The time left of `total` steps, from the time the first `done` of them took.
class ProgressEstimate {
 public:
  // The estimate is only shown when the steps are expected to take more than
  // `min_expected_s` in all (a short run needs no countdown).
  explicit ProgressEstimate(int total, double min_expected_s = 5.0);

  // Seconds left after `done` steps took `elapsed_s`; negative when there is no estimate
  // yet (no step done).
  double SecondsLeft(int done, double elapsed_s) const;
  // "k of N" for the step `done` + 1 about to be waited for, with ", about T left" when the
  // run is expected to be long enough; T in seconds, or minutes from 90 s up.
  std::string Label(int done, double elapsed_s) const;
  // The same with the time since construction.
  std::string Label(int done) const;

 private:
  int total_;
  double min_expected_s_;
  std::chrono::steady_clock::time_point start_;
};

// The worker threads a run uses: `requested` when positive, else the hardware's threads
// capped at `default_cap` (at least 1).
int WorkerThreads(int requested, int default_cap = 2);

// Runs job(i) for i in [0, n) on up to `threads` threads (the calling thread included);
// before the calling thread waits for job i's result it calls `before_wait(i)` (may be empty),
// in order 0, 1, ..., so that what it prints comes in the jobs' order whatever finishes first.
// Each job must write only its own result; an exception thrown by a job is rethrown here
// (the first in the jobs' order) once every job has stopped.
void ParallelFor(std::size_t n, int threads, const std::function<void(std::size_t)>& job,
                 const std::function<void(std::size_t)>& before_wait = {});

}  // namespace calib
