// The selection of effects run on the fits of a recording (selection_fits.h).

#include "diagnose/selection_fits.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "calib/core/progress.h"
#include "calib/core/statistics.h"
#include "diagnose/diagnose_candidates.h"
#include "diagnose/diagnose_describe.h"
#include "diagnose/diagnose_heldout.h"
#include "diagnose/diagnose_internal.h"
#include "diagnose/diagnose_region.h"

namespace calib::diag {
namespace {

// The selection's fits of the recording (selection.h SelectionFits); an added candidate starts
// from its single fit.
class RecordingFits : public SelectionFits {
 public:
  RecordingFits(const Recording& recording, int jobs, const std::vector<Candidate>& cands,
                const std::vector<Fit>& single, const Fit& f0, double log_n);
  // The catalogue's pairs both of whose members are candidates, fitted together from the baseline.
  std::vector<PairFit> FitPairs(const std::vector<ConfusablePair>& catalogue);
  const Fit& current() const { return current_; }
  const std::vector<PairFit>& pairs() const { return pairs_; }
  const std::vector<Fit>& joints() const { return joints_; }  // per pair

  bool PairConfirmed(int k) override;
  void StartFromPair(int k) override;
  StepTest TryAdd(int j) override;
  bool AddConfirmed(int j) override;
  void Add(int j) override;
  StepTest TryKeep(int j) override;
  bool KeepConfirmed(int j) override;
  void Drop(int j) override;
  LookAlikeFit FitLookAlike(int x, int y) override;
  StepTest TrySwap(int x, int y) override;
  bool SwapConfirmed(int x, int y) override;
  void Swap(int x, int y) override;

