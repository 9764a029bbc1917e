// `agvcal diagnose` on simulated recordings in which one effect of
// spec/effects.md is present but declared nowhere: named, sized within 20 %,
// the held-out residual lower where it acts; no effect on a clean control; an
// effect the trajectory does not excite is not named as anything else. The
// truth comes from the simulator config only; the diagnosis never sees it.

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <tuple>

#include <nlohmann/json.hpp>

#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/diagnose/diagnose.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/sim/simulator.h"
#include "sim_log.h"

namespace calib {
namespace {

using test_support::SimLog;
using test_support::Source;

SimConfig Sim(const std::string& name, uint64_t seed) {
  SimConfig config = LoadSimConfig(Source("config/sims/" + name + ".yaml"));
  config.seed = seed;
  config.imu.rate_hz = 0.0;
  return config;
}

DiagnoseReport DiagnoseSim(const SimConfig& config, const std::string& trajectory = "default") {
  const SimLog log(config, trajectory);
  const DiagnoseData data = ReadDiagnoseData(config.robot, log.path(), nullptr);
  return Diagnose(config.robot, data, DiagnoseOptions{}, log.path());
}

const FoundEffect* Find(const DiagnoseReport& r, const std::string& name) {
  for (const FoundEffect& e : r.effects)
    if (e.name == name) return &e;
  return nullptr;
}

std::string Named(const DiagnoseReport& r) {
  std::string s;
  for (const FoundEffect& e : r.effects) s += e.name + " ";
  return s.empty() ? "(none)" : s;
}

const CandidateOutcome& Outcome(const DiagnoseReport& r, const std::string& name) {
  for (const CandidateOutcome& c : r.candidates)
    if (c.name == name) return c;
  throw std::runtime_error("no candidate " + name);
}

// How much lower the held-out error is with the effect, by the effect's own measure:
// dead-reckoning drift over held-out windows, the error chained over the stretch of each
// held-out block where it acts most, or the residual per interval where it acts.
double HeldoutGain(const FoundEffect& e) {
  if (e.heldout_measure == "drift") return 1.0 - e.heldout_drift_after / e.heldout_drift_before;
  if (e.heldout_measure == "stretch") return 1.0 - e.heldout_stretch_after / e.heldout_stretch_before;
  return 1.0 - e.heldout_rms_after / e.heldout_rms_before;
}

// The suite's parameter target: within 20 % (or 2 sigma) of the truth.
::testing::AssertionResult NearTruth(const std::string& name, const ParamEstimate& p, double truth) {
  if (std::abs(p.value - truth) <= 0.2 * std::abs(truth) || std::abs(p.value - truth) <= 2 * p.std)
    return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << name << " " << p.value << " +- " << p.std << " truth " << truth;
}

// One hidden effect: exactly it is named, its parameter within 20 % (or 2 sigma) of the
// truth, and the held-out error at least 20 % lower.
void ExpectFound(const DiagnoseReport& r, const std::string& name, const std::string& key, double truth) {
  ASSERT_EQ(r.effects.size(), 1u) << "named: " << Named(r) << "\n" << DiagnoseSummaryText(r);
  const FoundEffect* e = Find(r, name);
  ASSERT_NE(e, nullptr) << "named: " << Named(r);
  EXPECT_TRUE(NearTruth(name, e->params.at(key), truth));
  EXPECT_LT(e->p_adjusted, 0.01);
  EXPECT_GE(HeldoutGain(*e), 0.2) << DiagnoseSummaryText(r);
  EXPECT_FALSE(e->where.empty());
  EXPECT_EQ(r.verdict, "effects_found");
}

// Issue 16: a 5 ms offset on the differential drive's default trajectory was named
// longitudinal_slip 0.0057: under the baseline alone the turn starts and stops it disturbs were
// set aside as outliers (39 intervals), and the offset fitted on what was left did not pay in BIC.
TEST(Diagnose, FiveMillisecondOffsetIsNamedAloneNotAsSlip) {
  SimConfig c = Sim("diff_robot", 1);
  c.effects.time_offset_s = 0.005;
  const SimLog log(c);
  const DiagnoseReport r = DiagnoseLog(c.robot, log.path(), DiagnoseOptions{});
  ASSERT_EQ(r.effects.size(), 1u) << "named: " << Named(r) << "\n" << DiagnoseSummaryText(r);
  const FoundEffect* e = Find(r, "time_offset");
  ASSERT_NE(e, nullptr) << "named: " << Named(r);
  EXPECT_NEAR(e->params.at("offset_s").value, 0.005, 0.0005);
}

// `solve --time-offset` and `diagnose` on one simulated differential-drive recording with a time
// offset: each within 10 % of the truth and of each other, diagnose naming the offset alone.
DiagnoseReport ExpectOffsetBySolveAndDiagnose(double offset_s) {
  SimConfig c = Sim("diff_robot", 1);
  c.effects.time_offset_s = offset_s;
  const SimLog log(c);
  SolveLogOptions so;
  so.calibration.estimate_time_offset = true;
  const CalibrationResult solved = SolveLog(c.robot, log.path(), so);
  EXPECT_TRUE(solved.time_offset.has_value());
  const double by_solve = solved.time_offset ? solved.time_offset->value : 0.0;
  EXPECT_NEAR(by_solve, offset_s, 0.1 * offset_s);
  const DiagnoseReport r = DiagnoseLog(c.robot, log.path(), DiagnoseOptions{});
  EXPECT_EQ(Named(r), "time_offset ") << DiagnoseSummaryText(r);
  if (const FoundEffect* e = Find(r, "time_offset")) {
    const double by_diagnose = e->params.at("offset_s").value;
    EXPECT_NEAR(by_diagnose, offset_s, 0.1 * offset_s);
    EXPECT_NEAR(by_diagnose, by_solve, 0.1 * std::abs(by_solve));
  }
  return r;
}

// Issue 16: offsets of 10-50 ms, where real robots are, fell in a hole: `solve --time-offset`
// found 0.65 ms (100 outliers) for 18 ms on this recording, while diagnose found 18 ms. Both
// now start from the one global search (calibrate/time_offset_search.h): each within 10 % of
// the truth, and within 10 % of each other.
TEST(Diagnose, EighteenMillisecondOffsetFoundByDiagnoseAndSolveAlike) {
  const DiagnoseReport r = ExpectOffsetBySolveAndDiagnose(0.018);
  // The share set aside is reported with its correlation to the motion.
  EXPECT_LT(r.outlier_share, 0.05);
}

// Issue 16: `solve --time-offset` found 1.30 ms for 1 ms on this recording (diagnose 1.03): the
// matcher places a de-skewed scan at its mean beam time (25 ms after its stamp), and the
// nominal de-skew model's turn-rate error (1.3 %) over that lead read as +0.3 ms of offset.
// Solve now matches again with the calibrated model on the wheel clock, as diagnose does.
TEST(Diagnose, OneMillisecondOffsetFoundBySolveAndDiagnoseAlike) { ExpectOffsetBySolveAndDiagnose(0.001); }

// Issue 16: Mines exp2 with every scan stamp +120 ms kept a failed match (0.11 rad of yaw in
// 0.09 s) that the model with the offset put at 556 times its noise scale: the candidates' own
// fits without the offset, each gated at its own robust scale, which the unmodelled offset
// inflates the more the larger it is, excused it, and it pulled the offset 26 ms. A model's scale
// is now at most the chosen model's. Here one scan match of a simulated recording with a 0.2 s
// offset is made to fail by 30 sigma in yaw (chi-square 900: 270 times the offset model's robust
// scale, 3 times that of the fits without the offset): set aside, the offset found.
TEST(Diagnose, FailedMatchBesideALargeOffsetIsSetAside) {
  SimConfig c = Sim("diff_robot", 1);
  c.effects.time_offset_s = 0.2;
  const SimLog log(c);
  DiagnoseData data = ReadDiagnoseData(c.robot, log.path(), nullptr);
  // The first valid match after the middle of the recording driven straight (where the
  // offset leaves the yaw alone, so the error added is what each model sees).
  std::size_t k = data.motions.size() / 2;
  while (k < data.motions.size() && !(data.motions[k].valid && !data.motions[k].degenerate &&
                                      std::abs(data.motions[k].delta.theta) < 0.002))
    ++k;
  ASSERT_LT(k, data.motions.size());
  SensorMotion& failed = data.motions[k];
  failed.delta.theta += 30.0 * std::sqrt(failed.covariance(2, 2));
  const DiagnoseReport r = Diagnose(c.robot, data, DiagnoseOptions{}, log.path());
  const auto it = std::find_if(r.intervals.begin(), r.intervals.end(), [&](const DiagnosedInterval& d) {
    return d.utime_start == failed.utime_start && d.utime_end == failed.utime_end;
  });
  ASSERT_NE(it, r.intervals.end());
  EXPECT_TRUE(it->outlier) << "residual before (x, y, yaw) " << it->before.transpose() << "\n" << DiagnoseSummaryText(r);
  const FoundEffect* e = Find(r, "time_offset");
  ASSERT_NE(e, nullptr) << "named: " << Named(r);
  EXPECT_NEAR(e->params.at("offset_s").value, 0.2, 0.02);
}

// A time offset and a longitudinal slip in one simulated recording: exactly the two are named,
// each within 20 % (or 2 sigma) of its truth.
DiagnoseReport ExpectOffsetAndSlip(const std::string& drive, uint64_t seed, double offset_s, double slip) {
  SimConfig c = Sim(drive, seed);
  c.effects.time_offset_s = offset_s;
  c.effects.longitudinal_slip_per_accel = slip;
  const DiagnoseReport r = DiagnoseSim(c);
  EXPECT_EQ(r.effects.size(), 2u) << "named: " << Named(r) << "\n" << DiagnoseSummaryText(r);
  for (const auto& [name, key, truth] : {std::tuple<std::string, std::string, double>{"time_offset", "offset_s", offset_s},
                                         {"longitudinal_slip", "slip_per_accel", slip}}) {
    const FoundEffect* e = Find(r, name);
    EXPECT_NE(e, nullptr) << name;
    if (e) EXPECT_TRUE(NearTruth(name, e->params.at(key), truth));
  }
  return r;
}

// Issue 16: beside a 50 ms offset the forklift's slip of 0.004 s^2/m was not declared. Every
// test divided its chi-square by the baseline's variance factor, and the baseline has no offset:
// 707 here against 1.3 once the offset is modelled, so the slip (Wald p 3e-39 given the offset)
// never paid for its parameter in BIC (delta BIC +6.1). A candidate added to a model is now
// judged at that model's noise scale.
TEST(Diagnose, SlipBesideAFiftyMillisecondOffsetIsDeclared) {
  const DiagnoseReport r = ExpectOffsetAndSlip("forklift", 1, 0.05, 0.004);
  const FoundEffect* offset = Find(r, "time_offset");
  const FoundEffect* slip = Find(r, "longitudinal_slip");
  ASSERT_TRUE(offset && slip) << "named: " << Named(r);
  EXPECT_NEAR(offset->params.at("offset_s").value, 0.05, 0.005);
  EXPECT_LT(slip->delta_bic, 0.0);
}

// A time offset beyond the search's first bound (0.5 s; a real recording's own offset adds to
// the one a user injects): the search and fit at the bound are repeated over twice the range.
// Before, `solve --time-offset` stopped at 0.5 s.
TEST(Diagnose, OffsetBeyondTheFirstSearchBoundIsFound) {
  SimConfig c = Sim("diff_robot", 1);
  c.effects.time_offset_s = 0.6;
  const SimLog log(c);
  SolveLogOptions so;
  so.calibration.estimate_time_offset = true;
  const CalibrationResult solved = SolveLog(c.robot, log.path(), so);
  ASSERT_TRUE(solved.time_offset.has_value());
  EXPECT_NEAR(solved.time_offset->value, 0.6, 0.06);
  EXPECT_EQ(solved.time_offset_bound_s, 1.0);
}

// A fit that stops at its iteration limit says so: with one iteration per fit the diagnosis's fits
// cannot converge, and the report names them (REPORT.json `warnings`, summary.txt); with the
// default limit there is none.
TEST(Diagnose, FitsThatDoNotConvergeAreReportedAsSuch) {
  const SimConfig config = Sim("diff_robot", 4);
  const SimLog log(config, "default");
  const DiagnoseData data = ReadDiagnoseData(config.robot, log.path(), nullptr);
  DiagnoseOptions limited;
  limited.max_iterations = 1;
  const DiagnoseReport r = Diagnose(config.robot, data, limited, log.path());
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings[0].find("stopped short of convergence"), std::string::npos) << r.warnings[0];
  EXPECT_TRUE(nlohmann::json::parse(DiagnoseReportJson(r)).contains("warnings"));
  EXPECT_NE(DiagnoseSummaryText(r).find("warning: the fit of"), std::string::npos);

