#include "sim/lidar3d_model.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace calib {

Eigen::Matrix3d Lidar3dRotation(const Mount3d& mount, const Lidar3dSensorConfig& sensor, double angle) {
  // R = Ry(axis_pitch) Rx(axis_roll) Rz(angle) Rz(yaw) Ry(pitch) Rx(roll); no turret: the mount.
  return (Eigen::AngleAxisd(sensor.turret_axis_pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(sensor.turret_axis_roll, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(angle + mount.yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(mount.pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(mount.roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

agvcal::point_cloud_t SimulateCloud(const World& world, const Lidar3dSensorConfig& L,
                                    const Mount3d& m, const Pose2& pose, double turret_angle,
                                    std::mt19937_64* rng, std::normal_distribution<double>* normal) {
  const Eigen::Matrix3d mount_rotation = Lidar3dRotation(m, L, turret_angle);
  const Eigen::Matrix3d robot_rotation =
      Eigen::AngleAxisd(pose.theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d origin_robot(m.x, m.y, m.z);
  const Eigen::Vector3d origin_world =
      Eigen::Vector3d(pose.x, pose.y, 0.0) + robot_rotation * origin_robot;
  agvcal::point_cloud_t msg{};
  for (int ring = 0; ring < L.rings; ++ring) {
    const double elevation =
        L.rings == 1 ? L.elevation_min_rad
                     : L.elevation_min_rad +
                           ring * (L.elevation_max_rad - L.elevation_min_rad) / (L.rings - 1);
    for (int k = 0; k < L.points_per_ring; ++k) {
      const double azimuth = -M_PI + 2.0 * M_PI * k / L.points_per_ring;
      const Eigen::Vector3d dir_sensor(std::cos(elevation) * std::cos(azimuth),
                                       std::cos(elevation) * std::sin(azimuth),
                                       std::sin(elevation));
      const Eigen::Vector3d dir_robot = mount_rotation * dir_sensor;
      double range = std::min(
          world.CastRay3d(origin_world, robot_rotation * dir_robot, L.range_max),
          CastRayBox(L.body, origin_robot, dir_robot, L.range_max));
      const double noise = L.range_noise * (*normal)(*rng);
      if (range == kNoHit) continue;
      range += noise;
      const Eigen::Vector3f p = (dir_sensor * range).cast<float>();
      msg.xyz.push_back({p.x(), p.y(), p.z()});
      msg.ring.push_back(static_cast<int16_t>(ring));
    }
  }
  msg.npoints = msg.nring = static_cast<int32_t>(msg.xyz.size());
  msg.nintensity = 0;
  return msg;
}

}  // namespace calib