 private:
  const Recording& recording_;
  const int jobs_;
  const std::vector<Candidate>& cands_;
  const std::vector<Fit>& single_;
  const Fit& f0_;
  const double log_n_;
  Fit current_;
  std::vector<PairFit> pairs_;
  std::vector<Fit> joints_;  // per pair
  std::vector<Fit> trials_;  // per candidate: its last TryAdd
  Fit with_, without_;       // the last TryKeep, or TrySwap (the model with the look-alike, without both)
  std::vector<int> others_;  // free in `without_`
  Fit lookalike_;            // the last FitLookAlike's joint fit, of look-alike `lookalike_of_`
  int lookalike_of_ = -1;
};

// The calibration on the fit blocks without effects, twice (the second from the first's values),
// then once more at the variance factor it sets (recording->noise_scale2): every later chi-square
// is in that scale. The report gets the factor and the counts of intervals.
Fit FitBaseline(const Model& start, Recording* recording, DiagnoseReport* report) {
  recording->noise_scale2 = 1.0;
  Fit f0 = FitModel(*recording, start, {}, {});
  f0 = FitModel(*recording, f0.m, {}, {});
  const int dof_base = 3 * f0.n_fit - (5 - int(recording->held_params.size())) - 3;
  recording->noise_scale2 = f0.chi2_fit / std::max(1, dof_base);
  f0 = FitModel(*recording, f0.m, {}, {});
  report->variance_factor = recording->noise_scale2;
  for (const Interval& it : recording->intervals) {
    report->fit_intervals += (!it.heldout && !it.outlier);
    report->heldout_intervals += (it.heldout && !it.outlier);
    report->outliers += it.outlier;
  }
  return f0;
}

// Every candidate fitted alone on the baseline.
std::vector<Fit> FitSingles(const Recording& recording, const std::vector<Candidate>& cands, const Fit& f0,
                            double offset_start_s, const DiagnoseOptions& options) {
  // Independent fits on the worker threads, each into its own slot; the progress lines come
  // from this thread in the catalogue's order, each before its candidate's result is awaited.
  std::vector<Fit> single(cands.size());
  const ProgressEstimate estimate(static_cast<int>(cands.size()));
  auto fit = [&](std::size_t j) {
    const Candidate& c = cands[j];
    Model from = f0.m;
    // The time offset's cost has local minima a sample period apart (encoder ticks): start
    // it where the calibration's own joint estimate put it.
    if (c.beta[0] == kTimeOffset) from.beta[kTimeOffset] = offset_start_s;
    // A lag's cost is far from quadratic in tau: fitted from zero, a local fit stops well short of
    // a large lag. Global before local: the best of a grid over its range.
    if (c.beta[0] == kLag) from.beta[kLag] = BestOnGrid(recording, from, kLag, {0.0, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4});
    single[j] = FitModel(recording, from, c.beta, c.beta);
  };
  auto report = [&](std::size_t j) {
    const Candidate& c = cands[j];
    if (options.progress)
      options.progress("testing " + c.name + (c.wheel.empty() ? "" : " (" + c.wheel + ")") + " (" +
                       estimate.Label(static_cast<int>(j)) + ")");
  };
  ParallelFor(cands.size(), WorkerThreads(options.jobs), fit, report);
  return single;
}

// The figures the selection judges each single fit by (selection.h SingleFit).
std::vector<SingleFit> SingleFigures(const Recording& recording, const std::vector<Candidate>& cands,
                                     const std::vector<Fit>& single, const Fit& f0, double log_n, int jobs) {
  std::vector<SingleFit> out(cands.size());
  ParallelFor(cands.size(), WorkerThreads(jobs), [&](std::size_t j) {  // each into its own slot
    const Candidate& c = cands[j];
    const Fit& f = single[j];
    SingleFit& s = out[j];
    s.name = c.name, s.layer = c.layer, s.wheel = c.wheel;
    s.p = f.p;
    s.delta_bic = DeltaBic(f.chi2_fit, f0.chi2_fit, c.beta.size(), log_n);
    double var = 0, info_var = 0;
    for (std::size_t i = 0; i < c.beta.size(); ++i) {
      var += f.cov(i, i) / c.beta.size();
      info_var += f.info_cov(i, i) / c.beta.size();
    }
    const double sigma = std::sqrt(std::max(var, 0.0));
    s.params = static_cast<int>(c.beta.size());
    s.bic_drop = c.beta.size() * log_n;
    s.information_std = std::sqrt(std::max(info_var, 0.0));
    s.estimate = {c.beta.size() == 2 ? std::hypot(f.m.beta[c.beta[0]], f.m.beta[c.beta[1]]) : f.m.beta[c.beta[0]], sigma};
    s.plausible = c.plausible;
    s.excitation = c.excitation;
    const Localized where = Localize(recording, c, f.m, f0.m);
    s.heldout_gain = HeldoutGain(f0, f), s.span_gain = where.span_gain();
    s.heldout_confirmed = ScoreConfirmed(recording, f0, f) || DriftConfirmed(recording, f0, f, where.comp == 2);
  });
  return out;
}

RecordingFits::RecordingFits(const Recording& recording, int jobs, const std::vector<Candidate>& cands,
                             const std::vector<Fit>& single, const Fit& f0, double log_n)
    : recording_(recording), jobs_(jobs), cands_(cands), single_(single), f0_(f0), log_n_(log_n), current_(f0),
      trials_(cands.size()) {}

std::vector<PairFit> RecordingFits::FitPairs(const std::vector<ConfusablePair>& catalogue) {
  for (const ConfusablePair& pair : catalogue) {
    int ia = -1, ib = -1;
    for (std::size_t j = 0; j < cands_.size(); ++j) {
      if (cands_[j].name == pair.a) ia = int(j);
      if (cands_[j].name == pair.b) ib = int(j);
    }
    if (ia < 0 || ib < 0) continue;
    PairFit pf;
    pf.pair = &pair, pf.a = ia, pf.b = ib;
    pairs_.push_back(pf);
  }
  // The joint fits are independent: on the worker threads, each into its own slot.
  joints_.assign(pairs_.size(), Fit());
  ParallelFor(pairs_.size(), WorkerThreads(jobs_), [&](std::size_t k) {
    const int ba = cands_[pairs_[k].a].beta[0], bb = cands_[pairs_[k].b].beta[0];
    Model startm = f0_.m;
    startm.beta[ba] = single_[pairs_[k].a].m.beta[ba];
    startm.beta[bb] = single_[pairs_[k].b].m.beta[bb];
    joints_[k] = FitAcrossOffsetMinima(recording_, startm, {ba, bb}, {ba, bb});
  });
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const Fit& joint = joints_[k];
    PairFit& pf = pairs_[k];
    pf.p = joint.p, pf.wald = joint.wald;
    pf.delta_bic = DeltaBic(joint.chi2_fit, f0_.chi2_fit, 2, log_n_);
    pf.var_a = joint.cov(0, 0), pf.var_b = joint.cov(1, 1);
    pf.correlation = Correlation(joint.cov, 0, 1);
  }
  return pairs_;
}

bool RecordingFits::PairConfirmed(int k) {
  return HeldoutConfirms(recording_, cands_[pairs_[k].a], f0_, joints_[k]);
}

void RecordingFits::StartFromPair(int k) { current_ = joints_[k]; }

StepTest RecordingFits::TryAdd(int j) {
  const Candidate& c = cands_[j];
  std::vector<int> free = current_.free;
  free.insert(free.end(), c.beta.begin(), c.beta.end());
  Model startm = current_.m;
  for (int b : c.beta) startm.beta[b] = single_[j].m.beta[b];
  // A time offset's look-alike added beside it: the offset fitted alone took up the look-alike's
  // share, and the joint minimum may lie in another of the offset's basins.
  const bool beside_its_look_alike = std::any_of(pairs_.begin(), pairs_.end(), [&](const PairFit& pf) {
    const int other = pf.a == j ? pf.b : pf.b == j ? pf.a : -1;
    return other >= 0 && cands_[other].beta[0] == kTimeOffset &&
           std::find(current_.free.begin(), current_.free.end(), int(kTimeOffset)) != current_.free.end();
  });
  trials_[j] = beside_its_look_alike ? FitAcrossOffsetMinima(recording_, startm, free, c.beta)
                                     : FitModel(recording_, startm, free, c.beta);
  // The look-alike's joint fit with the current model is this model too, fitted from more starts.
  if (lookalike_of_ == j && lookalike_.free == free && lookalike_.chi2_fit < trials_[j].chi2_fit) trials_[j] = lookalike_;
  const Fit& f = trials_[j];
  return {f.p, f.wald, DeltaBicAt(current_, f0_, f.chi2_fit, current_.chi2_fit, c.beta.size(), log_n_)};
}

bool RecordingFits::AddConfirmed(int j) { return HeldoutConfirms(recording_, cands_[j], current_, trials_[j]); }

void RecordingFits::Add(int j) { current_ = trials_[j]; }

StepTest RecordingFits::TryKeep(int j) {
  without_ = FitWithout(recording_, current_, cands_[j].beta, &others_);
  with_ = FitModel(recording_, current_.m, current_.free, cands_[j].beta);
  return {with_.p, with_.wald, 0.0};
}

bool RecordingFits::KeepConfirmed(int j) { return HeldoutConfirms(recording_, cands_[j], without_, with_); }

void RecordingFits::Drop(int j) { current_ = FitModel(recording_, without_.m, others_, {}); }

// A candidate's size in `f` (the norm of a two-parameter effect) and its std, its terms at
// positions `at` of `f`'s free parameters.
ParamEstimate SizeIn(const Fit& f, const Candidate& c, const std::vector<int>& at) {
  double var = 0;
  for (int i : at) var += f.cov(i, i) / at.size();
  const double size = c.beta.size() == 2 ? std::hypot(f.m.beta[c.beta[0]], f.m.beta[c.beta[1]]) : f.m.beta[c.beta[0]];
  return {size, std::sqrt(std::max(var, 0.0))};
}

// Where effect `c`'s terms sit among `free`.
std::vector<int> PlacesOf(const Candidate& c, const std::vector<int>& free) {
  std::vector<int> at;
  for (int b : c.beta) at.push_back(int(std::find(free.begin(), free.end(), b) - free.begin()));
  return at;
}

LookAlikeFit RecordingFits::FitLookAlike(int x, int y) {
  const Candidate &cx = cands_[x], &cy = cands_[y];
  std::vector<int> free = current_.free;
  free.insert(free.end(), cy.beta.begin(), cy.beta.end());
  Model startm = current_.m;
  for (int b : cy.beta) startm.beta[b] = single_[y].m.beta[b];
  Fit joint = FitAcrossOffsetMinima(recording_, startm, free, cy.beta);
  // From the current model the chosen one has taken up the look-alike's share (a time offset's
  // cost has minima a sample period apart): from its own single fit too, and the better fit.
  for (int b : cx.beta) startm.beta[b] = single_[x].m.beta[b];
  Fit from_single = FitModel(recording_, startm, free, cy.beta);
  if (from_single.chi2_fit < joint.chi2_fit) joint = std::move(from_single);
  lookalike_ = joint, lookalike_of_ = y;
  const std::vector<int> ax = PlacesOf(cx, free), ay = PlacesOf(cy, free);
  LookAlikeFit out;
  out.correlation = Correlation(joint.cov, ax[0], ay[0]);
  out.x = SizeIn(joint, cx, ax), out.y = SizeIn(joint, cy, ay);
  // x's Wald statistic given y (and the rest), over as many degrees as it has terms.
  Eigen::VectorXd b(ax.size());
  Eigen::MatrixXd v(ax.size(), ax.size());
  for (std::size_t i = 0; i < ax.size(); ++i) {
    b(i) = joint.m.beta[cx.beta[i]];
    for (std::size_t k = 0; k < ax.size(); ++k) v(i, k) = joint.cov(ax[i], ax[k]);
  }
  const bool usable = v.determinant() > 0;
  out.p_x = usable ? ChiSquareUpperTail(b.dot(v.ldlt().solve(b)), int(ax.size())) : 1.0;
  out.p_y = joint.p;
  return out;
}

StepTest RecordingFits::TrySwap(int x, int y) {
  const Candidate& c = cands_[y];
  without_ = FitWithout(recording_, current_, cands_[x].beta, &others_);
  std::vector<int> free = others_;
  free.insert(free.end(), c.beta.begin(), c.beta.end());
  Model startm = without_.m;
  for (int b : c.beta) startm.beta[b] = single_[y].m.beta[b];
  with_ = FitModel(recording_, startm, free, c.beta);
  return {with_.p, with_.wald, DeltaBicAt(without_, f0_, with_.chi2_fit, without_.chi2_fit, c.beta.size(), log_n_)};
}

bool RecordingFits::SwapConfirmed(int, int y) { return HeldoutConfirms(recording_, cands_[y], without_, with_); }

void RecordingFits::Swap(int, int) { current_ = with_; }

// The fits the report stands on that stopped short of convergence, as warnings.
void NoteUnconverged(const std::vector<Candidate>& cands, const std::vector<Fit>& single, const RecordingFits& fits,
                     const Fit& f0, DiagnoseReport* report) {
  auto note = [&](const std::string& what, const Fit& f) {
    if (!f.not_converged.empty()) report->warnings.push_back("the fit of " + what + " " + f.not_converged);
  };
  note("the baseline", f0);
  for (std::size_t j = 0; j < cands.size(); ++j)
    note(cands[j].name + (cands[j].wheel.empty() ? "" : " (" + cands[j].wheel + ")") + " alone", single[j]);
  for (std::size_t k = 0; k < fits.pairs().size(); ++k)
    note(std::string(fits.pairs()[k].pair->a) + " with " + fits.pairs()[k].pair->b, fits.joints()[k]);
  note("the final model", fits.current());
}

}  // namespace

