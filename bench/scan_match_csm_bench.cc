// agvcal-bench-scan-match-csm: agvcal's scan matcher against CSM's PL-ICP (AndreaCensi/csm) on the
// same scan pairs with the same first guess: pairs per second on one core (thread CPU time) and the
// error against the simulator's truth.
//
//   agvcal-bench-scan-match-csm [--case NAME]... [--passes N]
//
// Cases (issue 19's table):
//   diff540    config/sims/diff_robot.yaml, 540 beams over 270°, 20 Hz, default trajectory; the
//              pipeline's keyframe pairs
//   tricycle540 config/sims/forklift.yaml, 540 beams over 270°, 20 Hz, default trajectory; keyframes
//   demo720    logs/forklift_demo.log (config/sims/forklift.yaml's truth), 720 beams, every
//              consecutive pair
// The simulated cases are simulated afresh (seed 1) into /tmp. Every scan is de-skewed with the TRUE
// motion (GROUND_TRUTH composed with the true lidar mount, interpolated per beam), so the matchers
// see the same points; the first guess is the nominal odometry's prediction (what the pipeline
// uses). The truth of a pair is the true sensor motion between the scans' first beams.
//
// Timing: clock_gettime(CLOCK_THREAD_CPUTIME_ID) over N passes (default 5) of all pairs, the median
// pass reported. agvcal's pass includes the line fit of every scan (PreparedScan, once per scan, as
// ScanMatcher does); CSM's includes its own preprocessing (sm_icp redoes it every call).
// Converting the scans to each matcher's input (points; CSM's polar laser_data) is not timed.
//
// CSM is compiled in only when the build is configured with -DAGVCAL_CSM_SOURCE=<csm checkout>
// -DAGVCAL_CSM_LIBRARY=<libcsm.so> (built outside the repository with -O2; docs/calibration.md).
// Without it, only agvcal's figures are printed.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/laser_scan.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/wheel_track.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/match/scan_match.h"
#include "calib/sim/simulator.h"
#include "sim_recording.h"

#ifdef AGVCAL_WITH_CSM
#include <csm/csm_all.h>
#undef max  // CSM defines max and min as macros
#undef min
#endif

