#pragma once
// The ground calibration (calib/ground/ground.h) fed with messages in arrival order:
// clouds (point_cloud_t on the robot file's lidar3d.channel) and, for a lidar
// that turns on its mount, the angle it stands at (mount_angle_t on
// lidar3d.rotation.channel). The live process agvcal-ground and the offline
// `agvcal ground` both go through GroundSession, so a recording gives the
// same numbers either way. Also: reading a whole recording or a cloud file,
// and the RESULT.json of spec/cli.md.

#include <cstdint>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "agvcal/ground_estimate_t.hpp"
#include "agvcal/mount_angle_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "calib/core/robot.h"
#include "calib/ground/ground.h"

namespace calib {

class GroundSession {
 public:
  // Throws InputError naming the robot file when it has no lidar3d.
  GroundSession(const RobotDescription& robot, GroundOptions options);

  // One cloud; for a rotating lidar it takes the newest angle stamped at or
  // before the cloud (not older than rotation.max_age_s), else it is skipped.
  // Returns the frame's fit, or nullptr for a skipped frame.
  const FrameFit* OnCloud(const agvcal::point_cloud_t& cloud);
  void OnMountAngle(const agvcal::mount_angle_t& angle);
  // Decodes and dispatches an encoded message by channel; false for a channel
  // it does not use. A message that does not decode is an InputError(origin, place).
  bool OnMessage(const std::string& channel, const void* data, int size, const std::string& origin,
                 const std::string& place);

  // The state for GROUND_ESTIMATE (never throws; a refusal is in `status`).
  agvcal::ground_estimate_t EstimateMessage() const;

  const GroundCalibrator& calibrator() const { return calibrator_; }
  const std::string& cloud_channel() const { return cloud_channel_; }
  const std::string& angle_channel() const { return angle_channel_; }  // "" for a fixed lidar
  int clouds() const { return clouds_; }

 private:
  GroundCalibrator calibrator_;
  std::string cloud_channel_, angle_channel_;
  double max_age_s_ = 0.0;
  std::deque<std::pair<int64_t, double>> angles_;  // recent (utime, angle), arrival order
  int clouds_ = 0;
  int64_t last_utime_ = 0;
  double last_angle_ = 0.0;
  int last_sector_ = -1;
};

// A cloud message (CLOUD, spec/messages.md) holding `xyz` (interleaved, sensor
// frame, m), e.g. a PCD or KITTI frame read by calib/io/cloud_file.h, for a recording.
agvcal::point_cloud_t CloudMessage(const std::vector<float>& xyz, int64_t utime);

// What a run over a file read.
struct GroundInput {
  std::string path;
  std::string kind;      // "log", "pcd" or "kitti"
  int clouds = 0;
  size_t points = 0;     // finite points read (cloud files)
};

// Runs the calibration over a recording (lcm-logger) or a cloud file (.pcd,
// KITTI .bin). Throws InputError for unreadable or corrupt input and for a
// recording without clouds on the lidar's channel, UnobservableError when
// the floor does not determine the answer.
GroundResult CalibrateGroundFile(const RobotDescription& robot, const GroundOptions& options,
                                 const std::string& path, bool with_grid, GroundInput* input);

// RESULT.json of `agvcal ground` (spec/cli.md: lidar3d.{z,pitch,roll}.{value,std},
// frames, inliers) with the extra keys of docs/ground.md (grid, sectors, ...).
std::string GroundResultJson(const GroundResult& result, const GroundInput& input);

// The same, as text for people (both estimates side by side).
std::string GroundResultText(const GroundResult& result, const GroundInput& input);

}  // namespace calib