SelectionPass SelectOnRecording(const RobotDescription& robot, const DiagnoseData& data,
                                const DiagnoseOptions& options, const SelectionStart& start, Recording* recording) {
  SelectionPass pass;
  DiagnoseReport& report = pass.report;
  report.drive = robot.drive;
  report.source = data.source;
  report.param_names = ParamNames(robot.drive);
  report.notes = start.notes;
  const Fit f0 = FitBaseline(start.model, recording, &report);

  // Every candidate against the baseline.
  const std::vector<Candidate> cands = Candidates(robot, data, recording->max_offset_s);
  const int m_odo = static_cast<int>(cands.size());
  const int m_act = ActuationCandidates(robot, data);
  SelectionLevels& levels = pass.levels;
  levels.candidates = m_odo;
  levels.actuation_candidates = m_act;
  levels.alpha = options.alpha * m_odo / double(m_odo + m_act);
  const double log_n = std::log(3.0 * f0.n_fit);
  const std::vector<Fit> single = FitSingles(*recording, cands, f0, start.time_offset_s, options);
  SingleVerdicts verdicts = JudgeSingles(SingleFigures(*recording, cands, single, f0, log_n, options.jobs), levels);

  // Every confusable pair fitted together from the baseline: the detectable sizes when the
  // look-alike is present too, and the pair's joint test in the selection.
  RecordingFits fits(*recording, options.jobs, cands, single, f0, log_n);
  const std::vector<PairFit> pairs = fits.FitPairs(Confusable());
  NoteDetectableWith(pairs, levels, &verdicts.outcomes);
  const Selection selection = SelectEffects(Confusable(), pairs, verdicts.eligible, levels, &fits,
                                            &verdicts.outcomes, &report.indistinguishable);

  // The final model and what each chosen effect contributes.
  const Fit& current = fits.current();
  DescribeModel(*recording, f0, current, &report);
  ReportFound(*recording, cands, selection, levels, f0, current, log_n, &report);
  ReportCalibration(*recording, data.source, f0, current, *start.calibration, &report);
  report.candidates = verdicts.outcomes;
  report.borderline = BorderlineDecisions(verdicts.outcomes, selection, levels);
  report.moved = MovedEffects(report.effects, verdicts.outcomes);
  TestRegions(*recording, cands, current, levels, &report);
  NoteUnconverged(cands, single, fits, f0, &report);
  pass.chosen = current.m;
  for (const Fit& f : single) pass.alternatives.push_back(f.m);
  return pass;
}

}  // namespace calib::diag
