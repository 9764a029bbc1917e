#include "calib/diagnose/selection.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "calib/core/statistics.h"
#include "calib/core/units.h"
#include "diagnose/diagnose_internal.h"

namespace calib::diag {

double DetectableZ(const SelectionLevels& levels) {
  return NormalUpper(levels.alpha / levels.candidates / 2) + NormalUpper(0.2);
}

double DetectableSize(const SingleFit& f, const SelectionLevels& levels) {
  const double sigma = f.estimate.std;
  if (!(sigma > 0)) return 0.0;
  // Both tests are on |estimate|^2: the Wald statistic in units of sigma^2, the chi-square drop
  // in units of information_std^2. In the Wald statistic's units the drop's threshold is
  // bic_drop (information_std / sigma)^2; the larger threshold decides.
  const double ratio = f.information_std > 0 ? f.information_std / sigma : 0.0;
  const double bic_level = f.bic_drop * ratio * ratio;
  // One degree of freedom: the normal form of DetectableZ (its other tail is negligible).
  if (f.params == 1)
    return (std::max(NormalUpper(levels.alpha / levels.candidates / 2), std::sqrt(bic_level)) + NormalUpper(0.2)) *
           sigma;
  const double wald_level = ChiSquareUpperQuantile(levels.alpha / levels.candidates, f.params);
  return std::sqrt(NoncentralityForPower(std::max(wald_level, bic_level), f.params, 0.8)) * sigma;
}

double DeltaBic(double chi2_with, double chi2_without, std::size_t params, double log_n) {
  return (chi2_with - chi2_without) + params * log_n;
}

SingleVerdicts JudgeSingles(const std::vector<SingleFit>& fits, const SelectionLevels& levels) {
  const int m_odo = levels.candidates, m_act = levels.actuation_candidates;
  const double alpha_odo = levels.alpha;
  std::vector<double> p;
  for (const SingleFit& f : fits) p.push_back(f.p);
  const std::vector<double> p_adj = HolmAdjust(p);
  SingleVerdicts out;
  out.outcomes.resize(fits.size());
  out.eligible.assign(fits.size(), false);
  for (std::size_t j = 0; j < fits.size(); ++j) {
    const SingleFit& f = fits[j];
    CandidateOutcome& o = out.outcomes[j];
    o.name = f.name, o.layer = f.layer, o.wheel = f.wheel;
    o.p_value = f.p;
    o.p_adjusted = std::min(1.0, p_adj[j] * double(m_odo + m_act) / m_odo);
    o.delta_bic = f.delta_bic;
    o.estimate = f.estimate;
    o.detectable = DetectableSize(f, levels);
    o.heldout_change = f.heldout_gain;
    o.heldout_confirmed = f.heldout_confirmed;
    // The Wald statistic rests on a linearisation and a robust variance; where the model is
    // far from linear in the parameter (a lag near its bound) or the regressor acts on a few
    // intervals only (their variance estimated from a handful of residuals), it can overstate
    // the evidence by orders of magnitude: a large Wald statistic while the chi-square hardly
    // drops. So the fit must also pay for its parameter in BIC (a real effect pays by a margin,
    // docs/mismatch.md), and data the fit never saw must confirm it.
    const bool pays = o.delta_bic < 0;
    out.eligible[j] = p_adj[j] < alpha_odo && pays && f.heldout_confirmed;
    if (p_adj[j] < alpha_odo && !out.eligible[j]) {
      std::ostringstream why;
      why.precision(3);
      if (!pays)
        why << "significant by its Wald statistic but the fit does not pay for its parameter (delta BIC "
            << o.delta_bic << ")";
      else
        why << "significant on the fit blocks but not confirmed on the held-out blocks (held-out chi2 "
            << -100 * f.heldout_gain << " % change, residual " << -100 * f.span_gain << " % where it would act)";
      o.note = why.str();
    }
    if (out.eligible[j]) {
      o.status = CandidateStatus::kRejected;  // until the selection chooses it
    } else if (!(o.detectable < f.plausible)) {
      o.status = CandidateStatus::kNotIdentifiable;
      o.note = "this recording could only detect it above " +
               QuantityText(o.detectable, ParamUnit(EffectSizeKey(f.name)), 3) + "; drive " + f.excitation;
    } else {
      o.status = CandidateStatus::kNotSignificant;
    }
  }
  return out;
}

void NoteDetectableWith(const std::vector<PairFit>& pairs, const SelectionLevels& levels,
                        std::vector<CandidateOutcome>* outcomes) {
  const double z = DetectableZ(levels);
  for (const PairFit& pf : pairs) {
    (*outcomes)[pf.a].detectable_with[pf.pair->b] = z * std::sqrt(std::max(pf.var_a, 0.0));
    (*outcomes)[pf.b].detectable_with[pf.pair->a] = z * std::sqrt(std::max(pf.var_b, 0.0));
  }
}

void SeedFromPair(const std::vector<PairFit>& pairs, const std::vector<bool>& eligible,
                  const SelectionLevels& levels, std::size_t catalogue_pairs, SelectionFits* fits,
                  Selection* selection) {
  const double level = levels.alpha / double(levels.candidates + catalogue_pairs);
  double best_wald = 0;
  int best = -1;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const PairFit& pf = pairs[k];
    if (eligible[pf.a] || eligible[pf.b]) continue;
    const bool pays = pf.delta_bic < 0;
    if (!(pf.p < level && pays && pf.wald > best_wald)) continue;
    if (!fits->PairConfirmed(int(k))) continue;
    best_wald = pf.wald;
    best = int(k);
  }
  if (best < 0) return;
  const PairFit& pf = pairs[best];
  fits->StartFromPair(best);
  selection->seeded = best;
  selection->chosen = {pf.a, pf.b};
  selection->p = {pf.p, pf.p};
  selection->wald = {pf.wald, pf.wald};
}

