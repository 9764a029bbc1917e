// agvcal-scanmatch: the scan matcher as a live process. Feeds WHEELS and the
// robot file's 2D lidar channel into calib::ScanMatcher (the same front
// end `agvcal solve` runs offline) and publishes each completed match on
// SCAN_MATCH. Time comes from the messages, never the wall clock.
#include <iostream>
#include <string>
#include <vector>

#include "agvcal/scan_match_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/match/scan_match.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Matches consecutive 2D lidar scans (the lidar2d channel of ROBOT.yaml, SCAN by
default), de-skewed with the WHEELS odometry of the robot file's nominal
model, and publishes the lidar's motion between them with its covariance on
SCAN_MATCH (agvcal::scan_match_t), plus HEARTBEAT. A match is published once
the wheel data cover both scans. SIGINT/SIGTERM: matches what it can of the
data received, publishes it, and exits.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md), with lidar2d")
      .Option("--catch-up", "RECORDING",
              "on start, first read the WHEELS and scans published so far\n"
              "from the group's recording (lcm-logger's file, still being written),\n"
              "then continue live; each message is used once (by stamp), so a\n"
              "restarted matcher matches the same scan pairs as an uninterrupted\n"
              "one (the matches it publishes again are dropped by the solver)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 stopped cleanly, 2 bad robot file (or no lidar2d) or bus,\n"
              "1 internal error.\n");
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-scanmatch");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::ScanMatcher matcher(robot);  // throws InputError without a lidar2d

  // A scan's path: the bus -> SubscribeScans -> matcher.AddScan -> its outcome -> SCAN_MATCH.
  // The wheel samples feed the matcher too, and may complete the scans that wait for them.
  BusSource bus(args.Get("--lcm-url", ""), "agvcal-scanmatch");
  auto publish = [&](const std::vector<calib::ScanMatchOutcome>& outcomes) {
    for (const calib::ScanMatchOutcome& outcome : outcomes) {
      if (!outcome.matched()) continue;
      const agvcal::scan_match_t msg = calib::ToMessage(outcome.motion);
      bus.lcm().publish(calib::kScanMatchChannel, &msg);
    }
  };
  calib::SubscribeWheels(&bus, robot, [&](const calib::WheelSample& sample) { publish(matcher.AddWheels(sample)); });
  calib::SubscribeScans(&bus, robot.lidar2d->channel, [&](calib::LaserScan scan) { publish(matcher.AddScan(scan)); });
  Heartbeat heartbeat(&bus.lcm(), "scanmatch");
  bus.ReportOn(&heartbeat);
  InstallStopHandlers();
  std::cerr << "agvcal-scanmatch: " << robot.name << ", matching " << robot.lidar2d->channel
            << " with WHEELS, publishing " << calib::kScanMatchChannel << "\n";

  auto state = [&](const char* what) {
    const calib::ScanMatchCounts& c = matcher.counts();
    const std::string clocks = matcher.clock_problem().empty() ? "" : "; " + matcher.clock_problem();
    return std::string(what) + ": " + std::to_string(c.matches) + " matches (" +
           std::to_string(c.invalid) + " failed, " + std::to_string(c.degenerate) +
           " degenerate), " + std::to_string(c.scans_dropped + c.wheels_dropped) + " out of order" + clocks;
  };
  // Two clock domains make every scan unmatchable, which would otherwise show only as no
  // matches: said on stderr once, as soon as the matcher sees it (when the streams first meet);
  // every heartbeat's state carries it on.
  bool clocks_said = false;
  auto check_clocks = [&]() {
    if (clocks_said || matcher.clock_problem().empty()) return;
    clocks_said = true;
    std::cerr << "agvcal-scanmatch: " << matcher.clock_problem() << "\n";
  };
  // Catching up also delivers each message once, by stamp, from then on (BusSource::CatchUp).
  if (args.Has("--catch-up")) bus.CatchUp(args.Get("--catch-up", ""), &heartbeat);
  check_clocks();

  while (!bus.done()) {
    bus.HandleNext(100);
    check_clocks();
    heartbeat.Beat(state("running"));
  }
  bus.HandleQueued();
  bus.Finish();  // a message a stream's gate still holds (after a long gap)
  publish(matcher.Finish());
  const calib::ScanMatchCounts& c = matcher.counts();
  std::cerr << "agvcal-scanmatch: stopped; received " << c.scans << " scans and " << bus.received(calib::kWheelsChannel)
            << " wheel states; " << c.matches << " matches ("
            << c.invalid << " failed, " << c.degenerate
            << " degenerate); dropped: " << c.scans_dropped << " scans and " << c.wheels_dropped
            << " wheel states out of order, " << c.scans_uncovered << " scans without wheel data, "
            << bus.skipped() << " unusable messages\n";
  heartbeat.Beat(state("stopped"), true /* force */);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-scanmatch", Run, argc, argv); }
