#pragma once
// The selection of effects (selection.h) run on the fits of a recording (internal to libcalib):
// the baseline, every candidate of the catalogue fitted alone, the confusable pairs fitted
// together, then the forward and backward steps of SelectEffects on those fits, and the report
// of the final model.

#include <string>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"
#include "calib/diagnose/diagnose.h"
#include "calib/diagnose/selection.h"
#include "diagnose/diagnose_fit.h"

namespace calib::diag {

// Where a selection starts.
struct SelectionStart {
  Model model;                                   // the calibration's values, no effect
  const CalibrationResult* calibration = nullptr;  // its stds (the report's calibration)
  double time_offset_s = 0;   // the calibration's joint estimate: the time offset's fit starts there
  std::vector<std::string> notes;  // the report's notes so far
};

// One pass of the selection.
struct SelectionPass {
  DiagnoseReport report;             // all but the actuation layer and the unexplained structure
  Model chosen;                      // the final model
  std::vector<Model> alternatives;   // every candidate's single fit
  SelectionLevels levels;            // how the family-wise rate was shared
};

// Sets the recording's noise scale to the baseline's variance factor.
SelectionPass SelectOnRecording(const RobotDescription& robot, const DiagnoseData& data,
                                const DiagnoseOptions& options, const SelectionStart& start, Recording* recording);

}  // namespace calib::diag
