// agvcal stop: the operator's stop on the bus (STOP, agvcal::operator_stop_t).
#include <lcm/lcm-cpp.hpp>

#include <iostream>

#include "agvcal/operator_stop_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/messages.h"
#include "commands.h"
#include "common/process_util.h"

namespace agvcal_cli {

namespace {
// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Publishes the operator's stop on STOP: the trajectory commander stops the robot
and holds it (sending stop commands) until `agvcal stop --release`, then resumes
its trajectory from rest. The message is sent three times, 50 ms apart (UDP).)")
      .Flag("--release", "release a stop")
      .Option("--reason", "TEXT", "logged with the stop")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 sent; 2 the bus did not open or publishing failed; 1 internal error.\n");
}
}  // namespace

int Stop(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal stop");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  agvcal::operator_stop_t msg;
  msg.utime = WallMicros();
  msg.stop = !args.Has("--release");
  msg.source = "agvcal stop";
  msg.reason = args.Get("--reason", "");
  for (int i = 0; i < 3; ++i) {
    if (i > 0) lcm.handleTimeout(50);  // paces the repeats
    if (lcm.publish(calib::kStopChannel, &msg) != 0)
      throw calib::InputError(calib::kStopChannel, "", "publishing failed");
  }
  std::cerr << "agvcal stop: " << (msg.stop ? "stop" : "release") << " sent on " << calib::kStopChannel
            << "\n";
  return calib::kExitOk;
}

}  // namespace agvcal_cli
