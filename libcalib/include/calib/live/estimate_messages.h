#pragma once
// The live solver's output on the bus (CALIB_ESTIMATE, CALIB_RESIDUALS of
// spec/messages.md) from the calibration's plain results. Kept at the live edge
// so that io/messages.h, below the calibration, needs none of its types.

#include <cstdint>
#include <string>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/calib_residual_t.hpp"
#include "calib/calibrate/calibration.h"

namespace calib {

// The live solver's estimate; `status` and `message` as in calib_estimate_t.
agvcal::calib_estimate_t ToMessage(const CalibrationResult& result, int64_t utime,
                                   const std::string& status);
agvcal::calib_residual_t ToMessage(const IntervalResidual& residual);

}  // namespace calib
