// agvcal-solver: the live calibration. Collects WHEELS and the sensor's motions
// (SCAN_MATCH from agvcal-scanmatch, or POSE), re-solves every N new motions
// and publishes CALIB_ESTIMATE and CALIB_RESIDUALS; on SIGINT/SIGTERM solves
// once more on everything and writes RESULT.json. The solve is a function of
// the messages' contents, not of their arrival times, so a replay of a
// recording ends with the numbers `agvcal solve` gives for it. With
// --catch-up (as scripts/agvcal-group runs it) a solver restarted mid-run first
// takes what it missed from the group's recording, and ends with the same numbers.
// With SCAN_MATCH the final solve, as `agvcal solve`'s, matches the scans a second
// time, de-skewed with the calibrated model (and offset): the solver holds only the
// motions, so it reads the scans again from that recording (calib::SolveAgainDeskewed).
#include <lcm/lcm-cpp.hpp>
#include <malloc.h>

#include <chrono>
#include <functional>
#include <future>
#include <iostream>
#include <thread>
#include <vector>

#include "calib/calibrate/calibration_data.h"
#include "calib/calibrate/calibration_report.h"
#include "calib/calibrate/recording_input.h"
#include "calib/calibrate/result_files.h"
#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/io/process_names.h"
#include "calib/live/estimate_messages.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Calibrates the robot of ROBOT.yaml live: WHEELS with SCAN_MATCH (the 2D lidar's
motion from agvcal-scanmatch) or with POSE (an external pose source). Publishes
CALIB_ESTIMATE (estimates, sigmas, observability) after every N new motions and
CALIB_RESIDUALS (per-interval residuals), and HEARTBEAT.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md)")
      .Option("--source", "lidar2d|pose", "the sensor (default lidar2d if the robot file has one, else pose)")
      .Option("--every", "N", "re-solve after N new motions (default 20: about every 12 s of\n"
              "the bundled samples, whose scan matcher gives a motion per 0.6 s)")
      .Flag("--time-offset",
            "also estimate the lidar-to-wheel time offset (the final solve's second\n"
            "pass then de-skews on the wheel clock, as `agvcal solve --time-offset`)")
      .Option("--out", "RESULT.json", "on exit, solve on all data and write the result (docs/spec/cli.md)")
      .Option("--catch-up", "RECORDING",
              "on start, first read the inputs published so far from the\n"
              "group's recording (lcm-logger's file, still being written),\n"
              "then continue live; each message is used once (by stamp).\n"
              "With SCAN_MATCH the final solve then matches the recording's\n"
              "scans a second time, de-skewed with the calibrated model, as\n"
              "`agvcal solve` does (without --catch-up: once, said on stderr)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("A message that does not decode or convert is skipped, counted and reported once.\n"
              "Exit status: 0 stopped by SIGINT/SIGTERM (after the final solve), 2 bad robot\n"
              "file or bus, 3 the final solve cannot determine a parameter, 1 internal.\n");
}

// Intermediate solves run on a worker thread while the main thread keeps receiving: a solve
// on a long run's data takes seconds (2.5 s at one hour of 100 Hz wheel data), and a process
// that stops reading that long loses messages in the bus's buffers, which changes the final
// result (docs/live.md, "Memory over long runs"). Messages received during a solve are held
// and added, in their order, when it ends, so the data, and the final solve on them, are those
// of a serial run.
class Solver {
 public:
  Solver(const calib::RobotDescription& robot, calib::MotionSource source, calib::CalibrationOptions options,
         lcm::LCM* lcm)
      : robot_(robot), source_(source), options_(options), data_(robot_), lcm_(lcm) {}

  // Subscribes to WHEELS and the motion channel (SCAN_MATCH, or the robot file's pose channel).
  void Subscribe(calib::MessageSource* source) {
    calib::SubscribeWheels(source, robot_, [this](const calib::WheelSample& sample) {
      if (solving()) {
        held_wheels_.push_back(sample);
      } else {
        data_.AddWheels(sample);
      }
    });
    if (source_ == calib::MotionSource::kPose) {
      calib::SubscribePoses(source, calib::PoseChannel(robot_), [this](const calib::StampedPose& pose) {
        if (solving()) return held_poses_.push_back(pose);
        data_.AddPose(pose);
        MaybeSolve();
      });
    } else {
      calib::SubscribeScanMatches(source, [this](const calib::SensorMotion& motion) {
        if (solving()) return held_motions_.push_back(motion);
        data_.AddMotion(motion);
        MaybeSolve();
      });
    }
  }

  void set_every(std::size_t every) { every_ = every; }
  // While catching up, no intermediate solves (they would be outdated at once).
  void set_holding_solves(bool hold) {
    holding_solves_ = hold;
    MaybeSolve();
  }