void SelectForward(const std::vector<bool>& eligible, const SelectionLevels& levels, SelectionFits* fits,
                   Selection* selection) {
  std::vector<int>& chosen = selection->chosen;
  for (;;) {
    int best = -1;
    StepTest best_test;
    for (std::size_t j = 0; j < eligible.size(); ++j) {
      if ((chosen.empty() && !eligible[j]) || std::find(chosen.begin(), chosen.end(), int(j)) != chosen.end())
        continue;
      const StepTest t = fits->TryAdd(int(j));
      const double level = levels.alpha / double(levels.candidates - chosen.size());
      const bool pays = t.delta_bic < 0;
      if (t.p < level && pays && fits->AddConfirmed(int(j)) && (best < 0 || t.wald > best_test.wald)) {
        best = int(j);
        best_test = t;
      }
    }
    if (best < 0) break;
    fits->Add(best);
    chosen.push_back(best);
    selection->p.push_back(best_test.p);
    selection->wald.push_back(best_test.wald);
  }
}

void EliminateBackward(const SelectionLevels& levels, SelectionFits* fits, Selection* selection,
                       std::vector<CandidateOutcome>* outcomes) {
  std::vector<int>& chosen = selection->chosen;
  for (bool dropped = true; dropped && !chosen.empty();) {
    dropped = false;
    for (std::size_t n = 0; n < chosen.size(); ++n) {
      const StepTest with = fits->TryKeep(chosen[n]);
      const double level = levels.alpha / double(levels.candidates - chosen.size() + 1);
      if (with.p < level && fits->KeepConfirmed(chosen[n])) {
        selection->p[n] = with.p;
        selection->wald[n] = with.wald;
        continue;
      }
      (*outcomes)[chosen[n]].note = "explained by the other effects found";
      fits->Drop(chosen[n]);
      chosen.erase(chosen.begin() + n);
      selection->p.erase(selection->p.begin() + n);
      selection->wald.erase(selection->wald.begin() + n);
      dropped = true;
      break;
    }
  }
}

void ReportSeededPair(const PairFit& seeded, const Selection& selection, std::vector<CandidateOutcome>* outcomes,
                      std::vector<Indistinguishable>* indistinguishable) {
  const ConfusablePair& pair = *seeded.pair;
  auto is_chosen = [&](const char* name) {
    for (int j : selection.chosen)
      if ((*outcomes)[j].name == name) return true;
    return false;
  };
  if (is_chosen(pair.a) || is_chosen(pair.b)) return;
  indistinguishable->push_back({pair.a, pair.b, seeded.correlation, pair.motion});
  for (CandidateOutcome& o : *outcomes) {
    if (o.name == pair.a || o.name == pair.b) {
      o.status = CandidateStatus::kIndistinguishable;
      o.note = std::string("together significant, but neither given the other: indistinguishable from ") +
               (o.name == pair.a ? pair.b : pair.a) + " with this recording; to separate them drive " + pair.motion;
    }
  }
}

