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
#include "common/provenance.h"

namespace agvcal_cli {

namespace {
// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Compares the recording with the robot's calibrated model and names the physics
the model leaves out (docs/spec/effects.md): where and under what motion the residual
stands out, each effect fitted jointly with the calibration, tested against a
false-alarm rate over the whole catalogue, and proven on held-out data
(alternating time blocks the fit never sees). Prints a plain-words summary.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md), calibrated")
      .Positional("LOG", "the robot's recording (lcm-logger)")
      .Option("--out", "REPORT.json",
              "write the report (docs/spec/cli.md), atomically; besides docs/spec/cli.md's\n"
              "keys: candidates[] (every candidate: status, estimate value/std,\n"
              "p_value, delta_bic, detectable, note saying why a significant one\n"
              "was not named), fit.outlier_share and fit.outlier_correlation (the\n"
              "share of intervals set aside, which is only what neither the final\n"
              "model nor any candidate explains, and its correlation with |speed|,\n"
              "|acceleration|, |turn rate|, |turn-rate change|, |centripetal|,\n"
              "|steering rate|); docs/mismatch.md lists every key")
      .Option("--report", "DIR",
              "human report (docs/reports.md; a folder, created if missing, an\n"
              "earlier agvcal report there cleared): index.html with the candidates and\n"
              "the calibration as tables, summary.txt and SVG plots (residual over\n"
              "time before/after, each effect's signature and its held-out error\n"
              "per stretch, the route with the spans marked, actuation close-ups)")
      .Option("--sim", "SIM_LOG",
              "also diagnose a simulator's recording of the same commands and\n"
              "report where the two differ (REPORT.json key \"sim_comparison\")")
      .Option("--write-sim", "FILE",
              "a simulation config (truth = refitted calibration, effects found)\n"
              "that makes the simulator reproduce this robot (world and sensors:\n"
              "the simulator's defaults; edit to match)")
      .Option("--alpha", "A", "family-wise false-alarm rate over all candidates (default 0.01)")
      .Option("--block-s", "S", "length of the alternating fit / held-out blocks (default 10 s)")
      .Option("--drift-window", "S",
              "held-out dead reckoning is judged over windows of S seconds\n"
              "(default 2, at most --block-s)")
      .Option("--jobs", "N",
              "threads for the candidates' independent fits (default: the machine's\n"
              "cores, at most 2); the report is the same for any N")
      .Flag("--quiet",
            "no progress on stderr (else a line per step; a long run's candidate\n"
            "lines say how many are left and about how long they take)")
      .Flag("--verbose", "also print the diagnosis's bookkeeping (REPORT.json's notes, the status\n"
                         "and statistics of every candidate tested and not named)")
      .Footer("Exit status: 0 done (effects found or not); 2 unusable input; 3 the recording cannot\n"
              "determine the calibration itself; 1 internal error.\n");
}
}  // namespace

int Diagnose(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal diagnose");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const std::string log_path = args.positional[1];
  agvcal_process::RecordProvenance(args, &robot, log_path);
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
  calib::CheckOutputs({args.positional[0], log_path, args.Get("--sim", "")}, {{"--out", args.Get("--out", "")},
      {"--write-sim", args.Get("--write-sim", "")}, {"--report", args.Get("--report", ""), true}});
  if (!args.Has("--quiet")) options.progress = [](const std::string& line) { std::cerr << line << "\n"; };

  const calib::DiagnoseReport report = calib::DiagnoseLog(robot, log_path, options);
  // Said even with --quiet, as solve says it: the diagnosis stands on less than the recording holds.
  for (const std::string& note : report.input_notes) std::cerr << "agvcal: left out: " << note << "\n";
  if (report.input_dropped > 0)
    std::cerr << "agvcal: " << report.input_dropped << " message(s) of " << log_path
              << " left out of the diagnosis (REPORT.json input.notes)\n";
  for (const std::string& warning : report.warnings) std::cerr << "agvcal: warning: " << warning << "\n";
  std::cout << calib::DiagnoseSummaryText(report, args.Has("--verbose"));

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
  calib::Outputs outputs;  // put in place together, only when all were written
  if (args.Has("--out")) outputs.WriteFile(args.Get("--out", ""), json);
  if (args.Has("--report")) calib::WriteDiagnoseReportDir(report, outputs.ReportDir(args.Get("--report", "")));
  if (args.Has("--write-sim"))
    outputs.WriteFile(args.Get("--write-sim", ""),
                      calib::SimConfigYaml(report, std::filesystem::absolute(args.positional[0]).string()));
  outputs.Commit();
  return calib::kExitOk;
}

}  // namespace agvcal_cli
