// Physics outside spec/effects.md: the simulator plants it through a sim config's `terms:`
// block; the diagnosis must not call such a recording explained within its noise, must model a
// term of its library (core/physics_terms.h) with its channel, regressor and size, and must leave
// a control alone. The truth comes from the simulator config only.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/core/errors.h"
#include "calib/diagnose/diagnose.h"
#include "calib/sim/simulator.h"
#include "diagnose/discover_fit.h"
#include "sim_log.h"

namespace calib {
namespace {

using test_support::SimLog;
using test_support::Source;

SimConfig Sim(const std::string& name, uint64_t seed, const std::vector<PhysicsTerm>& terms) {
  SimConfig config = LoadSimConfig(Source("config/sims/" + name + ".yaml"));
  config.seed = seed;
  config.imu.rate_hz = 0.0;
  config.terms = terms;
  return config;
}

DiagnoseReport DiagnoseSim(const SimConfig& config) {
  const SimLog log(config);
  const DiagnoseData data = ReadDiagnoseData(config.robot, log.path(), nullptr);
  return Diagnose(config.robot, data, DiagnoseOptions{}, log.path());
}

std::string DiscoveredText(const DiagnoseReport& r) {
  std::string s;
  for (const calib::Discovered& d : r.discovered)
    s += d.channel + " by " + d.terms[0].regressor + " = " + std::to_string(d.terms[0].coefficient.value) + " ± " +
         std::to_string(d.terms[0].coefficient.std) + "; ";
  return s.empty() ? "(none)" : s;
}

TEST(SimTerms, ConfigTakesATermsBlockAndNamesAnUnknownRegressor) {
  const std::string base = "robot: " + Source("config/robots/diff_robot.yaml") + "\n";
  const SimConfig c = ParseSimConfig(
      base + "terms:\n  - {channel: yaw_rate, regressor: \"turn_rate*|turn_rate|\", coefficient: -0.3}\n", "t.yaml", ".");
  ASSERT_EQ(c.terms.size(), 1u);
  EXPECT_EQ(c.terms[0].channel, TermChannel::kYawRate);
  EXPECT_EQ(c.terms[0].regressor, "turn_rate*|turn_rate|");
  EXPECT_DOUBLE_EQ(c.terms[0].coefficient, -0.3);
  try {
    ParseSimConfig(base + "terms:\n  - {channel: yaw_rate, regressor: omega, coefficient: 1}\n", "t.yaml", ".");
    FAIL() << "an unknown regressor was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("t.yaml"), std::string::npos) << what;
    EXPECT_NE(what.find("line 3"), std::string::npos) << what;
    EXPECT_NE(what.find("unknown regressor 'omega'"), std::string::npos) << what;
  }
  EXPECT_THROW(ParseSimConfig(base + "terms:\n  - {channel: steer, regressor: time, coefficient: 1}\n", "t.yaml", "."),
               InputError);  // a differential drive has no steering
}

// The body turns less than its wheels say, the more so the faster it turns (scrub): out of the
// catalogue, modelled as a yaw-rate term by turn_rate*|turn_rate|, its size within 20 % or 2σ.
TEST(Discover, ScrubIsModelledAsAYawRateTerm) {
  const double k = -0.2;  // s/rad
  const DiagnoseReport r = DiagnoseSim(Sim("diff_robot", 5, {{TermChannel::kYawRate, "turn_rate*|turn_rate|", k}}));
  EXPECT_NE(r.verdict, "no_significant_effect");
  EXPECT_EQ(r.verdict, "effects_found");
  ASSERT_FALSE(r.discovered.empty()) << "misfit " << r.misfit.variance_factor;
  const Discovered& d = r.discovered[0];
  EXPECT_EQ(d.channel, "yaw_rate") << DiscoveredText(r);
  EXPECT_EQ(d.terms[0].regressor, "turn_rate*|turn_rate|") << DiscoveredText(r);
  const ParamEstimate& c = d.terms[0].coefficient;
  EXPECT_TRUE(std::abs(c.value - k) <= std::max(0.2 * std::abs(k), 2.0 * c.std)) << DiscoveredText(r);
  EXPECT_LT(d.heldout_drift_after, 0.7 * d.heldout_drift_before);
  EXPECT_EQ(r.discovered.size(), 1u) << DiscoveredText(r);
  for (const FoundEffect& e : r.effects) ADD_FAILURE() << "catalogued effect declared: " << e.name;
  const std::string summary = DiagnoseSummaryText(r);
  EXPECT_EQ(summary.find("within its noise"), std::string::npos) << summary;
  EXPECT_NE(summary.find("ω_true = ω_kin·(1 − "), std::string::npos) << summary;
  const nlohmann::json j = nlohmann::json::parse(DiagnoseReportJson(r));
  ASSERT_EQ(j["discovered"].size(), 1u);
  EXPECT_EQ(j["discovered"][0]["terms"][0]["unit"], "s/rad");
  EXPECT_EQ(j["discovered"][0]["channel"], "yaw_rate");

  // The sim-to-real loop: the config `--write-sim` writes carries the term, and a recording
  // simulated from it is diagnosed with the same term within the sigmas.
  SimConfig again = ParseSimConfig(SimConfigYaml(r, Source("config/robots/diff_robot.yaml")), "written.yaml", ".");
  ASSERT_EQ(again.terms.size(), 1u);
  again.seed = 9;
  again.imu.rate_hz = 0.0;
  const DiagnoseReport r2 = DiagnoseSim(again);
  ASSERT_FALSE(r2.discovered.empty()) << "re-simulated: verdict " << r2.verdict;
  EXPECT_EQ(r2.discovered[0].terms[0].regressor, "turn_rate*|turn_rate|") << DiscoveredText(r2);
  const ParamEstimate& c2 = r2.discovered[0].terms[0].coefficient;
  EXPECT_LE(std::abs(c2.value - c.value), std::max(2.0 * std::hypot(c.std, c2.std), 0.05 * std::abs(c.value)))
      << DiscoveredText(r) << " against re-simulated " << DiscoveredText(r2);
}

// The wheels' rolling radius grows with speed (tyre growth): a radius term by |speed|.
TEST(Discover, TyreGrowthIsModelledAsARadiusTerm) {
  const double k = 0.03;  // s/m
  const DiagnoseReport r = DiagnoseSim(Sim("diff_robot", 6, {{TermChannel::kRadius, "|speed|", k}}));
  ASSERT_FALSE(r.discovered.empty()) << "verdict " << r.verdict << ", misfit " << r.misfit.variance_factor;
  const Discovered& d = r.discovered[0];
  EXPECT_EQ(d.channel, "radius") << DiscoveredText(r);
  EXPECT_EQ(d.terms[0].regressor, "|speed|") << DiscoveredText(r);
  const ParamEstimate& c = d.terms[0].coefficient;
  EXPECT_TRUE(std::abs(c.value - k) <= std::max(0.2 * std::abs(k), 2.0 * c.std)) << DiscoveredText(r);
}

// The body turns further one way than the other for the same wheel motion (a caster's drag, a
// slope): a yaw-rate term by |turn_rate|, the same sign turning left and right.
TEST(Discover, AsymmetricTurningIsModelledAsAYawRateTermByTheTurnRateMagnitude) {
  const double k = 0.01;
  const DiagnoseReport r = DiagnoseSim(Sim("diff_robot", 8, {{TermChannel::kYawRate, "|turn_rate|", k}}));
  ASSERT_FALSE(r.discovered.empty()) << "verdict " << r.verdict << ", misfit " << r.misfit.variance_factor;
  EXPECT_EQ(r.discovered.size(), 1u) << DiscoveredText(r);
  const Discovered& d = r.discovered[0];
  EXPECT_EQ(d.channel, "yaw_rate") << DiscoveredText(r);
  EXPECT_EQ(d.terms[0].regressor, "|turn_rate|") << DiscoveredText(r);
  const ParamEstimate& c = d.terms[0].coefficient;
  EXPECT_TRUE(std::abs(c.value - k) <= std::max(0.2 * std::abs(k), 2.0 * c.std)) << DiscoveredText(r);
  EXPECT_NE(DiagnoseSummaryText(r).find("ω_true = ω_kin + 0.01"), std::string::npos) << DiagnoseSummaryText(r);
}

// Physics the library has no term for (a yaw rate that grows with time since the start): the
// verdict says the model does not fit, never that it explains the recording within its noise.
TEST(Discover, PhysicsOutsideTheLibraryIsUnmodelledStructure) {
  const DiagnoseReport r = DiagnoseSim(Sim("diff_robot", 7, {{TermChannel::kYawRate, "time", 2e-4}}));
  EXPECT_EQ(r.verdict, "unmodelled_structure") << "variance factor " << r.misfit.variance_factor << ", drift ratio "
                                               << r.misfit.heading_drift_ratio << "; " << DiscoveredText(r);
  EXPECT_TRUE(r.misfit.beyond);
  const std::string summary = DiagnoseSummaryText(r);
  EXPECT_EQ(summary.find("within its noise"), std::string::npos) << summary;
  EXPECT_NE(summary.find("UNMODELLED STRUCTURE"), std::string::npos) << summary;
}

// A smaller yaw rate growing with time on the forklift: no term fits it and the residuals are
// several times a control's (variance factor between the bound and ten times a control's): the
// verdict still says the model does not fit.
TEST(Discover, PhysicsOutsideTheLibraryAtSeveralTimesAControlsMisfitIsUnmodelledStructure) {
  SimConfig config = LoadSimConfig(Source("config/sims/forklift.yaml"));
  config.seed = 7;
  config.terms = {{TermChannel::kYawRate, "time", 7e-6}};
  const DiagnoseReport r = DiagnoseSim(config);
  EXPECT_TRUE(r.discovered.empty()) << DiscoveredText(r);
  EXPECT_GT(r.misfit.variance_factor, 4.0);
  EXPECT_EQ(r.verdict, "unmodelled_structure") << "variance factor " << r.misfit.variance_factor << ", drift ratio "
                                               << r.misfit.heading_drift_ratio << "; " << DiscoveredText(r);
}

// A controller that takes a continuously changing setpoint at its 8.5 ms tick holds it half a
// tick late on average: the drive layer's lag lands on the timing resolution of the command
// stamps (4.25 ms) to within a few microseconds, and a tight sigma put it just above once a
// term was planted: a drive lag was declared beside physics that has nothing to do with the
// drive. A real lag of a couple of ticks on the same robot is still found.
TEST(Discover, NoDriveLagAtTheTickOfAContinuousSetpointBesideAPlantedTerm) {
  SimConfig config = Sim("diff_robot", 1, {{TermChannel::kYawRate, "turn_rate*|turn_rate|", 0.002}});
  config.physics_rate_hz = 1.0 / 0.0085;
  config.command_between = CommandsBetween::kContinuous;
  config.command_rate_hz = 38.2;
  config.wheels.rate_hz = 70.8;
  config.wheels.ticks_per_rev = 11743;
  const DiagnoseReport r = DiagnoseSim(config);
  EXPECT_EQ(DiscoveredText(r).find("yaw_rate by turn_rate*|turn_rate|"), 0u) << DiscoveredText(r);
  for (const FoundEffect& e : r.effects) EXPECT_NE(e.name, "drive_lag") << DiagnoseSummaryText(r);
  const auto lag = std::find_if(r.candidates.begin(), r.candidates.end(),
                                [](const CandidateOutcome& c) { return c.name == "drive_lag"; });
  ASSERT_NE(lag, r.candidates.end());
  EXPECT_GT(lag->detectable, 0.00425) << "beyond the half tick";

  config.effects.drive_lag_tau_s = 0.01;
  const DiagnoseReport lagged = DiagnoseSim(config);
  const auto found = std::find_if(lagged.effects.begin(), lagged.effects.end(),
                                  [](const FoundEffect& e) { return e.name == "drive_lag"; });
  EXPECT_NE(found, lagged.effects.end()) << DiagnoseSummaryText(lagged);
}

// A clock drift's column is the time offset's times the time since the start: large on the few
// intervals where the motion changes fast, the more so the later. Rows of a recording whose
// final model has a time offset (A), with a drift (G) `drift` s/s beside it, unit noise, and
// every 100th interval's motion changing 100 times faster; blocks of 20 rows, every other held out.
std::vector<diag::DiscoveryRow> OffsetAndDriftRows(double drift, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<diag::DiscoveryRow> rows;
  for (int i = 0; i < 800; ++i) {
    diag::DiscoveryRow row;
    row.block = i / 20;
    row.heldout = row.block % 2 == 1;
    const double t = 0.25 * i;                               // s since the start
    const double n = noise(rng);
    const double rate = i % 100 == 17 ? std::copysign(100.0, n) : n;  // the offset's column, yaw
    row.A = Eigen::MatrixXd::Zero(3, 1);
    row.A(2, 0) = rate;
    row.G = row.A * t;
    row.C = Eigen::MatrixXd::Zero(3, 0);
    row.r = Eigen::Vector3d(noise(rng), noise(rng), noise(rng)) - row.G.col(0) * drift;
    rows.push_back(row);
  }
  return rows;
}

// The held-out score of a drift the fit blocks show many sigma strong beside the offset. Its
// variance came from the residual without the drift, which carries the drift's own signal on the
// few fast intervals: the score stayed near 2 (one-sided level 2.33 at alpha 0.01) and the drift
// was never confirmed, the catalogue's time_offset kept in its place. Without a drift the
// score still passes that level about as often as alpha says.
TEST(Discover, HeldoutScoreOfAStrongClockDriftBesideAnOffsetIsNotSwampedByItsOwnSignal) {
  const diag::DesignColumns without, with{{0}, {}};
  const std::vector<diag::DiscoveryRow> drifting = OffsetAndDriftRows(3e-3, 1);
  const diag::LinearFit base = diag::FitRows(drifting, without, 4), fit = diag::FitRows(drifting, with, 4);
  const double wald = fit.Value(drifting[0], 0) / fit.Std(drifting[0], 0);
  ASSERT_GT(std::abs(wald), 8.0) << "the fit blocks show the drift: " << fit.Value(drifting[0], 0) << " ± " << fit.Std(drifting[0], 0);
  const double score = diag::HeldoutScore(drifting, without, 0, base, fit, 4);
  EXPECT_GT(score * (wald > 0 ? 1 : -1), 5.0) << "Wald z on the fit blocks " << wald;

  int passed = 0, trials = 400;
  for (int k = 0; k < trials; ++k) {
    const std::vector<diag::DiscoveryRow> rows = OffsetAndDriftRows(0.0, 100 + k);
    const diag::LinearFit b = diag::FitRows(rows, without, 4), f = diag::FitRows(rows, with, 4);
    const double z = f.Value(rows[0], 0) / f.Std(rows[0], 0);
    passed += diag::HeldoutScore(rows, without, 0, b, f, 4) * (z > 0 ? 1 : -1) > 2.326;
  }
  EXPECT_LE(passed, trials * 3 / 100) << "false confirmations without a drift";
}

// Controls: the same robots without a term.
TEST(Discover, ControlsHaveNoTermAndFitWithinTheirNoise) {
  for (uint64_t seed : {5, 6, 7}) {
    const DiagnoseReport r = DiagnoseSim(Sim("diff_robot", seed, {}));
    EXPECT_EQ(r.verdict, "no_significant_effect") << "seed " << seed << ": " << DiscoveredText(r);
    EXPECT_TRUE(r.discovered.empty()) << "seed " << seed << ": " << DiscoveredText(r);
    EXPECT_FALSE(r.misfit.beyond) << "seed " << seed << ": variance factor " << r.misfit.variance_factor
                                  << ", drift ratio " << r.misfit.heading_drift_ratio;
  }
}

}  // namespace
}  // namespace calib