namespace {

// "0.19 ± 0.03 s²/m, p = 2e-05 given time_offset": a look-alike's size and test given the other.
std::string GivenText(const std::string& name, const ParamEstimate& e, double p, const std::string& other) {
  return EstimateText(e.value, e.std, ParamUnit(EffectSizeKey(name))) + ", " + PValueText(p) + " given " + other;
}

// Chosen candidate `ix` leaves the selection in favour of `iy` (its place in the order kept).
void Replace(int ix, int iy, const StepTest& test, Selection* selection) {
  const std::size_t n = std::find(selection->chosen.begin(), selection->chosen.end(), ix) - selection->chosen.begin();
  selection->chosen[n] = iy, selection->p[n] = test.p, selection->wald[n] = test.wald;
}

}  // namespace

void CheckLookAlikes(const std::vector<ConfusablePair>& catalogue, const std::vector<bool>& eligible,
                     const SelectionLevels& levels, Selection* selection, SelectionFits* fits,
                     std::vector<CandidateOutcome>* outcomes, std::vector<Indistinguishable>* indistinguishable) {
  std::vector<CandidateOutcome>& out = *outcomes;
  auto chosen = [&](int j) {
    return std::find(selection->chosen.begin(), selection->chosen.end(), j) != selection->chosen.end();
  };
  auto index = [&](const std::string& name) {
    for (std::size_t j = 0; j < out.size(); ++j)
      if (out[j].name == name) return int(j);
    return -1;
  };
  for (const ConfusablePair& pair : catalogue) {
    const int ia = index(pair.a), ib = index(pair.b);
    if (ia < 0 || ib < 0 || chosen(ia) == chosen(ib)) continue;
    const int ix = chosen(ia) ? ia : ib, iy = chosen(ia) ? ib : ia;
    const std::string x = out[ix].name, y = out[iy].name;
    // Each fitted given the other: the evidence decides which stands, not which came first.
    const LookAlikeFit joint = fits->FitLookAlike(ix, iy);
    const double level = levels.alpha / levels.candidates;
    const bool x_stands = joint.p_x < level, y_stands = joint.p_y < level;
    const std::string y_given = GivenText(y, joint.y, joint.p_y, x), x_given = GivenText(x, joint.x, joint.p_x, y);
    const std::string correlation = "correlation of the estimates " + SignificantText(joint.correlation, 2);
    if (x_stands && !y_stands) {
      if (eligible[iy]) out[iy].status = CandidateStatus::kRejected;
      if (eligible[iy] || out[iy].note.empty())
        out[iy].note = "explained by " + x + " (" + y_given + "; " + correlation + ")";
      continue;
    }
    if (y_stands) {
      // Only the look-alike stands given the other: it replaces the chosen one; both stand: it
      // joins it. Either way as a forward step: paying in BIC and confirmed on held-out data.
      const StepTest test = x_stands ? fits->TryAdd(iy) : fits->TrySwap(ix, iy);
      const bool pays = test.delta_bic < 0;
      const bool confirmed = test.p < level && pays && (x_stands ? fits->AddConfirmed(iy) : fits->SwapConfirmed(ix, iy));
      if (confirmed && x_stands) {
        fits->Add(iy);
        selection->chosen.push_back(iy), selection->p.push_back(test.p), selection->wald.push_back(test.wald);
        out[iy].note = "stands given " + x + " (" + y_given + "; " + correlation + ")";
        continue;
      }
      if (confirmed) {
        fits->Swap(ix, iy);
        Replace(ix, iy, test, selection);
        out[ix].status = CandidateStatus::kRejected;
        out[ix].note = "explained by " + y + " (" + x_given + "; " + correlation + ")";
        out[iy].note = "stands given " + x + ", which does not given it (" + y_given + "; " + correlation + ")";
        continue;
      }
      if (x_stands) {
        out[iy].status = CandidateStatus::kRejected;
        out[iy].note = "stands given " + x + " (" + y_given + ") but " +
                       (pays ? "is not confirmed on the held-out blocks" : "does not pay for its parameter");
        continue;
      }
    }
    // Neither stands given the other (or the one that does is not confirmed on data the fit
    // never saw): the data cannot tell them apart. The chosen one stays in the model (together
    // they are significant, and it is the stronger alone), said to be indistinguishable.
    indistinguishable->push_back({x, y, joint.correlation, pair.motion});
    out[iy].status = CandidateStatus::kIndistinguishable;
    out[ix].note = "indistinguishable from " + y + " with this recording (" + x_given +
                   "); kept as the stronger alone; to separate them drive " + pair.motion;
    out[iy].note = "indistinguishable from " + x + " (" + y_given + "); drive " + pair.motion;
  }
}

