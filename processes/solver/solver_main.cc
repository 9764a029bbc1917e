// agvcal-solver: the live calibration. Collects WHEELS and the sensor's motions
// (SCAN_MATCH from agvcal-scanmatch, or POSE), re-solves every N new motions
// and publishes CALIB_ESTIMATE and CALIB_RESIDUALS; on SIGINT/SIGTERM solves
// once more on everything and writes RESULT.json. The solve is a function of
// the messages' contents, not of their arrival times, so a replay of a
// recording ends with the numbers `agvcal solve` gives for it. With
// --catch-up (as scripts/agvcal-group runs it) a solver restarted mid-run first
// takes what it missed from the group's recording, and ends with the same numbers.
#include <lcm/lcm-cpp.hpp>

#include <iostream>

#include "agvcal/pose2d_t.hpp"
#include "agvcal/scan_match_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/calibrate/calibration_data.h"
#include "calib/calibrate/result_files.h"
#include "calib/core/errors.h"
#include "calib/io/messages.h"
#include "calib/live/estimate_messages.h"
#include "common/process_util.h"

namespace {

const char* kUsage = R"(usage: agvcal-solver ROBOT.yaml [--source lidar2d|pose] [--every N] [--time-offset]
                     [--out RESULT.json] [--catch-up RECORDING] [--lcm-url URL]

Calibrates the robot of ROBOT.yaml live: WHEELS with SCAN_MATCH (the 2D lidar's
motion from agvcal-scanmatch) or with POSE (an external pose source). Publishes
CALIB_ESTIMATE (estimates, sigmas, observability) after every N new motions and
CALIB_RESIDUALS (per-interval residuals), and HEARTBEAT.
  --source lidar2d|pose   the sensor (default lidar2d if the robot file has one, else pose)
  --every N               re-solve after N new motions (default 200)
  --time-offset           also estimate the lidar-to-wheel time offset
  --out RESULT.json       on exit, solve on all data and write the result (spec/cli.md)
  --catch-up RECORDING    on start, first read the inputs published so far from the
                          group's recording (lcm-logger's file, still being written),
                          then continue live; each message is used once (by stamp)
  --lcm-url URL           LCM provider (default: $LCM_DEFAULT_URL or LCM's default)
Exit status: 0 stopped by SIGINT/SIGTERM (after the final solve), 2 bad robot
file, bus or message, 3 the final solve cannot determine a parameter, 1 internal.
)";

class Solver {
 public:
  Solver(const calib::RobotDescription& robot, calib::MotionSource source, calib::CalibrationOptions options,
         lcm::LCM* lcm)
      : robot_(robot), source_(source), options_(options), data_(robot_), lcm_(lcm) {}

  // One encoded message of `channel` (WHEELS, or the motion channel).
  void OnMessage(const std::string& channel, const uint8_t* data, size_t size) {
    error_.Run([&] {
      if (channel == calib::kWheelsChannel) {
        agvcal::wheel_state_t m;
        if (Decoded(channel, data, size, &m)) data_.AddWheels(m, channel);
        return;
      }
      if (source_ == calib::MotionSource::kPose) {
        agvcal::pose2d_t m;
        if (!Decoded(channel, data, size, &m)) return;
        data_.AddPose(m);
      } else {
        agvcal::scan_match_t m;
        if (!Decoded(channel, data, size, &m)) return;
        data_.AddMotion(calib::FromMessage(m, channel));
      }
      if (!holding_solves_) MaybeSolve();
    });
  }

  void set_every(std::size_t every) { every_ = every; }
  // While catching up, no intermediate solves (they would be outdated at once).
  void set_holding_solves(bool hold) {
    holding_solves_ = hold;
    if (!hold) MaybeSolve();
  }
  const std::optional<std::string>& error() const { return error_.message(); }

