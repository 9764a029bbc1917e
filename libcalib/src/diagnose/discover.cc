#include "diagnose/discover.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "calib/core/physics_terms.h"
#include "diagnose/diagnose_internal.h"
#include "diagnose/discover_columns.h"
#include "diagnose/discover_fit.h"

namespace calib::diag {
namespace {

// At most this many terms: beyond, a recording explains noise better than physics.
constexpr int kMaxTerms = 3;
// Misfit: far beyond a well-fitting recording's (docs/effects.md "Discovered physics" measures
// both on controls and planted terms).
// A well-fitting simulated recording's variance factor lies near 1 (up to about 3 with coarse
// sensors); physics the model lacks shows from 5 times a control's.
constexpr double kMisfitVarianceFactor = 4.0;
constexpr double kMisfitDriftRatio = 3.0;

// The catalogued effects by their parameters (diagnose_model.h Beta), for the preference.
struct CataloguedGroup {
  const char* name;
  std::vector<int> betas;
};
const std::vector<CataloguedGroup>& CataloguedGroups() {
  static const std::vector<CataloguedGroup> groups = {
      {"time_offset", {kTimeOffset}},        {"longitudinal_slip", {kSlip}},
      {"lateral_slip", {kLateral}},          {"steering_lag", {kLag}},
      {"steering_backlash", {kBacklash}},    {"wheel_eccentricity", {kEcc0C, kEcc0S}},
      {"wheel_eccentricity", {kEcc1C, kEcc1S}}, {"scan_distortion", {kDistortion}}};
  return groups;
}

// A catalogued effect the selection declared that the discovered terms explain (its parameter no
// longer significant in the joint fit, at the catalogue-wide level) is not declared: the term
// explains its residual and more, and nothing is reported twice.
void DemoteExplained(const Recording& recording, const Model& model, const std::vector<int>& free_betas,
                     const LinearFit& all, double alpha, DiagnoseReport* report) {
  const int first_beta = int(FreeParams(recording).size()) + 3;
  const double m = double(CataloguedGroups().size());
  std::vector<FoundEffect> kept;
  for (const FoundEffect& e : report->effects) {
    bool explained = false;
    for (const CataloguedGroup& g : CataloguedGroups()) {
      if (e.name != g.name || g.betas.size() != 1) continue;
      const auto at = std::find(free_betas.begin(), free_betas.end(), g.betas[0]);
      if (at == free_betas.end()) continue;
      const int c = first_beta + int(at - free_betas.begin());
      const double value = model.beta[g.betas[0]] + all.coef[c], std = std::sqrt(std::max(all.cov(c, c), 0.0));
      explained = std > 0 && std::erfc(std::abs(value / std) / std::sqrt(2.0)) * m >= alpha;
    }
    if (explained)
      for (CandidateOutcome& c : report->candidates)
        if (c.name == e.name && c.wheel == e.wheel && c.status == CandidateStatus::kFound) {
          c.status = CandidateStatus::kRejected;
          c.note = "explained by the discovered terms";
        }
    if (explained)
      report->notes.push_back(e.name + ", declared by the catalogue's selection, is explained by the discovered "
                               "terms (not significant beside them): not declared");
    else
      kept.push_back(e);
  }
  report->effects = kept;
}

struct Step {
  int term = -1;
  double z = 0, p = 1;
};

class Discovery {
 public:
  Discovery(const Recording& recording, const Model& m, double alpha, DiagnoseReport* report)
      : recording_(recording), alpha_(alpha), report_(report), model_(m) {
    terms_ = LibraryTerms(recording.track.drive);
    for (int j = 0; j < kNumBeta; ++j)
      if (m.beta[j] != 0.0) free_betas_.push_back(j);
    rows_ = DiscoveryRows(recording, m, terms_, free_betas_);
  }
  void Run();

 private:
  Step BestTerm(const LinearFit& base);
  bool Confirmed(const Step& step, const LinearFit& base, const LinearFit& with);
  const char* CataloguedAlike(const Step& step, const LinearFit& with);
  Discovered Describe(int term, const LinearFit& all);
  LinearFit Relinearise(LinearFit fit);
  void DropWeakest(LinearFit* base);
  void NoteStop(const Step& step, double p_adjusted, const char* why);
  void DropNotLowerHeldout(LinearFit* base);
  void Correct(const LinearFit& all);
  void MeasureMisfit(const LinearFit& all);
  // The chosen term k's coefficient: where the rows are linearised plus the fit's step.
  double TermValue(const LinearFit& f, int k) const {
    return (coefficients_.empty() ? 0.0 : coefficients_[chosen_.terms[k]]) + f.Value(rows_[0], k);
  }
  double VarianceFactor(const LinearFit& f) const {
    return f.chi2_fit / std::max(1, 3 * f.n_fit - f.params);
  }