void MarkFound(const Selection& selection, const std::vector<bool>& eligible,
               std::vector<CandidateOutcome>* outcomes) {
  for (int j : selection.chosen) {
    (*outcomes)[j].status = CandidateStatus::kFound;
    if (!eligible[j]) (*outcomes)[j].note = "significant given the other effects found";
  }
}

std::vector<Borderline> BorderlineDecisions(const std::vector<CandidateOutcome>& outcomes, const Selection& selection,
                                            const SelectionLevels& levels) {
  // In the units of the catalogue-wide p-values (CandidateOutcome::p_adjusted): Holm's over
  // these candidates scaled to the whole catalogue, at the family-wise level.
  const double share = double(levels.candidates + levels.actuation_candidates) / std::max(1, levels.candidates);
  const double alpha = levels.alpha * share;
  std::vector<Borderline> out;
  for (std::size_t j = 0; j < outcomes.size(); ++j) {
    const CandidateOutcome& o = outcomes[j];
    const auto at = std::find(selection.chosen.begin(), selection.chosen.end(), int(j));
    double p = o.p_adjusted;
    if (at != selection.chosen.end()) {
      p = std::min(1.0, selection.p[at - selection.chosen.begin()] * levels.candidates * share);
      if (!(p > alpha / kBorderlineFactor)) continue;
    } else if (o.status == CandidateStatus::kNotIdentifiable || o.status == CandidateStatus::kIndistinguishable ||
               !(p > alpha / kBorderlineFactor && p < alpha * kBorderlineFactor)) {
      continue;
    }
    out.push_back({o.name, o.wheel, o.status, p, alpha, o.heldout_change, o.heldout_confirmed});
  }
  return out;
}

std::vector<MovedEffect> MovedEffects(const std::vector<FoundEffect>& effects,
                                      const std::vector<CandidateOutcome>& outcomes) {
  std::vector<MovedEffect> out;
  for (const FoundEffect& e : effects) {
    const auto size = e.params.find(EffectSizeKey(e.name));
    if (size == e.params.end()) continue;
    for (const CandidateOutcome& o : outcomes) {
      if (o.name != e.name || o.wheel != e.wheel) continue;
      const ParamEstimate& with = size->second;
      if (!(std::abs(with.value - o.estimate.value) > 2 * std::max(with.std, o.estimate.std))) continue;
      MovedEffect m{e.name, e.wheel, o.estimate, with, {}};
      for (const FoundEffect& other : effects)
        if (&other != &e) m.others.push_back(other.name + (other.wheel.empty() ? "" : " (" + other.wheel + ")"));
      out.push_back(m);
    }
  }
  return out;
}

Selection SelectEffects(const std::vector<ConfusablePair>& catalogue, const std::vector<PairFit>& pairs,
                        const std::vector<bool>& eligible, const SelectionLevels& levels, SelectionFits* fits,
                        std::vector<CandidateOutcome>* outcomes, std::vector<Indistinguishable>* indistinguishable) {
  // Two effects present at once hide each other in their single fits (the other's residual
  // inflates the robust variance): on the dual-steer AGV a time offset with slip was
  // significant alone in 1 of 10 recordings, given the slip in most. A confusable pair whose
  // members hide each other enters the selection whole; backward elimination keeps each only
  // if it stands given the other, and when neither does they are reported indistinguishable.
  Selection selection;
  SeedFromPair(pairs, eligible, levels, catalogue.size(), fits, &selection);
  SelectForward(eligible, levels, fits, &selection);
  // An effect chosen early may be explained by one chosen later (the look-alike of a bigger
  // effect).
  EliminateBackward(levels, fits, &selection, outcomes);
  if (selection.seeded >= 0) ReportSeededPair(pairs[selection.seeded], selection, outcomes, indistinguishable);
  // A chosen effect fitted together with its look-alike: when neither stands on its own given
  // the other, the data cannot tell them apart.
  CheckLookAlikes(catalogue, eligible, levels, &selection, fits, outcomes, indistinguishable);
  MarkFound(selection, eligible, outcomes);
  return selection;
}

}  // namespace calib::diag
