#include "calib/core/progress.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace calib {

ProgressEstimate::ProgressEstimate(int total, double min_expected_s)
    : total_(total), min_expected_s_(min_expected_s), start_(std::chrono::steady_clock::now()) {}

double ProgressEstimate::SecondsLeft(int done, double elapsed_s) const {
  if (done <= 0 || total_ <= 0) return -1.0;
  return elapsed_s / done * std::max(0, total_ - done);
}

std::string ProgressEstimate::Label(int done, double elapsed_s) const {
  std::string out = std::to_string(done + 1) + " of " + std::to_string(total_);
  const double left = SecondsLeft(done, elapsed_s);
  if (left < 0.5 || elapsed_s + left <= min_expected_s_) return out;
  if (left < 90.0) return out + ", about " + std::to_string(std::lround(left)) + " s left";
  return out + ", about " + std::to_string(std::lround(left / 60.0)) + " min left";
}

std::string ProgressEstimate::Label(int done) const {
  return Label(done, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
}

int WorkerThreads(int requested, int default_cap) {
  if (requested > 0) return requested;
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, std::min(hardware > 0 ? hardware : 1, default_cap));
}

void ParallelFor(std::size_t n, int threads, const std::function<void(std::size_t)>& job,
                 const std::function<void(std::size_t)>& before_wait) {
  std::vector<std::exception_ptr> errors(n);
  std::vector<char> finished(n, 0);
  std::atomic<std::size_t> next{0};
  std::mutex mutex;
  std::condition_variable done_cv;
  auto run = [&](std::size_t k) {
    try {
      job(k);
    } catch (...) {
      errors[k] = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    finished[k] = 1;
    done_cv.notify_all();
  };
  // Takes the next job until none is left; the jobs are taken in order, so that with one
  // thread the run is the serial one.
  auto work = [&]() {
    for (std::size_t i = next++; i < n; i = next++) run(i);
  };
  const std::size_t helpers = std::min<std::size_t>(n, std::size_t(std::max(1, threads))) - (n > 0 ? 1 : 0);
  std::vector<std::thread> pool;
  for (std::size_t t = 0; t < helpers; ++t) pool.emplace_back(work);
  // The calling thread reports in order and works when the job it waits for is not taken yet
  // (with one thread: each job runs where it is waited for, after its progress line).
  for (std::size_t i = 0; i < n; ++i) {
    if (before_wait) before_wait(i);
    while (true) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        if (finished[i]) break;
        if (next.load() > i) {  // taken by a helper: wait for it
          done_cv.wait(lock, [&] { return finished[i] != 0; });
          break;
        }
      }
      const std::size_t k = next++;
      if (k < n) run(k);
    }
  }
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace calib