  const DiagnoseReport converged = Diagnose(config.robot, data, DiagnoseOptions{}, log.path());
  EXPECT_TRUE(converged.warnings.empty()) << converged.warnings[0];
  EXPECT_FALSE(nlohmann::json::parse(DiagnoseReportJson(converged)).contains("warnings"));
}

TEST(Diagnose, CleanForkliftHasNoEffect) {
  const DiagnoseReport r = DiagnoseSim(Sim("forklift", 11));
  EXPECT_EQ(r.verdict, "no_significant_effect") << DiagnoseSummaryText(r);
  EXPECT_TRUE(r.effects.empty());
  // The commander never steers faster than the robot's limit: a slower limit could show,
  // a faster one cannot.
  EXPECT_EQ(Outcome(r, "steering_rate_limit").status, CandidateStatus::kNotIdentifiable);
  EXPECT_GT(r.fit_intervals, 100);
  EXPECT_GT(r.heldout_intervals, 100);
}

// Issue 16: a 0.62 rad/s steering rate limit on a forklift whose commander ramps the steering at
// 1.0 rad/s (41.7 Hz held commands, 4.2 ms physics step, 78 Hz encoders; randomized suite forklift
// seed 1132) was
// not identifiable at 50 rad/s: the golden section over log(rate) walked into the flat part of
// the cost (a limit above every commanded rate changes nothing). A grid comes first now. And on
// a control whose commands ramp on a 7.3 ms tick (47.1 Hz; seed 1006) the grid found a "limit"
// of 0.999 rad/s, the commander's own ramp: a limit is declared only below that ramp less the
// share the command stamps' timing leaves uncertain.
TEST(Diagnose, SteeringRateLimitBelowTheCommandsOwnRamp) {
  SimConfig c = Sim("forklift", 1132);
  c.physics_rate_hz = 1.0 / 0.0042;
  c.command_rate_hz = 41.7;
  c.wheels.rate_hz = 78.0;
  c.wheels.ticks_per_rev = 8562;
  c.effects.steering_rate_limit_rad_s = 0.62;
  ExpectFound(DiagnoseSim(c), "steering_rate_limit", "rate_rad_s", 0.62);
  SimConfig k = Sim("forklift", 1006);
  k.physics_rate_hz = 1.0 / 0.0073;
  k.command_rate_hz = 47.1;
  k.command_between = CommandsBetween::kRamp;
  const DiagnoseReport r = DiagnoseSim(k);
  EXPECT_EQ(Find(r, "steering_rate_limit"), nullptr) << DiagnoseSummaryText(r);
  const CandidateOutcome& o = Outcome(r, "steering_rate_limit");
  EXPECT_EQ(o.status, CandidateStatus::kNotIdentifiable);
  EXPECT_LT(o.detectable, 1.0) << "the commander ramps at 1.0 rad/s";
  EXPECT_GT(o.detectable, 0.7);
}

// Issue 16: a 0.092 rad/s steering rate limit on a forklift whose controller ramps its
// setpoints on an 8.1 ms tick (32.5 Hz commands: four ticks a ramp, 122 Hz encoders; randomized
// suite forklift seed 1087) was named with a 17.5 ms drive lag beside it. The held profile won
// by 1.8 in log-likelihood: a held setpoint behind a lag of half a command period fits such a
// coarse ramp about as well, and with the ramped setpoints the lag is within the stamps' tick.
// When the data do not tell the profiles apart, an actuation effect must stand under both.
TEST(Diagnose, NoDriveLagWhereTheDataDoNotTellHeldFromRampedSetpoints) {
  SimConfig c = Sim("forklift", 1087);
  c.physics_rate_hz = 1.0 / 0.0081;
  c.command_rate_hz = 32.5;
  c.command_between = CommandsBetween::kRamp;
  c.wheels.rate_hz = 122.0;
  c.wheels.ticks_per_rev = 1433;
  c.effects.steering_rate_limit_rad_s = 0.092;
  const DiagnoseReport r = DiagnoseSim(c);
  ExpectFound(r, "steering_rate_limit", "rate_rad_s", 0.092);
  EXPECT_EQ(Find(r, "drive_lag"), nullptr) << DiagnoseSummaryText(r);
}

TEST(Diagnose, SteeringBacklashOnForklift) {
  SimConfig c = Sim("forklift", 12);
  c.effects.steering_backlash_width_rad = 0.002;  // 0.11 deg: 3x the steering reading's noise
  ExpectFound(DiagnoseSim(c), "steering_backlash", "width_rad", 0.002);
}

TEST(Diagnose, LongitudinalSlipOnDifferentialDrive) {
  SimConfig c = Sim("diff_robot", 13);
  c.effects.longitudinal_slip_per_accel = 0.01;
  ExpectFound(DiagnoseSim(c), "longitudinal_slip", "slip_per_accel", 0.01);
}

// The scan matcher de-skews each scan with odometry that knows no eccentric wheel, so a match
// carries the wheel's error shifted by the scan's mean beam time (25 ms here, 0.17 rad of wheel
// turn at 0.5 m/s). Modelled (DiagnoseData::deskew_lead_s), the phase comes out right; without,
// this recording gave 0.21 +- 0.02 for 0.4.
TEST(Diagnose, EccentricWheelPhaseThroughDeskewedScans) {
  SimConfig c = Sim("diff_robot", 3000);
  c.effects.eccentricity_amplitude = 0.0025;
  c.effects.eccentricity_phase = 0.4;
  c.effects.eccentricity_wheel = "left";
  const DiagnoseReport r = DiagnoseSim(c);
  ExpectFound(r, "wheel_eccentricity", "amplitude", 0.0025);
  const FoundEffect* e = Find(r, "wheel_eccentricity");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->wheel, "left");
  const ParamEstimate& phase = e->params.at("phase");
  EXPECT_NEAR(phase.value, 0.4, 3 * phase.std + 0.01);
  EXPECT_NEAR(e->params.at("amplitude").value, 0.0025, 0.05 * 0.0025);
}

