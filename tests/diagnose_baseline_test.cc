// An effect strong enough to make the baseline calibration refuse is evidence, not the end
// (docs/mismatch.md, "The starting calibration"): the diagnosis fits the catalogue's candidates
// inside the baseline before exit 3, starts from the one that determines everything and names the
// effect; a refusal, the calibration's or the diagnosis's, shows the estimate and sigma it refused.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>

#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/diagnose/diagnose.h"
#include "calib/import/importers.h"
#include "calib/io/recording.h"
#include "calib/sim/simulator.h"
#include "sim_log.h"

namespace calib {
namespace {

using test_support::SimLog;
using test_support::Source;

std::string DataDir() {
  const char* env = std::getenv("AGVCAL_DATA_DIR");
  return env ? env : Source("../shared/data");
}

// "name value ± sigma unit" as the refusals print an estimate.
const std::regex kEstimate("[a-z_.0-9]+ -?[0-9.e-]+ ± ([0-9.e-]+|undetermined) (m|rad|s)");

// The real circular run of the OptiOdom tricycle with an eccentricity of 0.11 written into its drive
// wheel (scripts/inject_effect.py): the plain calibration then cannot determine drive_radius and
// wheelbase; with wheel_eccentricity inside the baseline the recording determines everything.
TEST(DiagnoseBaseline, EccentricityThatBreaksTheBaselineIsNamedNotRefused) {
  const std::string run = DataDir() + "/optiodom-sousa/tricyc/circular/140120211415/140120211415_run-01.csv.gz";
  if (!std::filesystem::exists(run)) GTEST_SKIP() << "no dataset at " << run;
  const std::string robot_path = Source("config/robots/datasets/optiodom_tricycle.yaml");
  const RobotDescription robot = LoadRobotFile(robot_path);
  const std::string recorded = testing::TempDir() + "circular.log", injected = testing::TempDir() + "circular_ecc.log";
  {
    LogWriter writer(recorded);
    Import("optiodom", run, &robot, &writer);
    writer.Close();
  }
  const std::string inject = "python3 " + Source("scripts/inject_effect.py") + " " + recorded + " " + injected +
                             " " + robot_path + " eccentricity drive 0.11 0 >/dev/null";
  ASSERT_EQ(std::system(inject.c_str()), 0) << inject;

  // The plain calibration refuses, showing what it refused.
  try {
    SolveLog(robot, injected, {});
    FAIL() << "the baseline was expected to refuse this recording";
  } catch (const UnobservableError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("drive_radius"), std::string::npos) << what;
    EXPECT_TRUE(std::regex_search(what, kEstimate)) << what;
  }

  // The diagnosis does not: it names the effect and says how it started.
  DiagnoseOptions options;
  options.progress = nullptr;
  const DiagnoseReport report = DiagnoseLog(robot, injected, options);
  bool named = false;
  for (const FoundEffect& effect : report.effects) named = named || effect.name == "wheel_eccentricity";
  EXPECT_TRUE(named) << report.verdict;
  bool started_inside = false;
  for (const std::string& note : report.notes)
    started_inside = started_inside || note.find("wheel_eccentricity (drive) modelled inside the baseline") != std::string::npos;
  EXPECT_TRUE(started_inside);
}

// Where no candidate makes the recording determinable (straight runs only), the diagnosis refuses
// as the calibration does (exit 3), naming what stays undetermined with its estimate and sigma.
TEST(DiagnoseBaseline, RefusalWithEveryCandidateInsideShowsTheEstimates) {
  const SimConfig config = LoadSimConfig(Source("config/sims/diff_robot.yaml"));
  const SimLog log(config, "straight");
  try {
    DiagnoseLog(config.robot, log.path(), {});
    FAIL() << "a straight-only recording cannot determine the track";
  } catch (const UnobservableError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("modelled inside the baseline"), std::string::npos) << what;
    EXPECT_TRUE(std::regex_search(what, kEstimate)) << what;
    EXPECT_FALSE(e.remedy().empty());
  }
}

}  // namespace
}  // namespace calib
