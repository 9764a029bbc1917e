#pragma once
// Sensor readings as plain data: what the messages of spec/messages.md carry,
// converted at the io edge (calib/io/messages.h) so that the domain never sees
// a message. The wheel encoders' WheelSample is in wheel_track.h, the 2D lidar's
// LaserScan in laser_scan.h.

#include <array>
#include <cstdint>
#include <vector>

namespace calib {

// One IMU sample in the sensor frame: rad/s about z, m/s^2 along x and y.
struct ImuSample {
  int64_t utime = 0;
  double rate = 0.0;
  double accel_x = 0.0, accel_y = 0.0;
};

// A planar pose in a fixed world frame with its time (pose2d_t): an external
// pose source, or an odometry output.
struct StampedPose {
  int64_t utime = 0;                 // us, robot clock
  double x = 0.0, y = 0.0;           // m
  double theta = 0.0;                // rad
  std::array<double, 9> cov{};       // of (x, y, theta), row-major; all zero when unknown
};

// One 3D lidar frame (point_cloud_t): points in the sensor frame, m.
struct PointCloud {
  int64_t utime = 0;        // time of the first point, us
  std::vector<float> xyz;   // interleaved x, y, z
};

// The angle a turret-mounted 3D lidar stands at on its mount (mount_angle_t).
struct MountAngle {
  int64_t utime = 0;   // us
  double angle = 0.0;  // rad, 0 = the robot file's mount
};

}  // namespace calib
