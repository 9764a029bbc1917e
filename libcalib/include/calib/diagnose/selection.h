#pragma once
// The selection of effects in the diagnosis (diagnose.h), step by step, on the figures of
// the odometry and sensing candidates' fits: the single-candidate tests, the confusable
// pairs, greedy forward selection and backward elimination, each confirmed on the held-out
// blocks. The fits of a recording stay behind SelectionFits, so every step runs on plain
// numbers as well (tests/diagnose_select_test.cc).

#include <cstddef>
#include <string>
#include <vector>

#include "calib/diagnose/diagnose.h"

namespace calib::diag {

// How the family-wise rate is shared: Holm's correction runs over the whole catalogue, of
// which these candidates are `candidates` and the actuation layer `actuation_candidates`.
struct SelectionLevels {
  int candidates = 0;            // odometry and sensing candidates
  int actuation_candidates = 0;  // tested by the actuation layer
  double alpha = 0;              // these candidates' share: alpha * candidates / (candidates + actuation)
};

// One candidate fitted alone on the baseline.
struct SingleFit {
  std::string name, layer, wheel;
  double p = 1;            // of its Wald statistic (before Holm's correction)
  double delta_bic = 0;    // BIC on the fit blocks with it, less without it
  ParamEstimate estimate;  // its size (the norm of a two-parameter effect) and the std
  int params = 1;          // its parameters: the Wald test's degrees of freedom
  // The BIC gate asks the fit blocks' chi-square to drop by `bic_drop` (params log n), and it
  // drops by (size / information_std)^2, the std from the fit blocks' information alone
  // (independent residuals). 0: not known, the detectable size is then the Wald test's alone.
  double bic_drop = 0, information_std = 0;
  double plausible = 0;    // largest size a real robot plausibly shows
  std::string excitation;  // motion that excites it
  bool heldout_confirmed = false;  // the held-out blocks confirm it (score test or drift)
  // For the note of one that is significant but not confirmed: how much lower, as a fraction,
  // the held-out chi-square is with it, and the held-out residual where it would act.
  double heldout_gain = 0, span_gain = 0;
};

struct SingleVerdicts {
  // In the order of the fits. An eligible candidate stands as kRejected until the selection
  // chooses it (MarkFound); the others keep their status.
  std::vector<CandidateOutcome> outcomes;
  // Significant after Holm's correction, pays for its parameters in BIC and is confirmed on the
  // held-out blocks: forward selection starts among these.
  std::vector<bool> eligible;
};

// The single-candidate tests: Holm's correction over `fits`, the minimum detectable sizes
// and each candidate's status, with the reason when one significant by its Wald statistic
// alone is not eligible.
SingleVerdicts JudgeSingles(const std::vector<SingleFit>& fits, const SelectionLevels& levels);

// The size at which a candidate of standard error 1 is detected (level, power 0.8).
double DetectableZ(const SelectionLevels& levels);

// A single candidate's minimum detectable size (CandidateOutcome::detectable): the size found
// with power 0.8 by both gates it must pass, its Wald test (`f.params` degrees of freedom at the
// Holm level of the first step) and the BIC gate, whose chi-square drop counts the residuals
// as independent: where neighbouring intervals' errors cancel (they share a scan) the robust
// std is the smaller, and the Wald test alone claimed sizes the BIC gate rejects.
double DetectableSize(const SingleFit& f, const SelectionLevels& levels);

// BIC with `params` more parameters, less BIC without them (negative: they pay for themselves).
double DeltaBic(double chi2_with, double chi2_without, std::size_t params, double log_n);

// Two candidates whose signatures look alike, by name.
struct ConfusablePair {
  const char* a;
  const char* b;
  const char* motion;  // what would separate them
};

// A confusable pair both of whose members are candidates, fitted together on the baseline.
struct PairFit {
  const ConfusablePair* pair = nullptr;
  int a = -1, b = -1;           // candidate indices (of pair->a and pair->b)
  double p = 1, wald = 0;       // the joint two-parameter test
  double delta_bic = 0;         // against the baseline
  double var_a = 0, var_b = 0;  // variances of the two estimates
  double correlation = 0;       // of the two estimates
};

// Each member's detectable size with its look-alike fitted too (CandidateOutcome::detectable_with).
void NoteDetectableWith(const std::vector<PairFit>& pairs, const SelectionLevels& levels,
                        std::vector<CandidateOutcome>* outcomes);

// A candidate's test when it is added to the current model, or kept in it given the others.
struct StepTest {
  double p = 1, wald = 0;
  double delta_bic = 0;  // against the current model (forward selection only)
};

// A chosen candidate `x` fitted together with its look-alike `y`.
struct LookAlikeFit {
  double p_x = 1, p_y = 1;  // each given the other (and the rest of the model)
  double correlation = 0;   // of the two estimates
  ParamEstimate x, y;       // each size given the other (the norm of a two-parameter effect)
};

// The fits the selection asks for. It holds the current model, which starts as the baseline
// and changes only through StartFromPair, Add and Drop. Candidates and pairs are indices
// into the SingleFit and PairFit lists.
class SelectionFits {
 public:
  virtual ~SelectionFits() = default;
  // Whether the held-out blocks confirm pair `k`'s joint fit against the baseline.
  virtual bool PairConfirmed(int k) = 0;
  // The current model becomes pair `k`'s joint fit.
  virtual void StartFromPair(int k) = 0;
  // Candidate `j` (not in the model) fitted with the current model and tested given it.
  virtual StepTest TryAdd(int j) = 0;
  // Whether the held-out blocks confirm the last TryAdd(j) against the current model.
  virtual bool AddConfirmed(int j) = 0;
  // The current model becomes the last TryAdd(j)'s.
  virtual void Add(int j) = 0;
  // Candidate `j` (in the model) tested given the others; its model without `j` fitted too.
  virtual StepTest TryKeep(int j) = 0;
  // Whether the held-out blocks confirm `j` against the last TryKeep(j)'s model without it.
  virtual bool KeepConfirmed(int j) = 0;
  // The current model becomes the last TryKeep(j)'s without `j`, refitted.
  virtual void Drop(int j) = 0;
  // Candidate `x` (in the model) with its look-alike `y` (not in it) added.
  virtual LookAlikeFit FitLookAlike(int x, int y) = 0;
  // Candidate `x` (in the model) replaced by `y` (not in it): `y` tested given the others.
  virtual StepTest TrySwap(int x, int y) = 0;
  // Whether the held-out blocks confirm `y` against the last TrySwap(x, y)'s model without both.
  virtual bool SwapConfirmed(int x, int y) = 0;
  // The current model becomes the last TrySwap(x, y)'s.
  virtual void Swap(int x, int y) = 0;
};

// The effects chosen, in the order chosen, with their tests given all the others.
struct Selection {
  std::vector<int> chosen;
  std::vector<double> p, wald;
  int seeded = -1;  // the pair the selection started from (index into the PairFits), or -1
};

// A confusable pair whose members hide each other: neither eligible, the two together
// significant (a 2-dof test, its level shared with the single tests over the catalogue's
// `catalogue_pairs` pairs), paying in BIC and confirmed on the held-out blocks. The one with
// the largest Wald statistic starts the selection with both members.
void SeedFromPair(const std::vector<PairFit>& pairs, const std::vector<bool>& eligible,
                  const SelectionLevels& levels, std::size_t catalogue_pairs, SelectionFits* fits,
                  Selection* selection);

// Greedy forward selection, each candidate tested given those chosen: first among the
// eligible ones, then among all. A candidate enters when significant at the level left,
// paying in BIC and confirmed on the held-out blocks; the largest Wald statistic first.
void SelectForward(const std::vector<bool>& eligible, const SelectionLevels& levels, SelectionFits* fits,
                   Selection* selection);

// Backward elimination: each chosen candidate must stay significant given all the others and
// be confirmed on the held-out blocks; the first that is not is dropped (noted in its
// outcome) and the check starts over.
void EliminateBackward(const SelectionLevels& levels, SelectionFits* fits, Selection* selection,
                       std::vector<CandidateOutcome>* outcomes);

// The seeded pair when neither member survived: indistinguishable with this recording.
void ReportSeededPair(const PairFit& seeded, const Selection& selection, std::vector<CandidateOutcome>* outcomes,
                      std::vector<Indistinguishable>* indistinguishable);

// Each chosen candidate fitted together with its look-alike from `catalogue` (not chosen): the
// joint fit decides, not the order of the selection. The one that stands given the other is
// kept, the look-alike replacing the chosen one when only it stands (held-out confirmed); both
// are kept when each stands given the other (the look-alike added as in forward selection);
// when neither stands (or the one that alone stands is not confirmed held-out) the pair is
// indistinguishable with this recording, reported with the motion that separates them, the
// chosen one kept in the model (the stronger alone). Each note gives the size and p given the
// other.
void CheckLookAlikes(const std::vector<ConfusablePair>& catalogue, const std::vector<bool>& eligible,
                     const SelectionLevels& levels, Selection* selection, SelectionFits* fits,
                     std::vector<CandidateOutcome>* outcomes, std::vector<Indistinguishable>* indistinguishable);

// The chosen candidates are found (noted when only given the others).
void MarkFound(const Selection& selection, const std::vector<bool>& eligible,
               std::vector<CandidateOutcome>* outcomes);

// The decisions near their gate (Borderline): the effects found whose p given the others, and
// the candidates significant alone but not found whose p, lies within kBorderlineFactor of the
// family-wise level.
std::vector<Borderline> BorderlineDecisions(const std::vector<CandidateOutcome>& outcomes, const Selection& selection,
                                            const SelectionLevels& levels);

// The effects found whose size with the others found is more than two sigma (the larger of the
// two) from their size alone.
std::vector<MovedEffect> MovedEffects(const std::vector<FoundEffect>& effects,
                                      const std::vector<CandidateOutcome>& outcomes);

// The steps above in order, from the single verdicts and the pairs fitted on the baseline.
Selection SelectEffects(const std::vector<ConfusablePair>& catalogue, const std::vector<PairFit>& pairs,
                        const std::vector<bool>& eligible, const SelectionLevels& levels, SelectionFits* fits,
                        std::vector<CandidateOutcome>* outcomes, std::vector<Indistinguishable>* indistinguishable);

}  // namespace calib::diag
