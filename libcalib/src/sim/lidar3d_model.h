#pragma once
// The simulated 3D lidar: its orientation on the (possibly turning) mount and the rings of
// returns it sees in the world and on the robot's own body.

#include <random>

#include "agvcal/point_cloud_t.hpp"
#include "calib/core/se2.h"
#include "calib/sim/simulator.h"
#include "calib/sim/world.h"

namespace calib {

// One cloud (xyz in the sensor frame, and rings; utime left 0) from the robot at `pose`
// (world), the lidar mounted at `mount` with the turret at `turret_angle`. The range noise
// draws one `normal` sample of `rng` per ray, hit or not, so the stream does not depend on
// what the rays hit.
agvcal::point_cloud_t SimulateCloud(const World& world, const Lidar3dSensorConfig& sensor,
                                    const Mount3d& mount, const Pose2& pose, double turret_angle,
                                    std::mt19937_64* rng, std::normal_distribution<double>* normal);

}  // namespace calib