// A lateral slip at the concealed-effect suite's size (twice the smallest detectable):
// per interval it hides in the scan matcher's noise, over 2 s of dead reckoning it does not.
TEST(Diagnose, SmallLateralSlipShowsInHeldoutDrift) {
  SimConfig c = Sim("diff_robot", 21);
  c.effects.lateral_slip_gain = 0.0069;
  const DiagnoseReport r = DiagnoseSim(c);
  ExpectFound(r, "lateral_slip", "gain", 0.0069);
  const FoundEffect* e = Find(r, "lateral_slip");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->heldout_measure, "drift");
  EXPECT_EQ(e->drift_component, "translation");
  EXPECT_GE(e->drift_windows, 10);
  EXPECT_GT(HeldoutGain(*e), 1.0 - e->heldout_rms_all_after / e->heldout_rms_all_before)
      << "chained, the slip stands out more than per interval";
}

// A time offset at the concealed-effect suite's size: per interval it is the offset times the
// change of turn rate over a keyframe's half second, below the scan matcher's noise; over the
// stretch of a held-out block from its lowest to its highest turn rate the chained error is
// the offset times the whole change, while the registration error stays that of two scans.
TEST(Diagnose, SmallTimeOffsetShowsOverHeldoutStretches) {
  SimConfig c = Sim("diff_robot", 32);
  c.effects.time_offset_s = 0.00023;
  const DiagnoseReport r = DiagnoseSim(c);
  ExpectFound(r, "time_offset", "offset_s", 0.00023);
  const FoundEffect* e = Find(r, "time_offset");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->heldout_measure, "stretch");
  EXPECT_EQ(e->component, "yaw");
  EXPECT_GE(e->stretches.size(), 5u);
  EXPECT_GT(HeldoutGain(*e), 1.0 - e->heldout_rms_after / e->heldout_rms_before)
      << "over a stretch the offset stands out more than per interval";
}