namespace {

double ThreadSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

struct Case {
  std::string name, description;
  calib::SimConfig sim;     // truth (and the recording when `log` is empty)
  std::string log;          // a recorded log instead of a simulation
  bool consecutive = false; // every consecutive pair instead of the pipeline's keyframes
};

struct Data {
  calib::RobotDescription robot;
  std::vector<calib::WheelSample> wheels;
  std::vector<calib::LaserScan> scans;
  std::vector<calib::StampedPose> truth;  // GROUND_TRUTH, robot reference point
};

Data ReadLog(const std::string& path, const calib::RobotDescription& robot) {
  Data data;
  data.robot = robot;
  calib::RecordingSource recording(path);
  calib::SubscribeWheels(&recording, robot, [&](const calib::WheelSample& s) { data.wheels.push_back(s); });
  calib::SubscribeScans(&recording, calib::ScanChannel(robot),
                        [&](calib::LaserScan s) { data.scans.push_back(std::move(s)); });
  calib::SubscribePoses(&recording, calib::kGroundTruthChannel,
                        [&](const calib::StampedPose& p) { data.truth.push_back(p); });
  recording.HandleAll();
  if (data.truth.size() < 2 || data.scans.size() < 2)
    throw calib::InputError(path, calib::kGroundTruthChannel, "no ground truth or fewer than two scans");
  return data;
}

Data Load(const Case& c) {
  if (!c.log.empty()) return ReadLog(c.log, c.sim.robot);
  const std::string path = "/tmp/agvcal_bench_csm_" + c.name + ".log";
  {
    calib::LogWriter writer(path);
    calib::RunOffline(c.sim, calib::OfflineRunOptions{}, &writer);
    writer.Close();
  }
  Data data = ReadLog(path, c.sim.robot);
  std::remove(path.c_str());
  return data;
}


// A scan de-skewed with the true motion: every beam (with or without a return) as a point in the
// sensor frame at the first beam. `has` marks the returns.
struct TrueScan {
  int64_t utime = 0;
  calib::Pose2 sensor;                  // true sensor pose at utime, world frame
  std::vector<Eigen::Vector2d> beams;   // every beam, de-skewed (zero where no return)
  std::vector<double> nominal_angle;    // beam angle, rad
  std::vector<bool> has;
  calib::ScanPoints points;             // the returns, for agvcal
};

TrueScan Deskew(const calib::LaserScan& scan, const std::vector<calib::StampedPose>& truth,
                const calib::Pose2& mount) {
  TrueScan out;
  out.utime = scan.utime;
  out.sensor = calib::Compose(agvcal_bench::TruthAt(truth, double(scan.utime)), mount);
  const calib::Pose2 inverse = calib::Inverse(out.sensor);
  out.points.utime = scan.utime;
  out.points.angle_increment = scan.angle_increment;
  out.points.full_circle = std::abs(scan.angle_increment) * scan.size() >=
                           2.0 * M_PI - 1.5 * std::abs(scan.angle_increment);
  for (int i = 0; i < scan.size(); ++i) {
    const double a = scan.BeamAngle(i);
    out.nominal_angle.push_back(a);
    out.has.push_back(scan.HasReturn(i));
    if (!scan.HasReturn(i)) {
      out.beams.emplace_back(0.0, 0.0);
      continue;
    }
    const calib::Pose2 at = calib::Compose(inverse, calib::Compose(agvcal_bench::TruthAt(truth, scan.BeamTime(i)), mount));
    const double r = scan.ranges[i];
    const double px = r * std::cos(a), py = r * std::sin(a);
    const double c = std::cos(at.theta), s = std::sin(at.theta);
    out.beams.emplace_back(at.x + c * px - s * py, at.y + s * px + c * py);
    out.points.points.push_back(out.beams.back());
  }
  return out;
}

struct Pair {
  int a, b;             // scan indices
  calib::Pose2 guess;   // nominal odometry's prediction
  calib::Pose2 truth;   // true sensor motion
};

std::vector<Pair> MakePairs(const Case& c, const Data& data, const std::vector<TrueScan>& scans) {
  calib::ScanMatchOptions options;
  if (c.consecutive) options.keyframe_translation_m = options.keyframe_rotation_rad = -1.0;
  // The pipeline decides which scans pair (keyframes, coverage by wheel data).
  calib::ScanMatcher matcher(data.robot, options);
  std::vector<calib::SensorMotion> matches;
  auto keep_matches = [&](const std::vector<calib::ScanMatchOutcome>& outcomes) {
    for (const calib::ScanMatchOutcome& outcome : outcomes)
      if (outcome.matched()) matches.push_back(outcome.motion);
  };
  std::size_t w = 0;
  for (const calib::LaserScan& scan : data.scans) {
    while (w < data.wheels.size() && data.wheels[w].utime <= scan.utime) keep_matches(matcher.AddWheels(data.wheels[w++]));
    keep_matches(matcher.AddScan(scan));
  }
  for (; w < data.wheels.size(); ++w) keep_matches(matcher.AddWheels(data.wheels[w]));
  keep_matches(matcher.Finish());
  std::map<int64_t, int> index;
  for (std::size_t k = 0; k < scans.size(); ++k) index[scans[k].utime] = static_cast<int>(k);
  calib::WheelTrack track;
  for (const calib::WheelSample& s : data.wheels) track.Append(s);
  const std::unique_ptr<calib::DriveModel> model = calib::MakeDriveModel(data.robot);
  const calib::Pose2 mount{data.robot.lidar2d->x, data.robot.lidar2d->y, data.robot.lidar2d->yaw};
  const double t_end = data.truth.back().utime;
  std::vector<Pair> pairs;
  for (const calib::SensorMotion& m : matches) {
    const int a = index.at(m.utime_start), b = index.at(m.utime_end);
    if (data.scans[b].end_utime() > t_end) continue;
    pairs.push_back({a, b,
                     calib::PredictSensorMotion(track, *model, mount, double(m.utime_start), double(m.utime_end)),
                     calib::Between(scans[a].sensor, scans[b].sensor)});
  }
  return pairs;
}

struct Errors {
  std::vector<double> translation, rotation;
  std::vector<double> chi2;  // eᵀ cov⁻¹ e with the matcher's covariance (agvcal), 3 if exact
  int failed = 0;
  void Add(bool valid, const calib::Pose2& estimate, const calib::Pose2& truth) {
    if (!valid) {
      ++failed;
      return;
    }
    translation.push_back(std::hypot(estimate.x - truth.x, estimate.y - truth.y));
    rotation.push_back(calib::WrapAngle(estimate.theta - truth.theta));
  }
};

double Rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? NAN : std::sqrt(s / v.size());
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

struct Result {
  std::string name;
  double pairs_per_s = 0.0;
  Errors errors;
};

// One pass of agvcal's matcher over the pairs: seconds of thread CPU time.
double AgvcalPass(const std::vector<TrueScan>& scans, const std::vector<Pair>& pairs,
                  const calib::ScanMatchOptions& options, Errors* errors) {
  const double start = ThreadSeconds();
  std::unique_ptr<calib::PreparedScan> reference, current;
  int reference_index = -1;
  for (const Pair& p : pairs) {
    if (p.a != reference_index) reference = std::make_unique<calib::PreparedScan>(scans[p.a].points, options);
    current = std::make_unique<calib::PreparedScan>(scans[p.b].points, options);
    const calib::SensorMotion m = calib::MatchScans(*reference, *current, p.guess, options);
    if (errors) {
      errors->Add(m.valid, m.delta, p.truth);
      if (m.valid && !m.degenerate) {
        const Eigen::Vector3d e(m.delta.x - p.truth.x, m.delta.y - p.truth.y,
                                calib::WrapAngle(m.delta.theta - p.truth.theta));
        errors->chi2.push_back(e.dot(m.covariance.inverse() * e));
      }
    }
    reference = std::move(current);
    reference_index = p.b;
  }
  return ThreadSeconds() - start;
}

Result RunAgvcal(const std::string& name, const std::vector<TrueScan>& scans, const std::vector<Pair>& pairs,
                 const calib::ScanMatchOptions& options, int passes) {
  Result r;
  r.name = name;
  std::vector<double> times;
  for (int k = 0; k < passes; ++k) times.push_back(AgvcalPass(scans, pairs, options, k == 0 ? &r.errors : nullptr));
  r.pairs_per_s = pairs.size() / Median(times);
  return r;
}

#ifdef AGVCAL_WITH_CSM
// The de-skewed beams in CSM's polar form: each point's range and bearing (the bearing unwrapped
// next to the beam's nominal angle, so that the rays stay in order).
LDP ToCsm(const TrueScan& scan) {
  const int n = static_cast<int>(scan.beams.size());
  LDP ld = ld_alloc_new(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = scan.beams[i];
    const double nominal = scan.nominal_angle[i];
    ld->valid[i] = scan.has[i] ? 1 : 0;
    ld->readings[i] = scan.has[i] ? p.norm() : NAN;
    ld->theta[i] = scan.has[i] ? nominal + calib::WrapAngle(std::atan2(p.y(), p.x()) - nominal) : nominal;
    ld->cluster[i] = -1;
  }
  ld->min_theta = ld->theta[0];
  ld->max_theta = ld->theta[n - 1];
  return ld;
}

// CSM's PL-ICP with the settings of ROS's laser_scan_matcher (the usual PL-ICP configuration), the
// correspondence distance agvcal uses (0.3 m) and a tight convergence.
sm_params CsmParams() {
  sm_params p{};
  p.max_angular_correction_deg = 45.0;
  p.max_linear_correction = 0.5;
  p.max_iterations = 40;
  p.epsilon_xy = 1e-6;
  p.epsilon_theta = 1e-6;
  p.max_correspondence_dist = 0.3;
  p.sigma = 0.01;
  p.use_corr_tricks = 1;
  p.restart = 0;
  p.outliers_maxPerc = 0.9;
  p.outliers_adaptive_order = 0.7;
  p.outliers_adaptive_mult = 2.0;
  p.outliers_remove_doubles = 1;
  p.clustering_threshold = 0.25;
  p.orientation_neighbourhood = 20;
  p.do_alpha_test = 0;
  p.do_visibility_test = 0;
  p.use_point_to_line_distance = 1;
  p.use_ml_weights = 0;
  p.use_sigma_weights = 0;
  p.do_compute_covariance = 0;
  p.min_reading = 0.05;
  p.max_reading = 30.0;
  return p;
}

Result RunCsm(const std::vector<TrueScan>& scans, const std::vector<Pair>& pairs, int passes) {
  Result r;
  r.name = "CSM PL-ICP";
  sm_debug_write(0);
  std::vector<LDP> lds;
  for (const TrueScan& s : scans) lds.push_back(ToCsm(s));
  std::vector<double> times;
  for (int k = 0; k < passes; ++k) {
    const double start = ThreadSeconds();
    for (const Pair& pair : pairs) {
      sm_params params = CsmParams();
      params.laser_ref = lds[pair.a];
      params.laser_sens = lds[pair.b];
      params.first_guess[0] = pair.guess.x;
      params.first_guess[1] = pair.guess.y;
      params.first_guess[2] = pair.guess.theta;
      sm_result result{};
      sm_icp(&params, &result);
      if (k == 0) r.errors.Add(result.valid, {result.x[0], result.x[1], result.x[2]}, pair.truth);
    }
    times.push_back(ThreadSeconds() - start);
  }
  for (LDP ld : lds) ld_free(ld);
  r.pairs_per_s = pairs.size() / Median(times);
  return r;
}
#endif

calib::SimConfig Sim(const std::string& name, int beams, double fov) {
  calib::SimConfig sim = calib::LoadSimConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/sims/" + name);
  if (beams > 0) {
    sim.lidar2d.beams = beams;
    sim.lidar2d.fov_rad = fov;
  }
  return sim;
}

std::vector<Case> AllCases() {
  const double fov270 = 1.5 * M_PI;
  std::vector<Case> cases;
  cases.push_back({"diff540", "540 beams, 270°, differential, keyframe pairs", Sim("diff_robot.yaml", 540, fov270), "", false});
  cases.push_back({"tricycle540", "540 beams, 270°, tricycle, keyframe pairs", Sim("forklift.yaml", 540, fov270), "", false});
  Case demo{"demo720", "720 beams, forklift_demo consecutive", Sim("forklift.yaml", 0, 0), "", true};
  demo.log = std::string(AGVCAL_SOURCE_DIR) + "/logs/forklift_demo.log";
  demo.consecutive = true;
  cases.push_back(demo);
  return cases;
}

void Print(const Result& r, double csm_rate) {
  std::printf("  %-18s %7.0f pairs/s", r.name.c_str(), r.pairs_per_s);
  if (csm_rate > 0) std::printf(" (%4.2fx CSM)", r.pairs_per_s / csm_rate);
  std::printf("   translation rms %.3f / median %.3f mm, rotation rms %.2f mdeg, %d failed\n",
              1e3 * Rms(r.errors.translation), 1e3 * Median(r.errors.translation),
              1e3 * Rms(r.errors.rotation) * 180.0 / M_PI, r.errors.failed);
  if (!r.errors.chi2.empty()) {
    double sum = 0.0;
    for (double c : r.errors.chi2) sum += c;
    std::printf("  %-18s mean eᵀ cov⁻¹ e against the truth %.2f (3 if the reported covariance were exact)\n", "",
                sum / r.errors.chi2.size());
  }
}

int Run(int argc, char** argv) {
  int passes = 5;
  std::vector<std::string> wanted;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: agvcal-bench-scan-match-csm [--case diff540|tricycle540|demo720]... [--passes N]\n"
                   "agvcal's symmetric and one-way PL-ICP against CSM's (when built with AGVCAL_CSM_*),\n"
                   "same pairs and first guess, scans de-skewed with the true motion; pairs/s on one\n"
                   "core (thread CPU time, median of N passes) and the error against the truth.\n";
      return calib::kExitOk;
    }
    if (a == "--passes" && i + 1 < argc) {
      passes = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--case" && i + 1 < argc) {
      wanted.push_back(argv[++i]);
    } else {
      throw calib::InputError("command line", a, "unknown option");
    }
  }
