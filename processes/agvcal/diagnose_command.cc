#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <nlohmann/json.hpp>

#include "calib/core/errors.h"
#include "calib/diagnose/diagnose.h"
#include "calib/io/atomic_file.h"
#include "commands.h"
#include "common/process_util.h"

namespace agvcal_cli {

namespace {
const char* kUsage = R"(usage: agvcal diagnose ROBOT.yaml LOG [--sim SIM_LOG] [--out REPORT.json] [--report DIR]
                       [--write-sim SIM.yaml] [--alpha A] [--block-s S] [--drift-window S] [--jobs N]
                       [--quiet]

Compares the recording with the robot's calibrated model and names the physics
the model leaves out (spec/effects.md): where and under what motion the residual
stands out, each effect fitted jointly with the calibration, tested against a
false-alarm rate over the whole catalogue, and proven on held-out data
(alternating time blocks the fit never sees). Prints a plain-words summary.
  --out REPORT.json   write the report (spec/cli.md), atomically; besides spec/cli.md's
                      keys: candidates[] (every candidate: status, estimate value/std,
                      p_value, delta_bic, detectable, note saying why a significant one
                      was not named), fit.outlier_share and fit.outlier_correlation (the
                      share of intervals set aside, which is only what neither the final
                      model nor any candidate explains, and its correlation with |speed|,
                      |acceleration|, |turn rate|, |turn-rate change|, |centripetal|,
                      |steering rate|); docs/mismatch.md lists every key
  --report DIR        human report (docs/reports.md; a folder, created if missing, an earlier
                      agvcal report there cleared): index.html with the candidates and
                      the calibration as tables, summary.txt and SVG plots (residual over
                      time before/after, each effect's signature and its held-out error
                      per stretch, the route with the spans marked, actuation close-ups)
  --sim SIM_LOG       also diagnose a simulator's recording of the same commands and
                      report where the two differ (REPORT.json key "sim_comparison")
  --write-sim FILE    a simulation config (truth = refitted calibration, effects found)
                      that makes the simulator reproduce this robot (world and sensors:
                      the simulator's defaults; edit to match)
  --alpha A           family-wise false-alarm rate over all candidates (default 0.01)
  --block-s S         length of the alternating fit / held-out blocks (default 10 s)
  --drift-window S    held-out dead reckoning is judged over windows of S seconds
                      (default 2, at most --block-s)
  --jobs N            threads for the candidates' independent fits (default: the machine's
                      cores, at most 2); the report is the same for any N
  --quiet             no progress on stderr (else a line per step; a long run's candidate
                      lines say how many are left and about how long they take)
Exit status: 0 done (effects found or not); 2 unusable input; 3 the recording cannot
determine the calibration itself; 1 internal error.
)";
}  // namespace

int Diagnose(int argc, char** argv) {
  const auto args = agvcal_process::ParseArgs(
      argc, argv, 2, {"--sim", "--out", "--report", "--write-sim", "--alpha", "--block-s", "--drift-window", "--jobs"}, {"--quiet"});
  if (const auto status = agvcal_process::CheckUsage(args, kUsage, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const std::string log_path = args.positional[1];
  calib::DiagnoseOptions options;
  options.alpha = args.GetDouble("--alpha", options.alpha);
  options.block_s = args.GetDouble("--block-s", options.block_s);
  if (!(options.alpha > 0 && options.alpha < 1))
    throw calib::InputError("command line", "--alpha", "expected a number in (0, 1)");
  if (!(options.block_s >= 1.0))
    throw calib::InputError("command line", "--block-s", "expected at least 1 s");
  if (args.Has("--jobs")) {
    const double jobs = args.GetDouble("--jobs", 0);
    if (!(jobs >= 1 && jobs <= 64 && jobs == std::floor(jobs)))
      throw calib::InputError("command line", "--jobs", "expected a whole number from 1 to 64");
    options.jobs = static_cast<int>(jobs);
  }
  options.drift_window_s = args.GetDouble("--drift-window", std::min(options.drift_window_s, options.block_s));
  if (!(options.drift_window_s > 0 && options.drift_window_s <= options.block_s))
    throw calib::InputError("command line", "--drift-window", "expected a length in (0, --block-s]");
  // Where the results go is checked before the analysis (exit 2 at once, naming the path).
  for (const char* option : {"--out", "--write-sim"})
    if (args.Has(option)) calib::CheckWritableFile(args.Get(option, ""), option);
  if (args.Has("--report")) calib::PrepareReportDir(args.Get("--report", ""));
  if (!args.Has("--quiet")) options.progress = [](const std::string& line) { std::cerr << line << "\n"; };

  const calib::DiagnoseReport report = calib::DiagnoseLog(robot, log_path, options);
  for (const std::string& warning : report.warnings) std::cerr << "agvcal: warning: " << warning << "\n";
  std::cout << calib::DiagnoseSummaryText(report);

  std::string json = calib::DiagnoseReportJson(report);
  if (args.Has("--sim")) {
    const std::string sim_path = args.Get("--sim", "");
    const calib::DiagnoseReport sim = calib::DiagnoseLog(robot, sim_path, options);
    const std::string comparison = calib::CompareWithSimJson(report, sim);
    std::cout << "\nCompared with the simulator's recording " << sim_path << ":\n" << comparison << "\n";
    nlohmann::json j = nlohmann::json::parse(json);
    j["sim_comparison"] = nlohmann::json::parse(comparison);
    json = j.dump(1) + "\n";
  }
  if (args.Has("--out")) calib::WriteFileAtomically(args.Get("--out", ""), json);
  if (args.Has("--report")) calib::WriteDiagnoseReportDir(report, args.Get("--report", ""));
  if (args.Has("--write-sim"))
    calib::WriteFileAtomically(args.Get("--write-sim", ""),
                               calib::SimConfigYaml(report, std::filesystem::absolute(args.positional[0]).string()));
  return calib::kExitOk;
}

}  // namespace agvcal_cli
