// agvcal-bench-scan-match: scan pairs per second of the scan matcher on one
// core, for the 720-beam scans of a sample recording.
//
//   agvcal-bench-scan-match [LOG] [ROBOT.yaml] [--seconds S]
//
// Defaults: logs/forklift_demo.log with config/robots/forklift.yaml. Decodes
// the log once, then runs the whole front end (de-skewing, line fitting and
// the symmetric PL-ICP match of every pair: ScanMatcher) over it again
// and again for at least S seconds of thread CPU time (default 3), and the one-way match alone
// on the prepared scans. Prints pairs per second.
#include <time.h>

#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/laser_scan.h"
#include "calib/core/robot.h"
#include "calib/core/wheel_track.h"
#include "calib/io/message_source.h"
#include "calib/match/scan_match.h"

namespace {

// Thread CPU time: the figure holds on a loaded machine too.
double Now() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double Seconds(double since) { return Now() - since; }

int Run(int argc, char** argv) {
  std::string log = std::string(AGVCAL_SOURCE_DIR) + "/logs/forklift_demo.log";
  std::string robot_file = std::string(AGVCAL_SOURCE_DIR) + "/config/robots/forklift.yaml";
  double min_seconds = 3.0;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: agvcal-bench-scan-match [LOG] [ROBOT.yaml] [--seconds S]\n";
      return calib::kExitOk;
    }
    if (a == "--seconds" && i + 1 < argc) {
      min_seconds = std::atof(argv[++i]);
    } else if (a.rfind("--", 0) == 0) {
      throw calib::InputError("command line", a, "unknown option");
    } else {
      positional.push_back(a);
    }
  }
  if (positional.size() > 0) log = positional[0];
  if (positional.size() > 1) robot_file = positional[1];
  const calib::RobotDescription robot = calib::LoadRobotFile(robot_file);

  // Decode once: the benchmark measures matching, not decoding.
  struct Event {
    bool is_scan;
    std::size_t index;
  };
  std::vector<Event> order;
  std::vector<calib::WheelSample> wheels;
  std::vector<calib::LaserScan> scans;
  const std::string scan_channel = calib::ScanChannel(robot);
  calib::RecordingSource recording(log);
  calib::SubscribeWheels(&recording, robot, [&](const calib::WheelSample& sample) {
    order.push_back({false, wheels.size()});
    wheels.push_back(sample);
  });
  calib::SubscribeScans(&recording, scan_channel, [&](calib::LaserScan scan) {
    order.push_back({true, scans.size()});
    scans.push_back(std::move(scan));
  });
  recording.HandleAll();
  if (scans.size() < 2) throw calib::InputError(log, scan_channel, "fewer than two scans");

  const calib::ScanMatchOptions options;
  // Whole front end.
  int64_t pairs = 0, runs = 0;
  const double start = Now();
  do {
    calib::ScanMatcher matcher(robot, options);
    auto count_matches = [&](const std::vector<calib::ScanMatchOutcome>& outcomes) {
      for (const calib::ScanMatchOutcome& outcome : outcomes) pairs += outcome.matched();
    };
    for (const Event& ev : order)
      count_matches(ev.is_scan ? matcher.AddScan(scans[ev.index]) : matcher.AddWheels(wheels[ev.index]));
    count_matches(matcher.Finish());
    ++runs;
  } while (Seconds(start) < min_seconds);
  const double pipeline_rate = pairs / Seconds(start);

  // The one-way match alone, on scans prepared beforehand (no de-skewing).
  std::vector<calib::PreparedScan> prepared;
  for (const calib::LaserScan& scan : scans)
    prepared.emplace_back(calib::ScanToPoints(scan), options);
  int64_t matches = 0;
  const double start_match = Now();
  do {
    for (std::size_t k = 1; k < prepared.size(); ++k, ++matches)
      calib::MatchPointsToLines(prepared[k - 1], prepared[k].points(), calib::Pose2{}, options);
  } while (Seconds(start_match) < min_seconds);
  const double match_rate = matches / Seconds(start_match);

  std::cout << "log: " << log << " (" << scans.size() << " scans of " << scans.front().size()
            << " beams)\n"
            << "pipeline (de-skew, line fit, symmetric PL-ICP): "
            << static_cast<int64_t>(pipeline_rate) << " scan pairs/s (" << runs << " passes)\n"
            << "one-way PL-ICP alone: " << static_cast<int64_t>(match_rate) << " matches/s\n";
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return calib::RunMain("agvcal-bench-scan-match", Run, argc, argv);
}