  // Solves on everything collected; publishes the estimate and the new residuals.
  // Throws what Calibrate throws when `final`.
  calib::CalibrationResult Solve(bool final) {
    const calib::CalibrationResult result = calib::Calibrate(
        robot_, data_.wheels(), data_.motions(), source_, options_, "live " + std::string(calib::MotionSourceName(source_)));
    const int64_t utime = data_.motions().empty() ? 0 : data_.motions().back().utime_end;
    const agvcal::calib_estimate_t estimate = calib::ToMessage(result, utime, final ? "final" : "ok");
    lcm_->publish(calib::kCalibEstimateChannel, &estimate);
    for (const calib::IntervalResidual& r : result.intervals) {
      if (r.utime_end <= last_residual_utime_) continue;
      const agvcal::calib_residual_t m = calib::ToMessage(r);
      lcm_->publish(calib::kCalibResidualsChannel, &m);
      last_residual_utime_ = r.utime_end;
    }
    return result;
  }

 private:
  // A message of another type on our channel is skipped (as LCM's typed
  // subscriptions do), and reported once.
  template <typename Message>
  bool Decoded(const std::string& channel, const uint8_t* data, size_t size, Message* m) {
    if (calib::Decode(data, static_cast<int>(size), m)) return true;
    if (undecodable_++ == 0)
      std::cerr << "agvcal-solver: ignoring messages on " << channel << " that are not "
                << Message::getTypeName() << " (reported once)\n";
    return false;
  }

  void MaybeSolve() {
    if (data_.motions().size() < solved_at_ + every_) return;
    solved_at_ = data_.motions().size();
    try {
      Solve(false);
    } catch (const calib::UnobservableError& e) {
      Publish("unobservable", std::string(e.what()) + "; " + e.remedy());
    } catch (const calib::InputError& e) {
      Publish("waiting", e.what());
    }
  }

  void Publish(const std::string& status, const std::string& message) {
    agvcal::calib_estimate_t m{};
    m.utime = data_.motions().empty() ? 0 : data_.motions().back().utime_end;
    m.drive = calib::DriveTypeName(robot_.drive);
    m.status = status;
    m.message = message;
    lcm_->publish(calib::kCalibEstimateChannel, &m);
  }

  const calib::RobotDescription& robot_;
  calib::MotionSource source_;
  calib::CalibrationOptions options_;
  calib::CalibrationData data_;
  lcm::LCM* lcm_;
  std::size_t every_ = 200, solved_at_ = 0;
  bool holding_solves_ = false;
  int64_t undecodable_ = 0;
  int64_t last_residual_utime_ = 0;
  agvcal_process::FirstError error_;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  const Args args = ParseArgs(argc, argv, 1, {"--source", "--every", "--out", "--catch-up", "--lcm-url"},
                              {"--time-offset"});
  if (const auto status = CheckUsage(args, kUsage, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const calib::MotionSource source = MotionSourceOption(args, robot);
  const double every = args.GetDouble("--every", 200);
  if (!(every >= 1)) throw calib::InputError("command line", "--every", "must be >= 1");
  calib::CalibrationOptions options;
  options.estimate_time_offset = args.Has("--time-offset");

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  Solver solver(robot, source, options, &lcm);
  solver.set_every(static_cast<std::size_t>(every));
  const std::string motion_channel = source == calib::MotionSource::kPose
                                         ? (robot.pose ? robot.pose->channel : calib::kPoseChannel)
                                         : calib::kScanMatchChannel;
  CatchUpInput input(&lcm, {calib::kWheelsChannel, motion_channel},
                     [&solver](const std::string& channel, const uint8_t* data, size_t size) {
                       solver.OnMessage(channel, data, size);
                     });
  Heartbeat heartbeat(&lcm, "solver");
  InstallStopHandlers();
  if (args.Has("--catch-up")) {
    solver.set_holding_solves(true);
    input.CatchUp(args.Get("--catch-up", ""), "agvcal-solver", &heartbeat);
    solver.set_holding_solves(false);
  }
  while (!g_stop_requested) {
    lcm.handleTimeout(100);
    heartbeat.Beat("running");
  }
  // Messages already received when the stop came (e.g. the scan matcher's last
  // matches, sent just before it stopped) still count.
  HandleQueued(lcm);
  if (solver.error()) throw calib::InputError("bus", "message", *solver.error());
  const calib::CalibrationResult result = solver.Solve(true);
  if (args.Has("--out")) calib::WriteFileAtomically(args.Get("--out", ""), calib::CalibrationResultJson(result));
  std::cerr << "agvcal-solver: final solve on " << result.residual.intervals << " intervals\n";
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-solver", Run, argc, argv); }
