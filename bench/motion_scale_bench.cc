// agvcal-bench-motion-scale: where a scale error of the calibrated lengths comes from. For each
// interval the calibration sees (the pipeline's keyframe pairs, scans de-skewed with the TRUE
// values), three sensor motions: the matched one M, the one the wheel model predicts with the true
// values P, and the true one T (GROUND_TRUTH composed with the true mount). Prints the fitted scale
// of M and of P against T (translation and rotation), pooled over the seeds, with the translation
// scale's standard error (batch means over blocks of consecutive intervals), and the calibration
// (Calibrate, one pass) on the matched motions and on the true ones (the matcher's covariances
// kept): each value's mean error, absolute and relative to its truth (docs/calibration.md, "The
// lengths' scale bias").
//
//   agvcal-bench-motion-scale [--seeds N] [--sim NAME.yaml] [--range-noise M]
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/se2.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/sim/simulator.h"
#include "sim_recording.h"

namespace {

// The common scale of estimated motions against true ones, fitted by least squares over the
// intervals: translation and rotation apart.
// The translation scale's standard error from the spread over blocks of consecutive intervals
// (batch means): neighbouring intervals share a scan, and its error enters both with opposite
// signs, so intervals taken as independent would overstate it.
struct ScaleFit {
  static constexpr int kBlock = 40;
  double cross_t = 0, norm_t = 0, cross_r = 0, norm_r = 0;
  std::vector<std::pair<double, double>> terms;  // per block: sum of (est - truth) . truth, of |truth|²
  int in_block = kBlock;
  void Add(const calib::Pose2& est, const calib::Pose2& truth) {
    const double cross = (est.x - truth.x) * truth.x + (est.y - truth.y) * truth.y;
    const double norm = truth.x * truth.x + truth.y * truth.y;
    if (in_block == kBlock) terms.emplace_back(0.0, 0.0), in_block = 0;
    terms.back().first += cross;
    terms.back().second += norm;
    ++in_block;
    cross_t += cross;
    norm_t += norm;
    cross_r += calib::WrapAngle(est.theta - truth.theta) * truth.theta;
    norm_r += truth.theta * truth.theta;
  }
  void NewRecording() { in_block = kBlock; }
  double StandardError() const {
    const double scale = cross_t / norm_t;
    double sum = 0.0;
    for (const auto& [cross, norm] : terms) sum += (cross - scale * norm) * (cross - scale * norm);
    return std::sqrt(sum) / norm_t;
  }
  void Print(const char* what) const {
    std::printf("  %-34s translation scale %+9.2e +- %8.2e   rotation scale %+9.2e\n", what, cross_t / norm_t,
                StandardError(), cross_r / norm_r);
  }
};

int Run(int argc, char** argv) {
  int seeds = 5;
  std::string name = "forklift.yaml";
  double range_noise = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) seeds = std::atoi(argv[++i]);
    else if (a == "--sim" && i + 1 < argc) name = argv[++i];
    else if (a == "--range-noise" && i + 1 < argc) range_noise = std::atof(argv[++i]);
    else if (a == "--help" || a == "-h") {
      std::cout << "usage: agvcal-bench-motion-scale [--seeds N] [--sim NAME.yaml] [--range-noise M]\n";
      return calib::kExitOk;
    } else throw calib::InputError("command line", a, "unknown option");
  }
  calib::SimConfig base = calib::LoadSimConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/sims/" + name);
  base.robot.params = base.true_params;
  base.robot.lidar2d->x = base.true_lidar2d.x;
  base.robot.lidar2d->y = base.true_lidar2d.y;
  base.robot.lidar2d->yaw = base.true_lidar2d.yaw;
  if (range_noise >= 0) base.lidar2d.range_noise = range_noise;
  const calib::Pose2 mount{base.true_lidar2d.x, base.true_lidar2d.y, base.true_lidar2d.yaw};
  const std::unique_ptr<calib::DriveModel> model = calib::MakeDriveModel(base.robot);
  const std::string log = "/tmp/agvcal_bench_scale_" + std::to_string(getpid()) + ".log";
  ScaleFit matched, predicted, matched_vs_predicted;
  // The calibration on the matched motions and on the true motions (the matcher's covariances
  // kept): the mean error of each value, relative to its truth.
  std::map<std::string, double> truth_values = base.true_params;
  truth_values["mount_x"] = mount.x, truth_values["mount_y"] = mount.y, truth_values["mount_yaw"] = mount.theta;
  std::map<std::string, double> error_matched, error_true, sigma_sum;
  int intervals = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    for (ScaleFit* fit : {&matched, &predicted, &matched_vs_predicted}) fit->NewRecording();
    calib::SimConfig sim = base;
    sim.seed = seed;
    {
      calib::LogWriter writer(log);
      calib::RunOffline(sim, calib::OfflineRunOptions{}, &writer);
      writer.Close();
    }
    std::vector<calib::StampedPose> truth;
    {
      calib::RecordingSource recording(log);
      calib::SubscribePoses(&recording, calib::kGroundTruthChannel,
                            [&](const calib::StampedPose& p) { truth.push_back(p); });
      recording.HandleAll();
    }
    const calib::CalibrationData data =
        calib::ReadCalibrationData(sim.robot, log, calib::MotionSource::kLidar2d, nullptr);
    std::vector<calib::SensorMotion> true_motions;
    for (const calib::SensorMotion& m : data.motions()) {
      const double t0 = double(m.utime_start), t1 = double(m.utime_end);
      if (!m.valid || m.degenerate || !data.wheels().Covers(t0, t1)) continue;
      const calib::Pose2 a = calib::Compose(agvcal_bench::TruthAt(truth, t0), mount);
      const calib::Pose2 b = calib::Compose(agvcal_bench::TruthAt(truth, t1), mount);
      const calib::Pose2 t = calib::Between(a, b);
      const calib::Pose2 p = calib::PredictSensorMotion(data.wheels(), *model, mount, t0, t1);
      true_motions.push_back(m);
      true_motions.back().delta = t;
      matched.Add(m.delta, t);
      predicted.Add(p, t);
      matched_vs_predicted.Add(m.delta, p);
      ++intervals;
    }
    auto add = [&](const calib::CalibrationResult& r, std::map<std::string, double>* errors, bool sigma) {
      for (const auto& [n, v] : truth_values) {
        const calib::Estimate& e = n == "mount_x"     ? r.mount_x
                                   : n == "mount_y"   ? r.mount_y
                                   : n == "mount_yaw" ? r.mount_yaw
                                                      : r.params.at(n);
        (*errors)[n] += (e.value - v) / seeds;
        if (sigma) sigma_sum[n] += e.std / seeds;
      }
    };
    const calib::CalibrationResult fitted =
        calib::Calibrate(sim.robot, data.wheels(), data.motions(), calib::MotionSource::kLidar2d, {}, log);
    add(fitted, &error_matched, true);
    add(calib::Calibrate(sim.robot, data.wheels(), true_motions, calib::MotionSource::kLidar2d, {}, log), &error_true,
        false);
  }
  std::remove(log.c_str());
  std::printf("%s, %d seeds, %d intervals, range noise %g m\n", name.c_str(), seeds, intervals,
              base.lidar2d.range_noise);
  matched.Print("matched against true");
  predicted.Print("predicted (true values) against true");
  matched_vs_predicted.Print("matched against predicted");
  std::printf("  %-16s %12s %12s %12s %14s %14s\n", "value", "truth", "mean sigma", "bias matched", "bias true motion",
              "relative (m, t)");
  for (const auto& [n, v] : truth_values)
    std::printf("  %-16s %12.6g %12.3g %+12.3g %+14.3g   %+9.2e %+9.2e\n", n.c_str(), v, sigma_sum[n],
                error_matched[n], error_true[n], error_matched[n] / v, error_true[n] / v);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-bench-motion-scale", Run, argc, argv); }
