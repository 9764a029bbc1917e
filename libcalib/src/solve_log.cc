#include "calib/solve_log.h"

#include <optional>

#include "calib/errors.h"
#include "calib/log_summary.h"
#include "calib/messages.h"
#include "calib/recording.h"
#include "calib/laser_scan.h"
#include "calib/scan_match.h"

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
  if (requested == MotionSource::kLidar2d || (!requested && robot.lidar2d && has(scan))) {
    if (!has(scan))
      throw InputError(log_path, "channel " + scan, "not in the recording (needed for the 2D lidar)");
    return MotionSource::kLidar2d;
  }
  if (!has(pose)) {
    throw InputError(log_path, "channels " + scan + " / " + pose,
                     "neither scans of the robot's 2D lidar nor external poses in the recording");
  }
  return MotionSource::kPose;
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
  const std::string pose_channel = robot.pose ? robot.pose->channel : kPoseChannel;
  const std::string scan_channel = robot.lidar2d ? robot.lidar2d->channel : kScanChannel;
  std::optional<ScanMatchPipeline> matcher;
  if (source == MotionSource::kLidar2d) matcher.emplace(robot);
  auto take_matches = [&]() {
    for (const SensorMotion& m : matcher->TakeResults()) data.AddMotion(m);
  };
  LogReader reader(log_path);
  LogEvent event;
  int64_t count = 0;
  while (reader.Next(&event)) {
    const int size = static_cast<int>(event.data.size());
    if (event.channel == kWheelsChannel) {
      agvcal::wheel_state_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as wheel_state_t");
      const std::string origin = log_path + ": " + EventPlace(event);
      const WheelSample sample = WheelSampleFromMessage(m, robot, origin);
      data.AddWheels(sample);
      if (matcher) {
        matcher->AddWheels(sample);
        take_matches();
      }
    } else if (matcher && event.channel == scan_channel) {
      agvcal::laser_scan_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as laser_scan_t");
      LaserScan scan = LaserScanFromMessage(m, log_path + ": " + EventPlace(event));
      if (adjust_scan) adjust_scan(&scan);
      matcher->AddScan(scan);
      take_matches();
    } else if (source == MotionSource::kPose && event.channel == pose_channel) {
      agvcal::pose2d_t m;
      if (!Decode(event.data.data(), size, &m))
        throw InputError(log_path, EventPlace(event), "does not decode as pose2d_t");
      data.AddPose(m);
    }
    if (progress && ++count % 100000 == 0) {
      progress("read " + std::to_string(count) + " messages, " + std::to_string(data.motions().size()) +
               " motions");
    }
  }
  if (matcher) {
    matcher->Finish();
    take_matches();
  }
  return data;
}

CalibrationResult SolveLog(const RobotDescription& robot, const std::string& log_path,
                           const SolveLogOptions& options) {
  const MotionSource source = ChooseMotionSource(robot, log_path, options.source);
  const CalibrationData data = ReadCalibrationData(robot, log_path, source, options.progress);
  if (options.progress) {
    options.progress(std::to_string(data.wheels().size()) + " wheel states, " +
                     std::to_string(data.motions().size()) + " " + MotionSourceName(source) +
                     " motions; calibrating");
  }
  return Calibrate(robot, data.wheels(), data.motions(), source, options.calibration, log_path);
}

}  // namespace calib
