// agvcal-bench-long-recording: writes a long simulated recording for the soak benchmark
// (bench/soak.sh, docs/live.md "Memory over long runs").
//
//   agvcal-bench-long-recording SIM.yaml MINUTES OUT.log
//
// The default trajectory of SIM.yaml again and again (each run from its own start, seed + 1,
// 10 s apart on the robot clock; bench/sim_recording.h) until MINUTES of robot time are recorded.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

#include "calib/core/errors.h"
#include "calib/sim/simulator.h"
#include "sim_recording.h"

namespace {

int Run(int argc, char** argv) {
  if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::cout << "usage: agvcal-bench-long-recording SIM.yaml MINUTES OUT.log\n"
                 "Writes MINUTES of robot time of SIM.yaml's default trajectory, run again and again\n"
                 "(seed + 1 per run, 10 s apart), to OUT.log (an lcm-logger recording).\n";
    return calib::kExitOk;
  }
  if (argc != 4) {
    std::cerr << "usage: agvcal-bench-long-recording SIM.yaml MINUTES OUT.log (see --help)\n";
    return calib::kExitBadInput;
  }
  const double minutes = std::atof(argv[2]);
  if (!(minutes > 0)) throw calib::InputError("command line", "MINUTES", "must be > 0");
  const double recorded = agvcal_bench::WriteRecording(calib::LoadSimConfig(argv[1]), 60.0 * minutes, argv[3]);
  std::printf("recorded %.0f s of %s -> %s\n", recorded, argv[1], argv[3]);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-bench-long-recording", Run, argc, argv); }