  const Recording& recording_;
  const double alpha_;
  DiagnoseReport* report_;
  Model model_;  // where the rows are linearised
  std::vector<double> coefficients_;  // and the terms' values there (empty before)
  std::vector<LibraryTerm> terms_;
  std::vector<int> free_betas_;
  std::vector<DiscoveryRow> rows_;
  DesignColumns chosen_;
  std::vector<Step> steps_;
  std::vector<int> excluded_;  // terms a catalogued effect explains as well, or the others explain
};

Step Discovery::BestTerm(const LinearFit& base) {
  (void)base;
  Step best;
  for (int k = 0; k < int(terms_.size()); ++k) {
    if (std::count(chosen_.terms.begin(), chosen_.terms.end(), k) ||
        std::count(excluded_.begin(), excluded_.end(), k))
      continue;
    DesignColumns with = chosen_;
    with.terms.push_back(k);
    const LinearFit f = FitRows(rows_, with, recording_.hac_lags);
    const double std = f.Std(rows_[0], int(with.terms.size()) - 1);
    if (!(std > 0)) continue;
    const double z = f.Value(rows_[0], int(with.terms.size()) - 1) / std;
    if (best.term < 0 || std::abs(z) > std::abs(best.z)) best = {k, z, std::erfc(std::abs(z) / std::sqrt(2.0))};
  }
  return best;
}

// BIC on the fit blocks (chi-squares in the noise scale of the model it is added to) and the
// held-out score test, one-sided at alpha.
bool Discovery::Confirmed(const Step& step, const LinearFit& base, const LinearFit& with) {
  const double scale = VarianceFactor(base);
  const double delta_bic = (with.chi2_fit - base.chi2_fit) / scale + std::log(3.0 * base.n_fit);
  if (delta_bic >= 0) return false;
  const double score = HeldoutScore(rows_, chosen_, step.term, base, with, recording_.hac_lags);
  return score * (step.z > 0 ? 1 : -1) > NormalUpper(alpha_);
}

// The catalogued effect not in the final model that explains the term's residual as well, if any.
const char* Discovery::CataloguedAlike(const Step& step, const LinearFit& with) {
  (void)step;
  const double gain = FitRows(rows_, chosen_, recording_.hac_lags).chi2_fit - with.chi2_fit;
  for (const CataloguedGroup& g : CataloguedGroups()) {
    bool free = false, excited = false;
    for (int j : g.betas) {
      free = free || std::count(free_betas_.begin(), free_betas_.end(), j);
      for (const DiscoveryRow& row : rows_) excited = excited || row.C.col(j).squaredNorm() > 0;
    }
    if (free || !excited) continue;
    DesignColumns alike = chosen_;
    alike.catalogued = g.betas;
    const LinearFit f = FitRows(rows_, alike, recording_.hac_lags);
    if (FitRows(rows_, chosen_, recording_.hac_lags).chi2_fit - f.chi2_fit >= 0.95 * gain) return g.name;
  }
  return nullptr;
}

// Backward step: a term chosen earlier that the later ones explain (its Wald test given them no
// longer passes at the library-wide level) leaves, and does not come back.
void Discovery::DropWeakest(LinearFit* base) {
  const int L = int(terms_.size());
  while (!chosen_.terms.empty()) {
    int weakest = 0;
    double weakest_z = 1e300;
    for (int k = 0; k < int(chosen_.terms.size()); ++k) {
      const double z = std::abs(TermValue(*base, k) / base->Std(rows_[0], k));
      if (z < weakest_z) weakest = k, weakest_z = z;
    }
    if (std::erfc(weakest_z / std::sqrt(2.0)) * L < alpha_) return;
    excluded_.push_back(chosen_.terms[weakest]);
    if (!coefficients_.empty()) coefficients_[chosen_.terms[weakest]] = 0.0;
    chosen_.terms.erase(chosen_.terms.begin() + weakest);
    steps_.erase(steps_.begin() + weakest);
    rows_ = DiscoveryRows(recording_, model_, terms_, free_betas_, coefficients_);
    *base = FitRows(rows_, chosen_, recording_.hac_lags);
  }
}

// A term whose held-out residual, where it stands out, is not lower with it (the others and the
// calibration refitted without it) leaves: the score test sees its direction, this the residual
// a user would see.
void Discovery::DropNotLowerHeldout(LinearFit* base) {
  for (bool dropped = true; dropped;) {
    dropped = false;
    for (int k = 0; k < int(chosen_.terms.size()) && !dropped; ++k) {
      const Discovered d = Describe(k, *base);
      if (d.heldout_rms_after < d.heldout_rms_before) continue;
      report_->notes.push_back("discovery: " + d.channel + " by " + d.terms[0].regressor +
                               " is not modelled: the held-out residual where it stands out is not lower with it");
      if (!coefficients_.empty()) coefficients_[chosen_.terms[k]] = 0.0;
      excluded_.push_back(chosen_.terms[k]);
      chosen_.terms.erase(chosen_.terms.begin() + k);
      steps_.erase(steps_.begin() + k);
      rows_ = DiscoveryRows(recording_, model_, terms_, free_betas_, coefficients_);
      *base = FitRows(rows_, chosen_, recording_.hac_lags);
      dropped = true;
    }
  }
}

// Why discovery stopped at a term that came close: what the recording could not model.
void Discovery::NoteStop(const Step& step, double p_adjusted, const char* why) {
  std::ostringstream s;
  s.precision(3);
  s << "discovery: the strongest library term left, " << TermChannelName(terms_[step.term].channel) << " by "
    << terms_[step.term].regressor << " (Wald z " << step.z << ", p " << p_adjusted
    << " after the correction over the library), is not modelled: " << why;
  report_->notes.push_back(s.str());
}

void Discovery::Run() {
  if (rows_.size() < 30 || terms_.empty()) return;
  const int L = int(terms_.size());
  LinearFit base = FitRows(rows_, chosen_, recording_.hac_lags);
  while (int(chosen_.terms.size()) < kMaxTerms) {
    const Step step = BestTerm(base);
    if (step.term < 0) break;
    const double p_adjusted = std::min(1.0, step.p * double(L - int(chosen_.terms.size())));
    if (p_adjusted >= alpha_) {
      if (p_adjusted < 10 * alpha_) NoteStop(step, p_adjusted, "short of the library-wide level");
      break;
    }
    DesignColumns with = chosen_;
    with.terms.push_back(step.term);
    const LinearFit f = FitRows(rows_, with, recording_.hac_lags);
    if (!Confirmed(step, base, f)) {
      NoteStop(step, p_adjusted, "the held-out blocks or BIC do not confirm it");
      break;
    }
    if (const char* name = CataloguedAlike(step, f)) {
      excluded_.push_back(step.term);
      report_->notes.push_back(std::string("the residual the library term ") + TermChannelName(terms_[step.term].channel) +
                               " by " + terms_[step.term].regressor + " would explain is explained as well by the "
                               "catalogued " + name + ", which its own test did not declare");
      continue;
    }
    chosen_ = with;
    steps_.push_back({step.term, step.z, p_adjusted});
    base = Relinearise(f);
    DropWeakest(&base);
  }
  DropNotLowerHeldout(&base);
  // The evidence of each term given the others, in the final joint fit.
  for (int k = 0; k < int(chosen_.terms.size()); ++k) {
    steps_[k].z = TermValue(base, k) / base.Std(rows_[0], k);
    steps_[k].p = std::min(1.0, L * std::erfc(std::abs(steps_[k].z) / std::sqrt(2.0)));
  }
  for (int k = 0; k < int(chosen_.terms.size()); ++k) report_->discovered.push_back(Describe(k, base));
  if (!chosen_.terms.empty()) {
    Correct(base);
    DemoteExplained(recording_, model_, free_betas_, base, alpha_, report_);
  }
  MeasureMisfit(base);
}

std::string Signed(double c, const std::string& unit, const std::string& what) {
  std::ostringstream s;
  s.precision(3);
  s << (c < 0 ? " − " : " + ") << std::abs(c) << " " << unit << "·" << what;
  return s.str();
}

// The equation of one term in the channel's own quantity.
std::string Equation(TermChannel channel, const std::string& regressor, double c, const std::string& unit) {
  struct Form {
    TermChannel channel;
    const char* regressor;
    const char* before;  // up to the sign
    const char* factor;  // what the coefficient multiplies
    const char* after;
  };
  static const Form forms[] = {
      {TermChannel::kYawRate, "turn_rate*|turn_rate|", "ω_true = ω_kin·(1", "|ω_kin|", ")"},
      {TermChannel::kYawRate, "turn_rate*|speed|", "ω_true = ω_kin·(1", "|v|", ")"},
      {TermChannel::kYawRate, "|turn_rate|", "ω_true = ω_kin", "|ω_kin|", ""},
      {TermChannel::kRadius, "|speed|", "r_eff = r·(1", "|v|", ")"},
      {TermChannel::kRadius, "turn_rate^2", "r_eff = r·(1", "ω²", ")"},
      {TermChannel::kSteer, "steer*|steer|", "ψ_true = ψ·(1", "|ψ|", ")"},
      {TermChannel::kSteer, "steer^2", "ψ_true = ψ", "ψ²", ""},
      {TermChannel::kSteer, "steer*|speed|", "ψ_true = ψ·(1", "|v|", ")"},
      {TermChannel::kTiming, "time", "offset(t) = offset(0)", "t", ""},
  };
  for (const Form& f : forms)
    if (f.channel == channel && regressor == f.regressor) return f.before + Signed(c, unit, f.factor) + f.after;
  return std::string(TermChannelName(channel)) + " +=" + Signed(c, unit, regressor);
}

Discovered Discovery::Describe(int k, const LinearFit& all) {
  const LibraryTerm& t = terms_[chosen_.terms[k]];
  Discovered d;
  d.channel = TermChannelName(t.channel);
  DiscoveredTerm term;
  term.regressor = t.regressor;
  term.coefficient = {TermValue(all, k), all.Std(rows_[0], k)};
  term.unit = CoefficientUnit(t.channel, t.regressor);
  d.terms.push_back(term);
  d.equation = Equation(t.channel, t.regressor, term.coefficient.value, term.unit);
  d.interpretation = t.interpretation;
  if (term.coefficient.value < 0) d.interpretation += " (negative coefficient: the opposite sense)";
  d.wald = steps_[k].z * steps_[k].z;
  d.p_value = std::erfc(std::abs(steps_[k].z) / std::sqrt(2.0));
  d.p_adjusted = steps_[k].p;
  DesignColumns without = chosen_;
  without.terms.erase(without.terms.begin() + k);
  // The rows without the term (linearised where it is at its value).
  std::vector<DiscoveryRow> rows_without = rows_;
  const double at = coefficients_.empty() ? 0.0 : coefficients_[chosen_.terms[k]];
  for (DiscoveryRow& row : rows_without) row.r -= row.G.col(chosen_.terms[k]) * at;
  const LinearFit before = FitRows(rows_without, without, recording_.hac_lags);
  d.delta_bic = (all.chi2_fit - before.chi2_fit) / VarianceFactor(before) + std::log(3.0 * all.n_fit);
  // The term's contribution, unwhitened, and where it stands out: the tenth of the intervals
  // where it is largest.
  std::vector<Eigen::Vector3d> contribution(rows_.size()), err_before(rows_.size()), err_after(rows_.size());
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();
  std::vector<double> size;
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const DiscoveryRow& row = rows_[i];
    contribution[i] = row.unwhiten * row.G.col(chosen_.terms[k]) * term.coefficient.value;
    energy += contribution[i].cwiseAbs2();
    err_before[i] = row.unwhiten * ResidualLeft(rows_without[i], without, before);
    err_after[i] = row.unwhiten * ResidualLeft(row, chosen_, all);
    size.push_back((row.G.col(chosen_.terms[k]) * term.coefficient.value).norm());
  }
  int comp = 0;
  for (int c = 1; c < 3; ++c)
    if (energy[c] / std::max(1e-300, rows_[0].sigma[c] * rows_[0].sigma[c]) >
        energy[comp] / std::max(1e-300, rows_[0].sigma[comp] * rows_[0].sigma[comp]))
      comp = c;
  static const char* kNames[3] = {"x", "y", "yaw"};
  d.component = kNames[comp];
  std::vector<double> sorted = size;
  std::sort(sorted.begin(), sorted.end());
  const double cut = sorted[sorted.size() * 9 / 10];
  std::vector<double> hb, ha;
  std::vector<TimeSpan> flagged;
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    if (size[i] < cut) continue;
    flagged.push_back({rows_[i].utime_start, rows_[i].utime_end});
    if (rows_[i].heldout) hb.push_back(err_before[i][comp]), ha.push_back(err_after[i][comp]);
  }
  d.where = MergeSpans(flagged, 2000000);
  d.heldout_rms_before = Rms(hb);
  d.heldout_rms_after = Rms(ha);
  const HeadingChains cb = ChainHeading(rows_, err_before, recording_.drift_window_s);
  const HeadingChains ca = ChainHeading(rows_, err_after, recording_.drift_window_s);
  d.heldout_drift_before = cb.Rms();
  d.heldout_drift_after = ca.Rms();
  d.drift_windows = int(ca.sums.size());
  d.drift_window_s = recording_.drift_window_s;
  return d;
}

