#include "calib/calibrate/recording_input.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "calib/core/errors.h"
#include "calib/io/log_summary.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/match/scan_match.h"

namespace calib {

MotionSource ChooseMotionSource(const RobotDescription& robot, const std::string& log_path,
                                std::optional<MotionSource> requested) {
  // A pipe can be read once; the calibration reads its recording several times.
  struct stat info {};
  if (::stat(log_path.c_str(), &info) == 0 && S_ISFIFO(info.st_mode))
    throw InputError(log_path, "", "a pipe or FIFO: the recording is read more than once; save it to a file first");
  const LogSummary summary = SummarizeLog(log_path);
  auto has = [&](const std::string& channel) {
    const auto it = summary.channels.find(channel);
    return it != summary.channels.end() && it->second.count > 0;
  };
  // What a missing channel's message adds: the channels there are, as they are spelled
  // ("SCAN\x20" for a trailing space, io/recording.h's PrintableChannel).
  std::string present;
  for (const auto& [name, channel] : summary.channels) present += (present.empty() ? "" : ", ") + PrintableChannel(name);
  const std::string not_there = "not in the recording (it has " + present + ")";
  if (!has(kWheelsChannel))
    throw InputError(log_path, "channel " + std::string(kWheelsChannel), not_there);
  const std::string scan = ScanChannel(robot);
  const std::string pose = PoseChannel(robot);
  const std::string imu = ImuChannel(robot);
  // The IMU is chosen by itself only where its calibration applies (differential drives):
  // otherwise a robot whose lidar channel is absent hears about the lidar, not the IMU.
  if (requested == MotionSource::kImu || (!requested && !has(scan) && !has(pose) && robot.imu && has(imu) &&
                                          robot.drive == DriveType::kDifferential)) {
    if (!robot.imu) throw InputError(robot.source_file, "imu", "no IMU in the robot file (needed for --source imu)");
    if (!has(imu)) throw InputError(log_path, "channel " + imu, not_there + "; needed for the IMU");
    return MotionSource::kImu;
  }
  if (requested == MotionSource::kLidar2d || (!requested && robot.lidar2d && has(scan))) {
    if (!has(scan))
      throw InputError(log_path, "channel " + scan, not_there + "; needed for the 2D lidar");
    return MotionSource::kLidar2d;
  }
  if (requested == MotionSource::kPose && !has(pose))
    throw InputError(log_path, "channel " + pose, not_there + "; needed for --source pose");
  // Scans the robot file cannot use: its lidar2d is missing, not the recording's scans.
  if (!has(pose) && !robot.lidar2d && has(scan)) {
    throw InputError(robot.source_file, "lidar2d",
                     "no 2D lidar in the robot file, but the recording has " +
                         std::to_string(summary.channels.at(scan).count) + " scans on " + scan +
                         " (add lidar2d: {channel: " + scan + ", x: ..., y: ..., yaw: ...})");
  }
  if (!has(pose)) {
    throw InputError(log_path, "channels " + scan + " / " + pose + " / " + imu,
                     "neither scans of the robot's 2D lidar, external poses nor the robot's IMU in "
                     "the recording (it has " + present + ")");
  }
  return MotionSource::kPose;
}

void ReportScanMatching(const ScanMatcher& matcher, const std::string& log_path,
                        const std::function<void(const std::string&)>& progress) {
  const ScanMatchCounts& c = matcher.counts();
  if (progress) {
    progress("scan matcher: " + std::to_string(c.scans) + " scans, " + std::to_string(c.matches) +
             " matched pairs (" + std::to_string(c.invalid) + " failed, of which " + std::to_string(c.wheel_gaps) +
             " over encoder gaps; " + std::to_string(c.degenerate) + " degenerate)");
  }
  // Two clock domains in one recording: said as the cause, not as too little data.
  if (!matcher.clock_problem().empty() && c.matches == 0) throw InputError(log_path, "", matcher.clock_problem());
}

CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress) {
  return ReadCalibrationData(robot, log_path, source, progress, nullptr);
}

CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress,
                                    const std::function<void(LaserScan*)>& adjust_scan,
                                    int64_t deskew_shift_us, RecordingSource::Mode mode,
                                    const ScanMatchOptions& match_options) {
  CalibrationData data(robot);
  std::optional<ScanMatcher> matcher;
  if (source == MotionSource::kLidar2d) matcher.emplace(robot, match_options);
  auto add_matches = [&](const std::vector<ScanMatchOutcome>& outcomes) {
    for (const ScanMatchOutcome& outcome : outcomes) {
      if (!outcome.matched()) continue;
      SensorMotion motion = outcome.motion;  // back on the recorded stamps
      motion.utime_start += deskew_shift_us, motion.utime_end += deskew_shift_us;
      data.AddMotion(motion);
    }
  };

  RecordingSource log(log_path, mode);
  SubscribeWheels(&log, robot, [&](const WheelSample& sample) {
    data.AddWheels(sample);
    if (matcher) add_matches(matcher->AddWheels(sample));
  });
  int64_t scans = 0, scans_with_returns = 0;
  if (matcher) {
    SubscribeScans(&log, ScanChannel(robot), [&](LaserScan scan) {
      ++scans;
      for (int i = 0; i < scan.size(); ++i) {
        if (scan.HasReturn(i)) {
          ++scans_with_returns;
          break;
        }
      }
      if (adjust_scan) adjust_scan(&scan);
      scan.utime -= deskew_shift_us;  // on the wheel clock
      add_matches(matcher->AddScan(scan));
    });
  }
  if (source == MotionSource::kImu)
    SubscribeImu(&log, ImuChannel(robot), [&](const ImuSample& sample) { data.AddImu(sample); });
  if (source == MotionSource::kPose)
    SubscribePoses(&log, PoseChannel(robot), [&](const StampedPose& pose) { data.AddPose(pose); });
  log.set_on_drop([&](const std::string& note) { data.AddDropped(note); });

  int64_t count = 0;
  while (log.HandleNext(0)) {
    if (progress && ++count % 100000 == 0) {
      progress("read " + std::to_string(count) + " messages, " + std::to_string(data.motions().size()) +
               " motions");
    }
  }
  log.Finish();  // a growing log's reader does not end by itself (done at the end of a complete one)
  if (matcher) {
    add_matches(matcher->Finish());
    ReportScanMatching(*matcher, log_path, progress);
    // Scans without a single return (all NaN, all out of range): said as the cause, not as too
    // little data.
    if (scans > 0 && scans_with_returns == 0)
      throw InputError(log_path, "channel " + PrintableChannel(ScanChannel(robot)),
                       "none of the " + std::to_string(scans) +
                           " scans has a return (every range NaN, infinite or outside [range_min, range_max])");
  }
  return data;
}

bool SolvesAgainDeskewed(MotionSource source) { return source == MotionSource::kLidar2d; }

CalibrationResult SolveAgainDeskewed(const RobotDescription& robot, const std::string& log_path,
                                     const CalibrationResult& first, const CalibrationOptions& options,
                                     const std::string& origin, SecondPassInput* read) {
  CalibrationResult result = first;
  for (int pass = 0; pass < kMaxDeskewedPasses; ++pass) {
    const double matched_at = result.time_offset ? result.time_offset->value : 0.0;
    const CalibrationData again =
        ReadCalibrationData(Calibrated(robot, result), log_path, MotionSource::kLidar2d, nullptr, nullptr,
                            std::llround(matched_at * 1e6), RecordingSource::Mode::kGrowing);
    if (read) {
      read->wheel_states = again.wheels().size();
      read->last_wheel_utime = again.wheels().empty() ? 0 : again.wheels().last_utime();
      read->motions = again.motions();
    }
    result = Calibrate(robot, again.wheels(), again.motions(), MotionSource::kLidar2d, options, origin);
    // Without a time offset one pass: the first pass's model is within its sigmas of the truth,
    // and a de-skew model that close leaves no error of note.
    if (!result.time_offset ||
        std::abs(result.time_offset->value - matched_at) <= kDeskewedAgreeSigmas * result.time_offset->std)
      break;
  }
  return result;
}

CalibrationResult SolveLog(const RobotDescription& robot, const std::string& log_path,
                           const SolveLogOptions& options) {
  const MotionSource source = ChooseMotionSource(robot, log_path, options.source);
  const CalibrationData data = ReadCalibrationData(robot, log_path, source, options.progress);
  if (options.progress) {
    const size_t count = source == MotionSource::kImu ? data.imu().size() : data.motions().size();
    options.progress(std::to_string(data.wheels().size()) + " wheel states, " +
                     std::to_string(count) + " " + MotionSourceName(source) +
                     (source == MotionSource::kImu ? " samples" : " motions") + "; calibrating");
  }
  CalibrationResult result;
  try {
    result = source == MotionSource::kImu
                 ? ToCalibrationResult(robot, CalibrateWithImu(robot, data.wheels(), data.imu(), options.imu, log_path))
                 : Calibrate(robot, data.wheels(), data.motions(), source, options.calibration, log_path);
  } catch (const InputError& e) {
    // Too little data where the reader skipped part of the recording (a torn or cut-short log):
    // the skip is the cause to name, not only the count it left.
    const std::vector<std::string>& notes = data.drop_notes();
    const auto skip = std::find_if(notes.begin(), notes.end(),
                                   [](const std::string& note) { return note.find(" skipped (") != std::string::npos; });
    if (skip == notes.end() || e.file() != log_path) throw;
    throw InputError(e.file(), e.place(), e.problem() + "; the reader left out part of it: " + *skip);
  }
  if (SolvesAgainDeskewed(source)) {
    // Match again, de-skewed with the calibrated model (and offset) on the wheel clock (recording_input.h).
    if (options.progress) options.progress("matching the scans again, de-skewed with the calibrated model");
    result = SolveAgainDeskewed(robot, log_path, result, options.calibration, log_path);
  }
  result.input_dropped = data.dropped_input();
  result.input_notes = data.drop_notes();
  return result;
}

}  // namespace calib