TEST(Diagnose, DriveLagInTheActuationLayer) {
  SimConfig c = Sim("forklift", 14);
  c.effects.drive_lag_tau_s = 0.05;
  const DiagnoseReport r = DiagnoseSim(c);
  ExpectFound(r, "drive_lag", "tau_s", 0.05);
  EXPECT_EQ(Find(r, "drive_lag")->layer, "actuation");
}

// A controller that ramps the setpoint between DRIVE_CMD messages (commands.between: ramp, at
// 33 Hz, out of step with the 100 Hz encoders): a model that holds each command came out
// 0.087-0.092 s for 0.12 s on such recordings; the diagnosis decides hold or ramp from the data.
TEST(Diagnose, DriveLagWhenTheSetpointRampsBetweenCommands) {
  SimConfig c = Sim("diff_robot", 21);
  c.command_between = CommandsBetween::kRamp;
  c.command_rate_hz = 33.0;
  c.effects.drive_lag_tau_s = 0.12;
  const DiagnoseReport r = DiagnoseSim(c);
  const FoundEffect* e = Find(r, "drive_lag");
  ASSERT_NE(e, nullptr) << "named: " << Named(r);
  EXPECT_NEAR(e->params.at("tau_s").value, 0.12, 0.012);
  EXPECT_EQ(r.effects.size(), 1u) << Named(r);
  EXPECT_NE(std::find_if(r.notes.begin(), r.notes.end(),
                         [](const std::string& n) { return n.find("ramps between DRIVE_CMD") != std::string::npos; }),
            r.notes.end());
  // And the same controller without a lag: no drive lag (a held model would see one).
  c.effects.drive_lag_tau_s = 0.0;
  const DiagnoseReport clean = DiagnoseSim(c);
  EXPECT_EQ(Find(clean, "drive_lag"), nullptr) << DiagnoseSummaryText(clean);
}

