#pragma once
// The ground calibration (calib/ground/ground.h) fed with messages in arrival order:
// clouds (point_cloud_t on the robot file's lidar3d.channel) and, for a lidar
// that turns on its mount, the angle it stands at (mount_angle_t on
// lidar3d.rotation.channel). The live process agvcal-ground and the offline
// `agvcal ground` both subscribe a GroundSession to a message source
// (calib/io/message_source.h: the bus, a recording), so a recording gives the
// same numbers either way. Also: reading a whole recording or a cloud file,
// and the RESULT.json of spec/cli.md.

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "calib/core/robot.h"
#include "calib/core/sensor_data.h"
#include "calib/ground/ground.h"

namespace calib {

class MessageSource;  // calib/io/message_source.h

// The state of a session after a cloud (what GROUND_ESTIMATE, ground_estimate_t,
// carries): the estimate so far, or why there is none yet.
struct GroundEstimate {
  int64_t utime = 0;        // of the newest cloud
  std::string status;       // "ok", "waiting: ..." or "refused: ..."
  int frames_seen = 0;      // clouds received
  int frames = 0;           // clouds whose floor fit went into the estimate
  double inliers = 0.0;
  double z = 0.0, pitch = 0.0, roll = 0.0;              // m, rad
  double z_std = 0.0, pitch_std = 0.0, roll_std = 0.0;  // one sigma
  int sector = 0;           // of the newest cloud's mount angle; -1 for a fixed lidar
  double angle = 0.0;       // rad, the newest cloud's mount angle (0 for a fixed lidar)
  int sectors_done = 0;     // sectors with an estimate
  int num_sectors = 0;      // 0 for a fixed lidar
};

class GroundSession {
 public:
  // Throws InputError naming the robot file when it has no lidar3d.
  GroundSession(const RobotDescription& robot, GroundOptions options);

  // One cloud; for a rotating lidar it takes the newest angle stamped at or
  // before the cloud (not older than rotation.max_age_s), else it is skipped.
  // Returns the frame's fit, or nullptr for a skipped frame.
  const FrameFit* OnCloud(const PointCloud& cloud);
  void OnMountAngle(const MountAngle& angle);
  // Subscribes OnCloud and OnMountAngle to the session's channels on `source`;
  // `after_cloud` (may be empty) runs after each cloud.
  void Subscribe(MessageSource* source, std::function<void()> after_cloud = nullptr);

  // The state for GROUND_ESTIMATE (never throws; a refusal is in `status`).
  GroundEstimate CurrentEstimate() const;

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

// What a run over a file read.
struct GroundInput {
  std::string path;
  std::string kind;      // "log", "pcd" or "kitti"
  int clouds = 0;
  size_t points = 0;     // finite points read (cloud files)
  // Messages the recording's reader left out (a stamp out of order, a torn event), and the
  // first notes naming them: the command says them, so no cloud is lost without a word.
  int64_t dropped = 0;
  std::vector<std::string> drop_notes;
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

// `agvcal ground --report DIR`: index.html, summary.txt (GroundResultText) and SVG plots: the
// floor points coloured by their height above the calibrated floor, that height's histogram,
// every frame's own fit against the combined estimate, and the per-sector table of a turning
// lidar. Made like the diagnosis's report (docs/reports.md).
void WriteGroundReportDir(const RobotDescription& robot, const GroundResult& result, const GroundInput& input,
                          const std::string& dir);

// The robot file `robot.source_file` with lidar3d z, pitch and roll (m, rad: the file's units)
// calibrated in place, their sigmas under `std:` and `source` under `source:`; the file's
// comments and layout kept (core/robot_file_edit.h). A rotating lidar: the sector holding
// angle 0 (the robot file's mount).
std::string GroundCalibratedRobotYaml(const RobotDescription& robot, const GroundResult& result,
                                      const std::string& source);

}  // namespace calib
