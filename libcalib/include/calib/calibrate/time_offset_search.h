#pragma once
// Global search for the sensor-to-wheel time offset, before any local fit.
//
// The interval cost of a time offset has local minima an encoder or scan period apart and a basin
// only as wide as the motion's bandwidth allows, so a local fit started at zero stops in the
// nearest minimum, far from a large offset (docs/mismatch.md). So every estimate of the offset
// (`agvcal solve --time-offset`, calibration.cc, and `agvcal diagnose`, which starts from the
// calibration's joint estimate) starts from this search, and the local, joint fit refines it.
//
// The search: the wheel odometry under the drive parameters `params` (ParamNames order) is
// integrated once into a cumulative heading and path length over the encoder samples. For an
// offset d, interval k's wheel motion is the difference of those over [t0 - d, t1 - d]
// (interval_model.h's convention: a scan stamped t was taken at wheel time t - d), compared with
// the sensor's measured turn and travelled distance, each in units of the match's standard
// deviation: the cross-correlation of the wheel and scan-matched turn rates (and speeds), as a
// cost. The cost of an offset is the mean Cauchy cost of both residuals, each in its own robust
// scale (a wrong offset's large residuals, failed matches and unmodelled effects pull it only
// boundedly), on a 1 ms grid over [-max, max], then on a 0.05 ms grid around the best point. The
// scales are the residuals' median squares at the grid offset where their product is smallest,
// then again at the first pass's best. Every valid match counts at every offset (where an
// interval reaches beyond the wheel data, the wheel motion is held at the data's end), so nothing
// depends on where the offset lies in the range: shifting every sensor stamp moves the result by
// the shift. The heading and distance do not depend on the sensor's mount to first
// order, so the search needs no mount. Calibrate repeats the search (and its fit) over twice the
// range when the best lies at the bound (calibration.h kWidestTimeOffsetS).

#include <vector>

#include "calib/core/robot.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"

namespace calib {

struct TimeOffsetSearch {
  double offset_s = 0.0;       // the global minimum of the cost
  double cost = 0.0;           // mean Cauchy cost there (TimeOffsetSearch above)
  double cost_at_zero = 0.0;   // the same at offset 0
  int intervals = 0;           // intervals used
};

// The search over [-max_offset_s, max_offset_s]; `motions` the valid, non-degenerate ones are
// used (at least 10, else offset 0 is returned with intervals < 10).
TimeOffsetSearch SearchTimeOffset(DriveType drive, const double* params, const WheelTrack& wheels,
                                  const std::vector<SensorMotion>& motions, double max_offset_s);

}  // namespace calib