// DRIVE_CMD messages that are samples of a setpoint changing continuously (commands.between:
// continuous: the controller takes the commander's setpoint every physics step): a model that
// holds each command read a 0.12 s lag half a command period short (0.092 s at 20 Hz), one that
// ramps to it a whole period short. Interpolated between the samples, chosen from the data,
// the lag is within 5 % at 10 and 50 Hz; and the robot file can state the profile.
TEST(Diagnose, DriveLagWhenTheCommandsSampleAContinuousSetpoint) {
  for (const double rate : {10.0, 50.0}) {
    SimConfig c = Sim("diff_robot", 22);
    c.command_between = CommandsBetween::kContinuous;
    c.command_rate_hz = rate;
    c.effects.drive_lag_tau_s = 0.12;
    const SimLog log(c, "default");
    const DiagnoseData data = ReadDiagnoseData(c.robot, log.path(), nullptr);
    const DiagnoseReport r = Diagnose(c.robot, data, DiagnoseOptions{}, log.path());
    const FoundEffect* e = Find(r, "drive_lag");
    ASSERT_NE(e, nullptr) << rate << " Hz, named: " << Named(r);
    EXPECT_NEAR(e->params.at("tau_s").value, 0.12, 0.006) << rate << " Hz\n" << DiagnoseSummaryText(r);
    if (rate != 10.0) continue;
    RobotDescription stated = c.robot;
    stated.commands_between = CommandsBetween::kContinuous;
    const DiagnoseReport told = Diagnose(stated, data, DiagnoseOptions{}, log.path());
    ASSERT_NE(Find(told, "drive_lag"), nullptr) << Named(told);
    EXPECT_NEAR(Find(told, "drive_lag")->params.at("tau_s").value, 0.12, 0.006);
    EXPECT_NE(std::find_if(told.notes.begin(), told.notes.end(),
                           [](const std::string& n) { return n.find("stated in the robot file") != std::string::npos; }),
              told.notes.end());
  }
}

