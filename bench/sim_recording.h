#pragma once
// Long simulated recordings for the benchmarks: the default trajectory of a simulation config run
// again and again, each run from its own start (seed + 1, 10 s apart on the robot clock), the last
// run cut at the length asked for (OfflineRunOptions::max_duration_s).
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "calib/core/se2.h"
#include "calib/core/sensor_data.h"

#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/sim/simulator.h"

namespace agvcal_bench {

// Writes `seconds` of default runs of `config` back to back to `path`; returns the recorded seconds.
inline double WriteRecording(calib::SimConfig config, double seconds, const std::string& path) {
  calib::LogWriter writer(path);
  double simulated = 0.0;
  while (simulated < seconds - 1.0) {
    calib::OfflineRunOptions run;
    run.max_duration_s = seconds - simulated;  // the last run cut short
    const calib::OfflineRunSummary s = calib::RunOffline(config, run, &writer);
    simulated += s.duration_s;
    config.start_utime += static_cast<int64_t>((s.duration_s + 10.0) * 1e6);
    config.seed += 1;
  }
  writer.Close();
  return simulated;
}

// The true pose of the robot's reference point at t (us), linear between GROUND_TRUTH samples.
inline calib::Pose2 TruthAt(const std::vector<calib::StampedPose>& truth, double t) {
  auto it = std::lower_bound(truth.begin(), truth.end(), t,
                             [](const calib::StampedPose& p, double u) { return double(p.utime) < u; });
  if (it == truth.begin()) it = truth.begin() + 1;
  if (it == truth.end()) it = truth.end() - 1;
  const calib::StampedPose& a = *(it - 1);
  const calib::StampedPose& b = *it;
  const double s = (t - double(a.utime)) / double(b.utime - a.utime);
  return calib::Interpolate({a.x, a.y, a.theta}, {b.x, b.y, b.theta}, s);
}

}  // namespace agvcal_bench