  // Publishes an intermediate solve that has ended (all `wait`ing for one that runs), adds
  // the messages held meanwhile and starts the next solve if they call for one.
  void Poll(bool wait = false) {
    using namespace std::chrono_literals;
    if (!solving() || (!wait && running_.wait_for(0s) != std::future_status::ready)) return;
    try {
      Publish(running_.get(), false);
    } catch (const calib::UnobservableError& e) {
      PublishStatus("unobservable", std::string(e.what()) + "; " + e.remedy());
    } catch (const calib::InputError& e) {
      PublishStatus("waiting", e.what());
    }
    for (const calib::WheelSample& sample : held_wheels_) data_.AddWheels(sample);
    for (const calib::StampedPose& pose : held_poses_) data_.AddPose(pose);
    for (const calib::SensorMotion& motion : held_motions_) data_.AddMotion(motion);
    held_wheels_.clear();
    held_poses_.clear();
    held_motions_.clear();
    // The solve's memory, freed, goes back to the system rather than stay with the process.
    malloc_trim(0);
    MaybeSolve();
  }

  // The final solve's second pass, as `agvcal solve`'s (calib::SolvesAgainDeskewed), reads the
  // scans from `recording` (the group's); `flush` is called before each reading.
  void set_second_pass(std::string recording, std::function<void()> flush) {
    recording_ = std::move(recording);
    flush_ = std::move(flush);
  }

  // The final solve on everything collected (after an intermediate one still running), and
  // its second pass (set_second_pass); publishes the estimate and the new residuals. Throws
  // what Calibrate throws.
  calib::CalibrationResult SolveFinal() {
    holding_solves_ = true;  // no new one
    Poll(true /* wait */);
    calib::CalibrationResult result = Calibrate();
    if (calib::SolvesAgainDeskewed(source_)) result = SolveAgain(result);
    Publish(result, true);
    return result;
  }

 private:
  bool solving() const { return running_.valid(); }
  std::string origin() const { return "live " + std::string(calib::MotionSourceName(source_)); }

  calib::CalibrationResult Calibrate() const {
    return calib::Calibrate(robot_, data_.wheels(), data_.motions(), source_, options_, origin());
  }

  // The second pass on the recording's scans. lcm-logger writes the recording behind the bus
  // (it flushes when a message comes 100 ms after its last flush): when the recording's wheel
  // data end before this solver's, it is read once more, a second and a flush later (a pass on
  // an hour of data takes half a minute, repeated up to kMaxDeskewedPasses times). A recording
  // that lacks wheel states the solver received (lcm-logger lost them on an overloaded machine),
  // or that cannot be read, is said on stderr; the latter leaves the first pass's result.
  calib::CalibrationResult SolveAgain(const calib::CalibrationResult& first) {
    if (recording_.empty()) {
      std::cerr << "agvcal-solver: no recording (--catch-up) to match the scans again from: the result "
                   "is the first pass's, not `agvcal solve`'s\n";
      return first;
    }
    std::cerr << "agvcal-solver: matching the scans of " << recording_
              << " again, de-skewed with the calibrated model\n";
    const calib::WheelTrack& wheels = data_.wheels();
    for (int attempt = 1;; ++attempt) {
      if (attempt > 1) std::this_thread::sleep_for(std::chrono::seconds(1));
      if (flush_) flush_();
      calib::SecondPassInput read;
      calib::CalibrationResult result = first;
      try {
        result = calib::SolveAgainDeskewed(robot_, recording_, first, options_, origin(), &read);
      } catch (const calib::InputError& e) {
        std::cerr << "agvcal-solver: cannot match the scans again (" << e.what()
                  << "): the result is the first pass's\n";
        return first;
      }
      if (attempt == 1 && !wheels.empty() && read.last_wheel_utime < wheels.last_utime()) continue;
      if (read.wheel_states != wheels.size()) {
        std::cerr << "agvcal-solver: the recording holds " << read.wheel_states << " wheel states, the solver received "
                  << wheels.size() << ": the second pass is on the recording's, so the result differs from `agvcal "
                     "solve`'s on the messages the group had\n";
      }
      return result;
    }
  }

  // Starts an intermediate solve on a worker thread once `every_` new motions have come.
  void MaybeSolve() {
    if (holding_solves_ || solving() || data_.motions().size() < solved_at_ + every_) return;
    solved_at_ = data_.motions().size();
    running_ = std::async(std::launch::async, [this] { return Calibrate(); });
  }

