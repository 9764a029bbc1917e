// The diagnosis of a recording (diagnose.h), as a recipe: the calibration it starts from, the
// recording cut into intervals, the outliers gated, the effects selected (selection_fits.h; again
// while the gate changes), then the actuation layer and the structure left unexplained. Each step
// has its own room: diagnose_fit (the fits), diagnose_heldout (the held-out proofs),
// selection_fits and selection (the choice of effects), diagnose_region (effects of a region of
// the floor), diagnose_actuation (commands against encoders), discover (physics outside the
// catalogue, and the misfit the verdict reads), diagnose_describe (what the report
// says of the model), diagnose_read (the recording), diagnose_output (the report's files).

#include "calib/diagnose/diagnose.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/undetermined.h"
#include "calib/core/errors.h"
#include "calib/core/progress.h"
#include "calib/core/units.h"
#include "diagnose/diagnose_candidates.h"
#include "diagnose/diagnose_describe.h"
#include "diagnose/diagnose_fit.h"
#include "diagnose/diagnose_internal.h"
#include "diagnose/discover.h"
#include "diagnose/selection_fits.h"

namespace calib {
namespace {
using namespace diag;

// The calibrations the diagnosis starts from, on the whole recording.
struct StartingCalibrations {
  CalibrationResult plain;        // its values are the start, its stds the report's
  CalibrationResult with_offset;  // its time offset is where the time offset's fit starts
};

class Diagnoser {
 public:
  Diagnoser(const RobotDescription& robot, const DiagnoseData& data, const DiagnoseOptions& options,
            const std::string& origin)
      : robot_(robot), data_(data), options_(options), origin_(origin) {}

  DiagnoseReport Run();

 private:
  void Progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }
  StartingCalibrations Calibrations();
  CalibrationResult WithCandidateInside(const CalibrationResult& unchecked, const UnobservableError& refused);
  SelectionStart StartFrom(const CalibrationResult& calibration, double time_offset_s);
  SelectionPass SelectUntilTheGateHolds(const SelectionStart& start);