// A large steering backlash on a forklift whose controller ramps its setpoint between commands
// on a 5 ms tick (24.8 Hz commands, so the stamps are 40 or 45 ms apart): the ramp toward each
// command starts half a tick behind the continuous one and read as a 1.3 ms drive lag, named
// beside the backlash (issue 16; randomized suite forklift seed 12). A lag within the tick of
// the command stamps is not told from the data.
TEST(Diagnose, NoDriveLagBesideABacklashOnARampingTick) {
  SimConfig c = Sim("forklift", 12);
  c.physics_rate_hz = 200.0;
  c.command_between = CommandsBetween::kRamp;
  c.command_rate_hz = 24.8;
  c.effects.steering_backlash_width_rad = 0.0034;
  const DiagnoseReport r = DiagnoseSim(c);
  ExpectFound(r, "steering_backlash", "width_rad", 0.0034);
  const CandidateOutcome& lag = Outcome(r, "drive_lag");
  EXPECT_NE(lag.status, CandidateStatus::kFound);
  EXPECT_GE(lag.detectable, 0.0025) << "half the 5 ms tick";
}

// A wet patch: longitudinal slip 0.08 s^2/m inside a 5 x 3 m box of the floor, none outside.
// Named from the regions of the route, with its box (the route starts at the world origin
// heading along x, so the odometry frame is the world's); the box must cover at least half of
// the patch (intersection over the patch's area), on the part of the floor the route crosses.
TEST(Diagnose, LongitudinalSlipConfinedToAWetPatch) {
  SimConfig c = Sim("diff_robot", 1);
  c.effects.longitudinal_slip_per_accel = 0.08;
  c.effects.longitudinal_slip_region = std::array<double, 4>{-2.0, -3.0, 3.0, 0.0};
  const DiagnoseReport r = DiagnoseSim(c);
  const FoundEffect* e = Find(r, "longitudinal_slip");
  ASSERT_NE(e, nullptr) << "named: " << Named(r) << "\n" << DiagnoseSummaryText(r);
  ASSERT_TRUE(e->region.has_value());
  const auto& b = *e->region;
  const double ix = std::max(0.0, std::min(b[2], 3.0) - std::max(b[0], -2.0));
  const double iy = std::max(0.0, std::min(b[3], 0.0) - std::max(b[1], -3.0));
  EXPECT_GE(ix * iy / 15.0, 0.5) << "region " << b[0] << " " << b[1] << " " << b[2] << " " << b[3];
  EXPECT_TRUE(NearTruth("slip_per_accel", e->params.at("slip_per_accel"), 0.08));
  EXPECT_LT(e->p_adjusted, 0.01);
  EXPECT_EQ(r.effects.size(), 1u) << Named(r);
  const std::string json = DiagnoseReportJson(r);
  EXPECT_NE(json.find("\"region\""), std::string::npos);
}

TEST(Diagnose, ScanDistortionWhenScansDeclareNoTiming) {
  SimConfig c = Sim("forklift", 15);
  c.effects.scan_distortion_period_s = 0.05;
  ExpectFound(DiagnoseSim(c), "scan_distortion", "scan_period_s", 0.05);
}