  // The estimate and the residuals newer than those published before.
  void Publish(const calib::CalibrationResult& result, bool final) {
    const int64_t utime = data_.motions().empty() ? 0 : data_.motions().back().utime_end;
    const agvcal::calib_estimate_t estimate = calib::ToMessage(result, utime, final ? "final" : "ok");
    lcm_->publish(calib::kCalibEstimateChannel, &estimate);
    for (const calib::IntervalResidual& r : result.intervals) {
      if (r.utime_end <= last_residual_utime_) continue;
      const agvcal::calib_residual_t m = calib::ToMessage(r);
      lcm_->publish(calib::kCalibResidualsChannel, &m);
      last_residual_utime_ = r.utime_end;
    }
  }

  void PublishStatus(const std::string& status, const std::string& message) {
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
  calib::CalibrationData data_;  // read by the worker while it solves: added to only between solves
  lcm::LCM* lcm_;
  std::size_t every_ = 20, solved_at_ = 0;
  bool holding_solves_ = false;
  int64_t last_residual_utime_ = 0;
  std::future<calib::CalibrationResult> running_;  // the intermediate solve, while one runs
  std::vector<calib::WheelSample> held_wheels_;     // received while it runs
  std::vector<calib::StampedPose> held_poses_;
  std::vector<calib::SensorMotion> held_motions_;
  std::string recording_;        // the second pass's scans (set_second_pass)
  std::function<void()> flush_;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  // A solve's large blocks (the encoder track, Jacobians, residuals) come from the system and go
  // back when freed: glibc would otherwise raise its mmap and trim thresholds to the largest block
  // freed so far and keep up to twice that in the heap (docs/live.md, "Memory over long runs").
  // One arena: the intermediate solves run on a worker thread, whose own arena kept the pages of
  // its last solve while the final one grew the main arena (soak: peak 21.9 -> 17.6 MB above the start, docs/live.md).
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024);
  mallopt(M_ARENA_MAX, 1);
  CommandLine args("agvcal-solver");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const calib::MotionSource source =
      MotionSourceOption(args, {calib::MotionSource::kLidar2d, calib::MotionSource::kPose}, LiveMotionSource(robot))
          .value();
  const double every = args.GetDouble("--every", 20);
  if (!(every >= 1)) throw calib::InputError("command line", "--every", "must be >= 1");
  calib::CalibrationOptions options;
  options.estimate_time_offset = args.Has("--time-offset");
  calib::CheckOutputs({args.positional[0], args.Get("--catch-up", "")}, {{"--out", args.Get("--out", "")}});

  BusSource bus(args.Get("--lcm-url", ""), "agvcal-solver");
  bus.DeliverOncePerStamp();  // a message is used once, whether live, recovered or both
  Solver solver(robot, source, options, &bus.lcm());
  solver.set_every(static_cast<std::size_t>(every));
  solver.Subscribe(&bus);
  Heartbeat heartbeat(&bus.lcm(), calib::kSolverProcess);
  bus.ReportOn(&heartbeat);
  InstallStopHandlers();
  // The second pass's reading waits for lcm-logger to write what the solver received: two
  // heartbeats 150 ms apart make it flush (it does when a message comes 100 ms after its last
  // flush), and 250 ms more let it write.
  solver.set_second_pass(args.Get("--catch-up", ""), [&heartbeat] {
    using namespace std::chrono_literals;
    heartbeat.Beat("final solve: matching the recorded scans again", true);
    std::this_thread::sleep_for(150ms);
    heartbeat.Beat("final solve: matching the recorded scans again", true);
    std::this_thread::sleep_for(250ms);
  });
  if (args.Has("--catch-up")) {
    solver.set_holding_solves(true);
    bus.CatchUp(args.Get("--catch-up", ""), &heartbeat);
    solver.set_holding_solves(false);
  }
  while (!bus.done()) {
    bus.HandleNext(100);
    solver.Poll();
    heartbeat.Beat("running");
  }
  // Messages already received when the stop came (e.g. the scan matcher's last
  // matches, sent just before it stopped) still count.
  bus.HandleQueued();
  bus.Finish();  // a wheel sample held after a gap
  if (bus.skipped() > 0) std::cerr << "agvcal-solver: " << bus.skipped() << " unusable messages skipped\n";
  if (bus.dropped() > 0) std::cerr << "agvcal-solver: " << bus.dropped() << " message(s) left out of the fit\n";
  calib::CalibrationResult result = solver.SolveFinal();
  result.input_dropped = bus.dropped();
  result.input_notes = bus.drop_notes();
  if (args.Has("--out")) calib::WriteFileAtomically(args.Get("--out", ""), calib::CalibrationResultJson(result));
  std::cerr << "agvcal-solver: final solve on " << result.residual.intervals << " intervals\n"
            << calib::CalibrationConsoleText(result);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-solver", Run, argc, argv); }
