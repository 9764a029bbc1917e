// agvcal-bench-diagnose-time: how long `agvcal diagnose` takes on 1, 3 and 10-minute recordings of
// each drive (issue 19, the table in docs/mismatch.md).
//
//   agvcal-bench-diagnose-time [--agvcal PATH] [--minutes M[,M...]] [--sim NAME.yaml]... [--jobs J[,J...]]
//                              [--keep DIR]
//
// For each simulation config (default: config/sims/diff_robot.yaml, forklift.yaml,
// dual_steer_agv.yaml) and each length, simulates the default trajectory again and again (each
// run from its own start, seed + 1, 10 s apart on the robot clock, as agvcal-bench-solve), the
// last run cut at the length (OfflineRunOptions::max_duration_s), writes it to /tmp, then runs
// `PATH diagnose ROBOT LOG --out /tmp/...json` once and prints its wall time and the CPU time of
// the child (user + system, both cores' worth when it uses two). PATH defaults to this build's
// agvcal. With --jobs, diagnose runs once per value (`--jobs J`) on the same recording; --keep
// keeps the recordings in DIR (NAME-Mmin.log) and the reports (NAME-Mmin-jobsJ.json).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/sim/simulator.h"
#include "sim_recording.h"

namespace {

double ChildCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec + 1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

int Run(int argc, char** argv) {
  std::string agvcal = AGVCAL_BINARY;
  std::vector<double> minutes{1, 3, 10};
  std::vector<std::string> sims;
  std::vector<int> jobs;  // empty: diagnose's default
  std::string keep;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() {
      if (i + 1 >= argc) throw calib::InputError("command line", a, "expected a value");
      return std::string(argv[++i]);
    };
    if (a == "--help" || a == "-h") {
      std::cout << "usage: agvcal-bench-diagnose-time [--agvcal PATH] [--minutes M[,M...]] [--sim NAME.yaml]...\n"
                   "                                  [--jobs J[,J...]] [--keep DIR]\n"
                   "Times `agvcal diagnose` on simulated recordings of each length (default 1, 3, 10 min)\n"
                   "of each drive (default diff_robot, forklift, dual_steer_agv).\n"
                   "  --jobs J,...  run diagnose once per value with --jobs J (default: once, its default)\n"
                   "  --keep DIR    keep the recordings (NAME-Mmin.log) and reports (NAME-Mmin-jobsJ.json)\n";
      return calib::kExitOk;
    } else if (a == "--agvcal") {
      agvcal = value();
    } else if (a == "--minutes") {
      minutes.clear();
      std::stringstream list(value());
      for (std::string m; std::getline(list, m, ',');) minutes.push_back(std::atof(m.c_str()));
    } else if (a == "--jobs") {
      std::stringstream list(value());
      for (std::string j; std::getline(list, j, ',');) jobs.push_back(std::atoi(j.c_str()));
    } else if (a == "--keep") {
      keep = value();
    } else if (a == "--sim") {
      sims.push_back(value());
    } else {
      throw calib::InputError("command line", a, "unknown option");
    }
  }
  if (sims.empty()) sims = {"diff_robot.yaml", "forklift.yaml", "dual_steer_agv.yaml"};
  if (jobs.empty()) jobs.push_back(0);
  std::printf("sim                 recording   jobs   diagnose wall   CPU (user+sys)   exit\n");
  for (const std::string& name : sims) {
    const std::string sim_path = std::string(AGVCAL_SOURCE_DIR) + "/config/sims/" + name;
    const calib::SimConfig config = calib::LoadSimConfig(sim_path);
    for (double m : minutes) {
      const std::string stem = (keep.empty() ? std::string("/tmp/agvcal_bench_diagnose") : keep + "/" +
                                name.substr(0, name.rfind('.')) + "-" + std::to_string(int(m)) + "min");
      const std::string log = stem + ".log";
      const double recorded = agvcal_bench::WriteRecording(config, 60.0 * m, log);
      for (int j : jobs) {
        const std::string out = stem + (j > 0 ? "-jobs" + std::to_string(j) : std::string()) + ".json";
        const std::string command = agvcal + " diagnose " + config.robot.source_file + " " + log + " --out " + out +
                                    (j > 0 ? " --jobs " + std::to_string(j) : std::string()) + " > /dev/null 2>&1";
        const double cpu0 = ChildCpuSeconds();
        const auto start = std::chrono::steady_clock::now();
        const int status = std::system(command.c_str());
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const double cpu = ChildCpuSeconds() - cpu0;
        std::printf("%-18s  %6.0f s     %-4s   %8.1f s       %8.1f s       %d\n", name.c_str(), recorded,
                    j > 0 ? std::to_string(j).c_str() : "-", wall, cpu, WEXITSTATUS(status));
        std::fflush(stdout);
        if (keep.empty()) std::remove(out.c_str());
      }
      if (keep.empty()) std::remove(log.c_str());
    }
  }
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-bench-diagnose-time", Run, argc, argv); }
