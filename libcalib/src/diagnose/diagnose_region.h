#pragma once
// The floor effects tested over regions of the route (diagnose_region.cc). Internal to libcalib.

#include <vector>

#include "calib/diagnose/diagnose.h"
#include "calib/diagnose/selection.h"
#include "diagnose/diagnose_candidates.h"
#include "diagnose/diagnose_fit.h"

namespace calib::diag {

// Floor effects (longitudinal and lateral slip) the whole recording did not show, tested over
// boxes of the route at the final model `current`: a region that passes turns its candidate's
// outcome to found and adds the effect, with its box, to report->effects; one that does not adds
// to the candidate's note.
void TestRegions(const Recording& recording, const std::vector<Candidate>& cands, const Fit& current,
                 const SelectionLevels& levels, DiagnoseReport* report);

}  // namespace calib::diag
