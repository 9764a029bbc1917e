#pragma once
// Discovery of physics outside spec/effects.md (internal to libcalib), after the catalogue's
// selection: the terms of the library (core/physics_terms.h) fitted jointly with the calibration
// and the effects found, linearised at the final model (discover_columns.h), chosen by forward
// steps. A term joins when its Wald statistic, robust to the noise's scale and its correlation
// between neighbouring intervals (Newey-West, as the catalogue's), passes Holm's correction over
// the library at `alpha`, it lowers BIC, the held-out blocks confirm it (a one-sided score test
// at `alpha`) and no catalogued effect explains the same residual as well (the catalogue is
// preferred: nothing is reported twice). Then the final model's misfit is measured, with the
// terms found, against a well-fitting recording's.

#include "calib/diagnose/diagnose.h"
#include "diagnose/diagnose_fit.h"

namespace calib::diag {

// Appends the terms found to report->discovered (with their held-out figures and where they
// act), corrects the intervals' `after` residuals and the held-out RMS by them, and sets
// report->misfit. `final_model` is the catalogue's final model.
void DiscoverTerms(const Recording& recording, const Model& final_model, double alpha, DiagnoseReport* report);

// The verdict (spec/cli.md) from the effects found, the terms discovered and the misfit.
std::string Verdict(const DiagnoseReport& report);

}  // namespace calib::diag
