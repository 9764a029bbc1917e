#pragma once
// Random sample consensus for a plane, through PCL. Kept behind this small
// interface so that PCL's headers are compiled in one file only
// (pcl/sac_plane.cc, linked into calib from the calib_pcl library).

#include <cstddef>
#include <optional>

#include <Eigen/Core>

namespace calib {

struct SacPlane {
  Eigen::Vector3d normal;  // unit, on the side of `axis`
  double d = 0.0;          // the plane is normal . p + d = 0
  int inliers = 0;
};

// The plane with the most points within `threshold_m` among `count` points
// (xyz interleaved), whose normal is within `max_angle_rad` of the unit
// `axis`; nothing if no such plane is found. Deterministic (PCL's fixed seed).
std::optional<SacPlane> FindPlaneSac(const float* xyz, size_t count, const Eigen::Vector3d& axis,
                                     double max_angle_rad, double threshold_m,
                                     int max_iterations);

}  // namespace calib