#ifndef AGVCAL_WITH_CSM
  std::printf("(built without CSM: configure with -DAGVCAL_CSM_SOURCE=... -DAGVCAL_CSM_LIBRARY=...)\n");
#endif
  for (const Case& c : AllCases()) {
    if (!wanted.empty() && std::find(wanted.begin(), wanted.end(), c.name) == wanted.end()) continue;
    const Data data = Load(c);
    const calib::Pose2 mount{c.sim.true_lidar2d.x, c.sim.true_lidar2d.y, c.sim.true_lidar2d.yaw};
    std::vector<TrueScan> scans;
    for (const calib::LaserScan& s : data.scans) scans.push_back(Deskew(s, data.truth, mount));
    const std::vector<Pair> pairs = MakePairs(c, data, scans);
    std::printf("%s: %s, %zu pairs, %d beams\n", c.name.c_str(), c.description.c_str(), pairs.size(),
                data.scans.front().size());
    double csm_rate = 0.0;
#ifdef AGVCAL_WITH_CSM
    const Result csm = RunCsm(scans, pairs, passes);
    csm_rate = csm.pairs_per_s;
    Print(csm, 0.0);
#endif
    calib::ScanMatchOptions options;
    Print(RunAgvcal("agvcal symmetric", scans, pairs, options, passes), csm_rate);
    options.symmetric = false;
    Print(RunAgvcal("agvcal one-way", scans, pairs, options, passes), csm_rate);
  }
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-bench-scan-match-csm", Run, argc, argv); }
