#pragma once
// Closed-form first estimates of the drive parameters and the sensor mount,
// the starting point of the maximum-likelihood refinement (calibration.h).
//
// Each drive type in two linear steps (Censi, Franchi, Marchionni, Oriolo,
// T-RO 2013, generalised):
//   1. rotation: the heading change of each interval is linear in two unknowns:
//      differential  dtheta = J21 phi_L + J22 phi_R (J21 = -r_L/b, J22 = r_R/b);
//      tricycle      dtheta = (r/L) sum phi sin(alpha - offset), linear in
//                    (r/L) (cos offset, sin offset);
//      dual steer    the same as a tricycle on a1 (wheelbase b) over intervals
//                    where a2 stands at zero steering (W then cannot slide).
//   2. translation: with the ratios known, the robot's translation is one scale
//      s (b, or the drive radius) times a known vector c_k, and
//      s c_k - (I - R(dtheta_k)) l_xy - R(l_theta) z_xy = 0; minimised over
//      (s, l_x, l_y, cos l_theta, sin l_theta) on the unit circle of the last
//      two, which is a 2x2 eigenproblem after eliminating the first three.
//   3. dual steer only: a2 travels as far as W's x motion plus a times the
//      rotation, r2 phi2 = dx + a dtheta: linear in (r2, a).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/wheel_track.h"

namespace calib {

// One interval: the encoder steps over [utime_start, utime_end] of `wheels` and the sensor's
// measured motion. The steps are taken from the track when needed, not held: held for every
// interval of a long recording they took several times the track's own memory.
struct MotionInterval {
  const WheelTrack* wheels = nullptr;
  int64_t utime_start = 0, utime_end = 0;
  Pose2 sensor_motion;
  std::vector<WheelIncrement> steps() const { return wheels->Increments(utime_start, utime_end); }
};

struct ClosedFormEstimate {
  bool ok = false;
  std::string problem;                  // why not, when !ok
  std::map<std::string, double> params;  // ParamNames(type)
  Pose2 mount;
  double rotation_condition = 0.0;  // of the rotation step's normal matrix
};

// `nominal` supplies the signs the data cannot (e.g. which side of W a1 is on).
ClosedFormEstimate ClosedFormCalibration(DriveType type,
                                         const std::map<std::string, double>& nominal,
                                         const std::vector<MotionInterval>& intervals);

}  // namespace calib