// The rows linearised again where the joint fit moved the calibration (Gauss-Newton steps): the
// calibration absorbs part of a term's effect, and the regressors computed with the absorbing
// values would bias the term's size.
LinearFit Discovery::Relinearise(LinearFit fit) {
  if (coefficients_.empty()) coefficients_.assign(terms_.size(), 0.0);
  for (int step = 0; step < 3; ++step) {
    model_ = Updated(recording_, model_, free_betas_, fit.coef.data());
    for (std::size_t k = 0; k < chosen_.terms.size(); ++k) coefficients_[chosen_.terms[k]] += fit.Value(rows_[0], int(k));
    rows_ = DiscoveryRows(recording_, model_, terms_, free_betas_, coefficients_);
    fit = FitRows(rows_, chosen_, recording_.hac_lags);
  }
  return fit;
}

// The intervals' residuals after, and the held-out RMS, with the terms found.
void Discovery::Correct(const LinearFit& all) {
  std::size_t k = 0;
  std::vector<double> h[3];
  for (DiagnosedInterval& d : report_->intervals) {
    if (d.outlier || k >= rows_.size() || rows_[k].utime_start != d.utime_start) continue;
    d.after = rows_[k].unwhiten * ResidualLeft(rows_[k], chosen_, all);
    if (d.heldout)
      for (int c = 0; c < 3; ++c) h[c].push_back(d.after[c]);
    ++k;
  }
  for (int c = 0; c < 3; ++c) report_->heldout_rms_after[c] = Rms(h[c]);
  // The calibration refitted jointly with the terms (the columns of A in DiscoveryRows' order).
  const Model refitted = Updated(recording_, model_, free_betas_, all.coef.data());
  const std::string mount = report_->source == MotionSource::kPose ? "pose" : "lidar2d";
  const char* axes[3] = {".x", ".y", ".yaw"};
  for (int p : FreeParams(recording_))
    if (report_->refitted.count(ParamNames(recording_.track.drive)[p]))
      report_->refitted[ParamNames(recording_.track.drive)[p]].value = refitted.params[p];
  for (int k = 0; k < 3; ++k)
    if (report_->refitted.count(mount + axes[k])) report_->refitted[mount + axes[k]].value = refitted.mount[k];
}