TEST(Diagnose, UnexcitedSteeringLagIsNotNamedAsSomethingElse) {
  SimConfig c = Sim("forklift", 16);
  c.effects.steering_lag_tau_s = 0.1;  // steering turns only at standstill in this trajectory
  const DiagnoseReport r = DiagnoseSim(c);
  EXPECT_TRUE(r.effects.empty()) << "named: " << Named(r);
  // Steering turns only at standstill (and settles for 0.5 s): this recording could not
  // have detected a lag of the size present, and says so.
  const CandidateOutcome& lag = Outcome(r, "steering_lag");
  EXPECT_NE(lag.status, CandidateStatus::kFound);
  EXPECT_GT(lag.detectable, 0.1);
}

// The dual-steer AGV's noisy steering readings (0.2 mrad) with a few starts while the
// steering still settles: a steering lag's Wald statistic was 114 here (a robust variance
// from a handful of intervals) while it lowered the chi-square by 1.2. Nothing is named;
// the lag is left with the reason.
TEST(Diagnose, NoisySteeringReadingsAreNotASteeringLag) {
  const DiagnoseReport r = DiagnoseSim(Sim("dual_steer_agv", 3009));
  EXPECT_TRUE(r.effects.empty()) << "named: " << Named(r) << "\n" << DiagnoseSummaryText(r);
  EXPECT_NE(Outcome(r, "steering_lag").status, CandidateStatus::kFound);
}

// A time offset and a longitudinal slip on the dual-steer AGV at the concealed-effect
// suite's sizes: each alone hides in the other's residual (neither significant in its
// single fit), the two fitted together stand, each given the other.
TEST(Diagnose, TimeOffsetAndSlipThatHideEachOther) { ExpectOffsetAndSlip("dual_steer_agv", 3000, 0.00062, 0.0023); }

// A slalom: the forklift drives at constant speed while steering sinusoidally (the
// commander's trajectories steer only at standstill), commands recorded on DRIVE_CMD.
class SlalomLog {
 public:
  explicit SlalomLog(const SimConfig& config)
      : path_(testing::TempDir() + "diagnose_slalom_" + std::to_string(counter_++) + ".log") {
    LogWriter writer(path_);
    Simulator sim(config);
    const double radius = config.robot.param("drive_radius"), offset = config.robot.param("steer_offset");
    int64_t seq = 0;
    for (double t = 0; t < 150.0; t += 0.05) {
      DriveCommand cmd;
      // Between wheel samples: the simulated steering jumps to each command at once, and
      // interpolating a jump that falls right after a sample would make the reading look late.
      cmd.utime = config.start_utime + int64_t(t * 1e6) + 5000;
      cmd.mode = DriveMode::kWheels;
      const double in = std::fmod(t, 50.0);  // 45 s runs with 2 s ramps, then 5 s at rest
      const double speed = 0.4 * std::clamp(std::min(in, 45.0 - in) / 2.0, 0.0, 1.0);
      const double phase = 2 * M_PI * (0.15 + 0.1 * std::floor(t / 50.0)) * t;  // 0.15, 0.25, 0.35 Hz
      cmd.wheels.speed = {speed / radius};
      cmd.wheels.steer = {offset + 0.35 * std::sin(phase)};
      cmd.timeout_s = 0.5;
      sim.AdvanceTo(cmd.utime, &writer);
      writer.Publish(kDriveCmdChannel, cmd.utime, Encode(ToMessage(cmd, config.robot, seq++)));
      sim.ApplyCommand(cmd);
    }
    sim.AdvanceTo(config.start_utime + int64_t(151e6), &writer);
    writer.Close();
  }
  ~SlalomLog() { std::remove(path_.c_str()); }
  const std::string& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  std::string path_;
};

DiagnoseReport DiagnoseSlalom(const SimConfig& c) {
  const SlalomLog log(c);
  const DiagnoseData data = ReadDiagnoseData(c.robot, log.path(), nullptr);
  return Diagnose(c.robot, data, DiagnoseOptions{}, log.path());
}

TEST(Diagnose, SteeringLagWhenSteeringWhileDriving) {
  SimConfig c = Sim("forklift", 18);
  c.effects.steering_lag_tau_s = 0.05;
  const DiagnoseReport r = DiagnoseSlalom(c);
  ExpectFound(r, "steering_lag", "tau_s", 0.05);
  // Its look-alike, a time offset, was tested against it and not named.
  EXPECT_NE(Outcome(r, "time_offset").status, CandidateStatus::kFound);
}

TEST(Diagnose, TimeOffsetNotTakenForSteeringLag) {
  SimConfig c = Sim("forklift", 19);
  c.effects.time_offset_s = 0.01;
  const DiagnoseReport r = DiagnoseSlalom(c);
  ExpectFound(r, "time_offset", "offset_s", 0.01);
  EXPECT_NE(Outcome(r, "steering_lag").status, CandidateStatus::kFound);
}

