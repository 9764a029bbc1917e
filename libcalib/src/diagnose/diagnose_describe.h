#pragma once
// What the diagnosis's report says of the model (internal to libcalib): each interval before and
// after with the motion it was driven under, each effect found with its size, where it acts and
// its held-out proof, the calibration before and after, the intervals set aside, and the residual
// structure no catalogued effect explains.

#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/diagnose/diagnose.h"
#include "calib/diagnose/selection.h"
#include "diagnose/diagnose_candidates.h"
#include "diagnose/diagnose_fit.h"

namespace calib::diag {

// The intervals under the baseline `f0` and the final model `current` (report->intervals, with
// the motion conditions under the baseline), and the held-out figures of both.
void DescribeModel(const Recording& recording, const Fit& f0, const Fit& current, DiagnoseReport* report);

// The effects the selection chose (report->effects; one not in effects.md: report->unexplained),
// each against the final model refitted without it.
void ReportFound(const Recording& recording, const std::vector<Candidate>& cands, const Selection& selection,
                 const SelectionLevels& levels, const Fit& f0, const Fit& current, double log_n,
                 DiagnoseReport* report);

// The calibration on the fit blocks (the baseline `f0`) and refitted with the effects found
// (`current`), with the stds of the calibration `cal`; the mount named after `source`.
void ReportCalibration(const Recording& recording, MotionSource source, const Fit& f0, const Fit& current,
                       const CalibrationResult& cal, DiagnoseReport* report);

// The share of intervals set aside and its correlation with each motion regressor.
void DescribeOutliers(DiagnoseReport* report);

// Residual structure the final model leaves that no catalogued effect explains: a held-out
// residual component trending with where or how the robot drove (at the family-wise `alpha`).
void FindUnexplained(const Recording& recording, double alpha, DiagnoseReport* report);

}  // namespace calib::diag