void Discovery::MeasureMisfit(const LinearFit& all) {
  Misfit& m = report_->misfit;
  m.variance_factor = VarianceFactor(all);
  std::vector<Eigen::Vector3d> errors;
  for (const DiscoveryRow& row : rows_) errors.push_back(row.unwhiten * ResidualLeft(row, chosen_, all));
  const HeadingChains chains = ChainHeading(rows_, errors, recording_.drift_window_s);
  double expected = 0;
  for (int n : chains.counts) expected += n * chains.mean_square;
  if (!chains.sums.empty() && expected > 0)
    m.heading_drift_ratio = chains.Rms() / std::sqrt(expected / chains.sums.size());
  m.beyond = m.variance_factor >= kMisfitVarianceFactor || m.heading_drift_ratio >= kMisfitDriftRatio;
}

}  // namespace

void DiscoverTerms(const Recording& recording, const Model& final_model, double alpha, DiagnoseReport* report) {
  Discovery d(recording, final_model, alpha, report);
  d.Run();
}

// Discovered terms explain the recording when the misfit with them is within the bounds or one of
// them takes most of the held-out heading drift; the nearest library term of physics outside the
// library lowers the residual only a little and leaves the misfit far beyond.
std::string Verdict(const DiagnoseReport& report) {
  if (!report.effects.empty()) return "effects_found";
  bool explained = !report.misfit.beyond;
  for (const Discovered& d : report.discovered)
    explained = explained || d.heldout_drift_after <= 0.5 * d.heldout_drift_before;
  if (!report.discovered.empty() && explained) return "effects_found";
  return report.misfit.beyond ? "unmodelled_structure" : "no_significant_effect";
}

}  // namespace calib::diag