// Issue 16: a 90 ms lag fitted from zero stopped at 48 ms and was rejected by the BIC gate with
// 11 % of the intervals set aside; the lag now starts from the best of a grid over its range.
TEST(Diagnose, LargeSteeringLagIsFoundAtItsSize) {
  SimConfig c = Sim("forklift", 18);
  c.effects.steering_lag_tau_s = 0.09;
  const DiagnoseReport r = DiagnoseSlalom(c);
  ExpectFound(r, "steering_lag", "tau_s", 0.09);
  EXPECT_NEAR(Find(r, "steering_lag")->params.at("tau_s").value, 0.09, 0.009);
}

TEST(Diagnose, CleanSlalomHasNoEffect) {
  const SimConfig c = Sim("forklift", 20);
  const DiagnoseReport r = DiagnoseSlalom(c);
  EXPECT_TRUE(r.effects.empty()) << "named: " << Named(r) << "\n" << DiagnoseSummaryText(r);
}

TEST(Diagnose, ReportFilesAndSimConfig) {
  SimConfig c = Sim("forklift", 17);
  c.effects.steering_backlash_width_rad = 0.003;
  const SimLog log(c);
  const DiagnoseData data = ReadDiagnoseData(c.robot, log.path(), nullptr);
  const DiagnoseReport r = Diagnose(c.robot, data, DiagnoseOptions{}, log.path());
  const nlohmann::json j = nlohmann::json::parse(DiagnoseReportJson(r));
  EXPECT_EQ(j["verdict"], "effects_found");
  ASSERT_EQ(j["effects"].size(), 1u);
  EXPECT_EQ(j["effects"][0]["name"], "steering_backlash");
  for (const char* k : {"params", "evidence", "heldout_rms_before", "heldout_rms_after", "where"})
    EXPECT_TRUE(j["effects"][0].contains(k)) << k;
  EXPECT_TRUE(j["effects"][0]["evidence"].contains("delta_bic"));
  EXPECT_TRUE(j["effects"][0]["evidence"].contains("p_value"));
  EXPECT_TRUE(j["unexplained"].is_array());
  const std::string dir = testing::TempDir() + "diagnose_test_report";
  WriteDiagnoseReportDir(r, dir);
  EXPECT_EQ(j["effects"][0]["heldout_stretch"]["per_stretch"].size(), r.effects[0].stretches.size());
  EXPECT_GE(r.effects[0].stretches.size(), 5u);
  for (const char* f : {"summary.txt", "index.html", "residual_time.svg", "route.svg", "signature_1_steering_backlash.svg",
                        "heldout_1_steering_backlash.svg"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/" + f)) << f;
  // Held-out stretches and the effect's own spans have legends of their own; the page has the
  // candidates and the calibration as tables; spans also count seconds from the time origin.
  auto read = [&](const char* f) {
    std::ifstream in(dir + "/" + f);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string heldout = read("heldout_1_steering_backlash.svg"), residual = read("residual_time.svg");
  EXPECT_NE(heldout.find("held-out stretch"), std::string::npos);
  EXPECT_EQ(heldout.find("stands out"), std::string::npos);
  EXPECT_NE(residual.find("an effect stands out"), std::string::npos);
  EXPECT_NE(residual.find("time since the recording's first message (s)"), std::string::npos);
  const std::string page = read("index.html");
  EXPECT_EQ(page.find("<pre>"), std::string::npos);
  for (const char* text : {"Every candidate of the catalogue", "<td>steering_backlash</td>", "<td>found</td>",
                           "baseline ± 1σ", "refitted with the effects ± 1σ", "<td>wheelbase</td>"})
    EXPECT_NE(page.find(text), std::string::npos) << text;
  const int64_t origin = j["time_origin_utime"];
  const nlohmann::json& span = j["effects"][0]["where"][0];
  EXPECT_NEAR(span["t_start_s"].get<double>(), (span["utime_start"].get<int64_t>() - origin) * 1e-6, 1e-3);
  std::filesystem::remove_all(dir);
  // The written sim config reproduces the robot: truth = refitted calibration, effect = found.
  const std::string yaml = SimConfigYaml(r, Source("config/robots/forklift.yaml"));
  const SimConfig back = ParseSimConfig(yaml, "written", Source("config/sims"));
  EXPECT_NEAR(back.effects.steering_backlash_width_rad, 0.003, 0.0006);
  EXPECT_NEAR(back.true_params.at("wheelbase"), c.true_params.at("wheelbase"), 0.01);
}

TEST(Diagnose, MissingWheelsIsAnInputError) {
  const std::string path = testing::TempDir() + "diagnose_test_empty.log";
  {
    LogWriter writer(path);
    writer.Close();
  }
  EXPECT_THROW(ReadDiagnoseData(Sim("forklift", 1).robot, path, nullptr), InputError);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace calib