  const RobotDescription& robot_;
  const DiagnoseData& data_;
  const DiagnoseOptions& options_;
  const std::string origin_;
  Recording recording_;
  std::vector<std::string> notes_;  // the report's notes on how the diagnosis started
};

DiagnoseReport Diagnoser::Run() {
  recording_.num_params = static_cast<int>(ParamNames(robot_.drive).size());
  recording_.hac_lags = options_.hac_lags;
  recording_.drift_window_s = options_.drift_window_s;
  recording_.max_iterations = options_.max_iterations;
  BuildIntervals(robot_, data_, options_.block_s, origin_, &recording_);
  const StartingCalibrations calibrations = Calibrations();
  const SelectionStart start = StartFrom(calibrations.plain, calibrations.with_offset.time_offset->value);
  SelectionPass pass = SelectUntilTheGateHolds(start);
  DiagnoseReport& report = pass.report;
  std::vector<std::string> warnings;
  for (const CalibrationResult* calibration : {&calibrations.plain, &calibrations.with_offset})
    for (const std::string& warning : calibration->warnings) warnings.push_back("the starting calibration: " + warning);
  report.warnings.insert(report.warnings.begin(), warnings.begin(), warnings.end());
  DescribeOutliers(&report);
  const SelectionLevels& levels = pass.levels;
  const double actuation_alpha =
      options_.alpha * levels.actuation_candidates / double(levels.candidates + levels.actuation_candidates);
  DiagnoseActuation(robot_, data_, options_, actuation_alpha, &report);
  DiscoverTerms(recording_, pass.chosen, options_.alpha, &report);
  FindUnexplained(recording_, options_.alpha, &report);
  std::stable_sort(report.unexplained.begin(), report.unexplained.end(),
                   [](const Unexplained& a, const Unexplained& b) { return a.p_value < b.p_value; });
  if (report.unexplained.size() > 3) report.unexplained.resize(3);  // the strongest; the rest add little
  report.verdict = Verdict(report);
  return std::move(report);
}

// The calibration of calibration.h on everything (only a start), without and with the time
// offset, side by side (they are independent). Where `agvcal solve` refuses (a straight-only
// recording), so does the diagnosis: a model with parameters held at their nominal values would
// blame their error on missing physics, or call the recording explained (spec/cli.md: exit 3,
// naming what and the motion to add).
StartingCalibrations Diagnoser::Calibrations() {
  CalibrationOptions co;
  CalibrationOptions co_offset = co;
  co_offset.check_observability = false;
  co_offset.estimate_time_offset = true;
  // The offset is searched over the widest range at once: a narrower search can settle inside its
  // range on a minimum an encoder or scan period from a larger offset, and never widen.
  co_offset.max_time_offset_s = kWidestTimeOffsetS;
  std::optional<CalibrationResult> cal_plain, cal_offset;
  std::optional<UnobservableError> refused;
  ParallelFor(2, WorkerThreads(options_.jobs), [&](std::size_t k) {
    if (k == 1) {
      try {
        cal_offset = Calibrate(robot_, data_.wheels, data_.motions, data_.source, co_offset, origin_);
      } catch (const InputError&) {
        // A recording too short for the widest range's margins: the narrower search widens itself.
        CalibrationOptions narrower = co_offset;
        narrower.max_time_offset_s = kMaxOffsetS;
        cal_offset = Calibrate(robot_, data_.wheels, data_.motions, data_.source, narrower, origin_);
      }
      return;
    }
    try {
      cal_plain = Calibrate(robot_, data_.wheels, data_.motions, data_.source, co, origin_);
    } catch (const UnobservableError& e) {
      refused = e;
    }
  });
  if (refused) {
    // A large time offset the plain calibration ignores can make it refuse a mount parameter the
    // recording determines once the offset is modelled: then the calibration with the offset,
    // which must determine everything, is the start.
    CalibrationOptions checked = co_offset;
    checked.check_observability = true;
    try {
      cal_plain = Calibrate(robot_, data_.wheels, data_.motions, data_.source, checked, origin_);
      notes_.push_back("the calibration without a time offset refuses (" + std::string(refused->what()) +
                       "); the one with the offset is the start");
    } catch (const UnobservableError&) {
      cal_plain = WithCandidateInside(*cal_offset, *refused);
    }
  }
  // The diagnosis fits the offset near the calibration's, within kMaxOffsetS of it: a short
  // recording keeps the intervals a two-second margin would cost, and a small offset is not
  // searched across two seconds, where a scan period away from it lies another minimum.
  const double found_s = cal_offset->time_offset ? std::abs(cal_offset->time_offset->value) : 0.0;
  const double wanted_s = std::min(cal_offset->time_offset_bound_s, found_s + kMaxOffsetS);
  if (wanted_s > recording_.max_offset_s) {
    // The intervals again, with room for the wider offset on the wheel data.
    recording_.max_offset_s = wanted_s;
    BuildIntervals(robot_, data_, options_.block_s, origin_, &recording_);
  }
  return {std::move(*cal_plain), std::move(*cal_offset)};
}

// A strong effect the calibration leaves out can make it refuse: its residual swamps what the
// drive parameters explain. Before giving up, each candidate of the catalogue is fitted inside the
// baseline (from the calibration's unchecked values); the one that determines everything with the
// lowest chi-square gives the start (its values and stds). When none does, the refusal names
// only what stays undetermined with the best of them, with estimate and sigma.
CalibrationResult Diagnoser::WithCandidateInside(const CalibrationResult& unchecked,
                                                 const UnobservableError& refused) {
  const std::vector<std::string>& names = ParamNames(robot_.drive);
  const std::string sensor = MotionSourceName(data_.source);
  const std::string estimate_names[3] = {sensor + ".x", sensor + ".y", sensor + ".yaw"};
  Model start;
  for (int i = 0; i < recording_.num_params; ++i) start.params[i] = unchecked.params.at(names[i]).value;
  const Estimate* mount[3] = {&unchecked.mount_x, &unchecked.mount_y, &unchecked.mount_yaw};
  for (int k = 0; k < 3; ++k) start.mount[k] = mount[k]->value;
  start.beta[kTimeOffset] = unchecked.time_offset ? unchecked.time_offset->value : 0.0;
  for (int i = recording_.num_params; i < 5; ++i) recording_.held_params.push_back(i);
  recording_.noise_scale2 = 1.0;
  Gate({FitModel(recording_, start, {kTimeOffset}, {}).m}, &recording_);
  // What stays undetermined under fit `f`, as "name estimate ± sigma" (empty: nothing).
  auto undetermined = [&](const Fit& f) {
    std::vector<std::string> out;
    for (int i = 0; i < 5 + 3; ++i) {
      if (i >= recording_.num_params && i < 5) continue;
      const std::string name = i < 5 ? names[i] : estimate_names[i - 5];
      const double value = i < 5 ? f.m.params[i] : f.m.mount[i - 5];
      const double nominal = i < 5 ? robot_.params.at(names[i]) : 0.0;
      if (!(f.calibration_std[i] <= UndeterminedAbove(robot_.drive, name, nominal)))
        out.push_back(name + " " + EstimateText(value, f.calibration_std[i], ParamUnit(name)));
    }
    return out;
  };
  const std::vector<Candidate> cands = Candidates(robot_, data_, recording_.max_offset_s);
  int best = -1;
  Fit best_fit;
  std::vector<std::string> best_left;
  for (std::size_t j = 0; j < cands.size(); ++j) {
    std::vector<int> free = cands[j].beta;
    if (cands[j].beta[0] != kTimeOffset) free.push_back(kTimeOffset);
    Fit f = FitModel(recording_, start, free, {});
    const std::vector<std::string> left = undetermined(f);
    if (best < 0 || left.size() < best_left.size() ||
        (left.size() == best_left.size() && f.chi2_fit < best_fit.chi2_fit))
      best = int(j), best_fit = std::move(f), best_left = left;
  }
  recording_.held_params.clear();
  for (Interval& it : recording_.intervals) it.outlier = false;
  const std::string refused_what = refused.what();
  const std::string cause = refused_what.substr(0, refused_what.size() - std::min(refused_what.size(), refused.remedy().size() + 2));
  const std::string with = best < 0 ? "" : cands[best].name + (cands[best].wheel.empty() ? "" : " (" + cands[best].wheel + ")");
  if (best < 0 || !best_left.empty()) {
    std::string what = origin_ + ": the recording cannot determine ";
    for (std::size_t k = 0; k < best_left.size(); ++k) what += (k ? "; " : "") + best_left[k];
    throw UnobservableError(what + (best < 0 ? "" : " even with " + with + " modelled inside the baseline") +
                                ", so the calibration the diagnosis compares with cannot be made (" + cause + ")",
                            refused.remedy());
  }
  CalibrationResult out = unchecked;
  for (int i = 0; i < recording_.num_params; ++i)
    out.params[names[i]] = {best_fit.m.params[i], best_fit.calibration_std[i], robot_.params.at(names[i])};
  Estimate* out_mount[3] = {&out.mount_x, &out.mount_y, &out.mount_yaw};
  for (int k = 0; k < 3; ++k) out_mount[k]->value = best_fit.m.mount[k], out_mount[k]->std = best_fit.calibration_std[5 + k];
  notes_.push_back("the calibration refuses (" + cause + "); with " + with +
                   " modelled inside the baseline the recording determines every parameter: its values are the start");
  return out;
}

// The calibration's values as the model to start from; a drive parameter the recording does not
// determine is held at its nominal value (and said so).
SelectionStart Diagnoser::StartFrom(const CalibrationResult& calibration, double time_offset_s) {
  const std::vector<std::string>& names = ParamNames(robot_.drive);
  SelectionStart start;
  Model& model = start.model;
  for (int i = 0; i < recording_.num_params; ++i) {
    model.params[i] = calibration.params.at(names[i]).value;
    if (!std::isfinite(calibration.params.at(names[i]).std)) {
      recording_.held_params.push_back(i);
      model.params[i] = robot_.params.at(names[i]);
      notes_.push_back(names[i] + " is not determined by this recording: held at nominal");
    }
  }
  for (int i = recording_.num_params; i < 5; ++i) recording_.held_params.push_back(i);
  model.mount[0] = calibration.mount_x.value;
  model.mount[1] = calibration.mount_y.value;
  model.mount[2] = calibration.mount_yaw.value;
  start.calibration = &calibration;
  start.time_offset_s = time_offset_s;
  start.notes = notes_;
  return start;
}

// Outliers are gated at the robust scale of the baseline; once the effects are known, again with
// them (a strong effect must not hide its own evidence), and the selection rerun until the
// outliers no longer change. Set aside is only what neither the model chosen nor any candidate's
// own fit explains: under the baseline alone, the intervals where an unmodelled effect acts most
// would be set aside, and with them its evidence.
SelectionPass Diagnoser::SelectUntilTheGateHolds(const SelectionStart& start) {
  Progress("baseline calibration on " + std::to_string(recording_.intervals.size()) + " intervals");
  recording_.noise_scale2 = 1.0;
  Gate({FitModel(recording_, start.model, {}, {}).m}, &recording_);
  SelectionPass pass = SelectOnRecording(robot_, data_, options_, start, &recording_);
  for (int gate = 1; gate < 4; ++gate) {
    std::vector<bool> before_gate;
    for (const Interval& it : recording_.intervals) before_gate.push_back(it.outlier);
    recording_.noise_scale2 = 1.0;
    std::vector<Model> models = pass.alternatives;
    models.push_back(pass.chosen);
    Gate(models, &recording_);
    bool changed = false;
    for (std::size_t k = 0; k < recording_.intervals.size(); ++k)
      changed = changed || before_gate[k] != recording_.intervals[k].outlier;
    if (!changed) break;
    Progress("outliers re-gated with the effects found; selecting again");
    pass = SelectOnRecording(robot_, data_, options_, start, &recording_);
  }
  return pass;
}

}  // namespace

DiagnoseReport Diagnose(const RobotDescription& robot, const DiagnoseData& data,
                        const DiagnoseOptions& options, const std::string& origin) {
  Diagnoser d(robot, data, options, origin);
  return d.Run();
}

}  // namespace calib
