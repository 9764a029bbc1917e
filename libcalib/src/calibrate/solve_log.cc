#include "calib/calibrate/solve_log.h"

#include <optional>

#include "calib/core/errors.h"
#include "calib/io/log_summary.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/match/laser_scan.h"
#include "calib/match/scan_match.h"

namespace calib {

namespace {

std::string EventPlace(const LogEvent& event) {
  return "event " + std::to_string(event.event_number) + " (" + event.channel + ")";
}

}  // namespace

MotionSource ChooseMotionSource(const RobotDescription& robot, const std::string& log_path,
                                std::optional<MotionSource> requested) {
  const LogSummary summary = SummarizeLog(log_path);
  auto has = [&](const std::string& channel) {
    const auto it = summary.channels.find(channel);
    return it != summary.channels.end() && it->second.count > 0;
  };
  if (!has(kWheelsChannel))
    throw InputError(log_path, "channel " + std::string(kWheelsChannel), "not in the recording");
  const std::string scan = robot.lidar2d ? robot.lidar2d->channel : kScanChannel;
  const std::string pose = robot.pose ? robot.pose->channel : kPoseChannel;
  const std::string imu = robot.imu ? robot.imu->channel : kImuChannel;
  if (requested == MotionSource::kImu ||
      (!requested && !has(scan) && !has(pose) && robot.imu && has(imu))) {
    if (!robot.imu) throw InputError(robot.source_file, "imu", "no IMU in the robot file (needed for --source imu)");
    if (!has(imu)) throw InputError(log_path, "channel " + imu, "not in the recording (needed for the IMU)");
    return MotionSource::kImu;
  }
  if (requested == MotionSource::kLidar2d || (!requested && robot.lidar2d && has(scan))) {
    if (!has(scan))
      throw InputError(log_path, "channel " + scan, "not in the recording (needed for the 2D lidar)");
    return MotionSource::kLidar2d;
  }
  if (requested == MotionSource::kPose && !has(pose))
    throw InputError(log_path, "channel " + pose, "not in the recording (needed for --source pose)");
  if (!has(pose)) {
    throw InputError(log_path, "channels " + scan + " / " + pose + " / " + imu,
                     "neither scans of the robot's 2D lidar, external poses nor the robot's IMU in "
                     "the recording");
  }
  return MotionSource::kPose;
}

void ReadCalibrationStream(const RobotDescription& robot, const std::string& log_path,
                           bool match_scans, const CalibrationStreamHandlers& handlers) {
  const std::string pose_channel = robot.pose ? robot.pose->channel : kPoseChannel;
  const std::string scan_channel = robot.lidar2d ? robot.lidar2d->channel : kScanChannel;
  const std::string imu_channel = robot.imu ? robot.imu->channel : kImuChannel;
  std::optional<ScanMatchPipeline> matcher;
  if (match_scans) matcher.emplace(robot);
  auto take_matches = [&]() {
    for (const SensorMotion& m : matcher->TakeResults())
      if (handlers.motion) handlers.motion(m);
  };
  LogReader reader(log_path);
  LogEvent event;
  while (reader.Next(&event)) {
    const int size = static_cast<int>(event.data.size());
    if (event.channel == kWheelsChannel) {
      agvcal::wheel_state_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as wheel_state_t");
      const std::string origin = log_path + ": " + EventPlace(event);
      const WheelSample sample = WheelSampleFromMessage(m, robot, origin);
      if (handlers.wheels) handlers.wheels(sample);
      if (matcher) {
        matcher->AddWheels(sample);
        take_matches();
      }
    } else if (matcher && event.channel == scan_channel) {
      agvcal::laser_scan_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as laser_scan_t");
      LaserScan scan = LaserScanFromMessage(m, log_path + ": " + EventPlace(event));
      if (handlers.adjust_scan) handlers.adjust_scan(&scan);
      matcher->AddScan(scan);
      take_matches();
    } else if (handlers.imu && event.channel == imu_channel) {
      agvcal::imu_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as imu_t");
      handlers.imu(m, log_path + ": " + EventPlace(event));
    } else if (handlers.pose && event.channel == pose_channel) {
      agvcal::pose2d_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as pose2d_t");
      handlers.pose(m);
    }
    if (handlers.event) handlers.event();
  }
  if (matcher) {
    matcher->Finish();
    take_matches();
    if (handlers.progress) {
      const ScanMatchCounts& c = matcher->counts();
      handlers.progress("scan matcher: " + std::to_string(c.scans) + " scans, " + std::to_string(c.matches) +
               " matched pairs (" + std::to_string(c.invalid) + " failed, of which " +
               std::to_string(c.wheel_gaps) + " over encoder gaps; " + std::to_string(c.degenerate) +
               " degenerate)");
    }
  }
}

CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress) {
  return ReadCalibrationData(robot, log_path, source, progress, nullptr);
}

CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress,
                                    const std::function<void(LaserScan*)>& adjust_scan) {
  CalibrationData data(robot);
  CalibrationStreamHandlers handlers;
  handlers.adjust_scan = adjust_scan;
  handlers.progress = progress;
  handlers.wheels = [&](const WheelSample& sample) { data.AddWheels(sample); };
  handlers.motion = [&](const SensorMotion& m) { data.AddMotion(m); };
  if (source == MotionSource::kPose) handlers.pose = [&](const agvcal::pose2d_t& m) { data.AddPose(m); };
  if (source == MotionSource::kImu) {
    handlers.imu = [&](const agvcal::imu_t& m, const std::string& origin) { data.AddImu(m, origin); };
  }
  int64_t count = 0;
  handlers.event = [&]() {
    if (progress && ++count % 100000 == 0) {
      progress("read " + std::to_string(count) + " messages, " + std::to_string(data.motions().size()) +
               " motions");
    }
  };
  ReadCalibrationStream(robot, log_path, source == MotionSource::kLidar2d, handlers);
  return data;
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
  if (source == MotionSource::kImu) {
    return ToCalibrationResult(robot, CalibrateWithImu(robot, data.wheels(), data.imu(), options.imu, log_path));
  }
  return Calibrate(robot, data.wheels(), data.motions(), source, options.calibration, log_path);
}

}  // namespace calib
