// REPORT.json, the plain-words summary, the comparison with a simulator run
// and the simulation config that reproduces the robot.

#include <cmath>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "calib/calibrate/calibration_report.h"
#include "calib/calibrate/heldout.h"
#include "calib/core/units.h"
#include "calib/diagnose/diagnose.h"
#include "io/provenance_json.h"

namespace calib {
namespace {

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// Seconds since the origin, to the millisecond.
double Since(int64_t utime, int64_t origin) { return std::round((utime - origin) * 1e-3) * 1e-3; }

// Absolute utime (spec/cli.md) and seconds since the origin (t_start_s, t_end_s).
nlohmann::json Spans(const std::vector<TimeSpan>& spans, int64_t origin) {
  nlohmann::json j = nlohmann::json::array();
  for (const TimeSpan& s : spans)
    j.push_back({{"utime_start", s.utime_start}, {"utime_end", s.utime_end}, {"t_start_s", Since(s.utime_start, origin)},
                 {"t_end_s", Since(s.utime_end, origin)}});
  return j;
}


nlohmann::json Params(const std::map<std::string, ParamEstimate>& params) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : params) j[k] = {{"value", Number(v.value)}, {"std", Number(v.std)}};
  return j;
}

std::string Percent(double before, double after) {
  std::ostringstream s;
  s.precision(3);
  s << (before > 0 ? 100.0 * (before - after) / before : 0.0) << " %";
  return s.str();
}

// "before -> after unit": lengths in mm, angles in rad with degrees beside (units.h).
std::string BeforeAfter(double before, double after, const std::string& unit) {
  if (unit == "m") return MillimetresText(before, 3) + " -> " + MillimetresText(after, 3);
  if (unit == "rad") return MilliradiansText(before) + " -> " + MilliradiansText(after);  // docs/units.md
  return QuantityText(before, unit, 3) + " -> " + QuantityText(after, unit, 3);
}

}  // namespace

// A candidate's note without the clause of the test over boxes of the route (diagnose_region.cc),
// which is bookkeeping of a test that did not name it (and zeros where it did not run).
std::string CandidateNoteInWords(const std::string& note) {
  const std::string clause = "not confined to a region either";
  const std::size_t at = note.find(clause);
  if (at == std::string::npos) return note;
  std::size_t start = at;
  while (start > 0 && (note[start - 1] == ' ' || note[start - 1] == ';')) --start;
  const std::size_t next = note.find("; ", at);  // the clause holds no other semicolon
  if (next == std::string::npos) return note.substr(0, start);
  return start == 0 ? note.substr(next + 2) : note.substr(0, start) + note.substr(next);
}

std::string SpanTimes(const std::vector<TimeSpan>& spans, int64_t origin, std::size_t shown) {
  std::string text;
  for (std::size_t i = 0; i < spans.size() && i < shown; ++i)
    text += (i ? ", " : "") + FixedDecimals(Since(spans[i].utime_start, origin), 1) + "–" +
            FixedDecimals(Since(spans[i].utime_end, origin), 1) + " s";
  if (spans.size() > shown) text += ", … (" + std::to_string(spans.size()) + " spans)";
  return text;
}

int64_t ReportTimeOrigin(const DiagnoseReport& r) {
  return r.recording_start_utime ? r.recording_start_utime : r.intervals.empty() ? 0 : r.intervals.front().utime_start;
}

std::string EffectSizeKey(const std::string& effect_name) {
  static const std::map<std::string, std::string> kKeys = {
      {"time_offset", "offset_s"},       {"scan_distortion", "scan_period_s"},
      {"longitudinal_slip", "slip_per_accel"}, {"lateral_slip", "gain"},
      {"steering_lag", "tau_s"},         {"steering_backlash", "width_rad"},
      {"wheel_eccentricity", "amplitude"}, {"drive_lag", "tau_s"},
      {"steering_rate_limit", "rate_rad_s"}, {"travel_direction_offset", "offset_rad"}};
  const auto it = kKeys.find(effect_name);
  return it == kKeys.end() ? "" : it->second;
}

std::string ComponentUnit(const std::string& component) {
  const std::string first = component.substr(0, component.find(' '));
  if (first == "yaw" || first == "heading" || first == "steer") return "rad";
  if (first == "speed") return "rad/s";
  return "m";
}

const char* CandidateStatusName(CandidateStatus status) {
  switch (status) {
    case CandidateStatus::kFound: return "found";
    case CandidateStatus::kNotSignificant: return "not_significant";
    case CandidateStatus::kNotIdentifiable: return "not_identifiable";
    case CandidateStatus::kIndistinguishable: return "indistinguishable";
    case CandidateStatus::kRejected: return "rejected";
  }
  return "not_significant";
}

namespace {

// One found effect of REPORT.json `effects` (spec/cli.md).
nlohmann::json EffectJson(const FoundEffect& e, int64_t origin) {
  nlohmann::json je = {{"name", e.name}, {"layer", e.layer}, {"params", Params(e.params)}};
  if (!e.wheel.empty()) je["wheel"] = e.wheel;
  je["evidence"] = {{"delta_bic", Number(e.delta_bic)}, {"p_value", Number(e.p_adjusted)},
                    {"p_value_unadjusted", Number(e.p_value)}, {"wald", Number(e.wald)}};
  je["heldout_rms_before"] = Number(e.heldout_rms_before);
  je["heldout_rms_after"] = Number(e.heldout_rms_after);
  je["heldout_rms_all_before"] = Number(e.heldout_rms_all_before);
  je["heldout_rms_all_after"] = Number(e.heldout_rms_all_after);
  je["heldout_component"] = e.component;
  if (!e.drift_component.empty())
    je["heldout_drift"] = {{"component", e.drift_component}, {"window_s", e.drift_window_s},
                           {"windows", e.drift_windows}, {"rms_before", Number(e.heldout_drift_before)},
                           {"rms_after", Number(e.heldout_drift_after)}};
  if (!e.stretches.empty()) {
    nlohmann::json per = nlohmann::json::array();
    for (const HeldoutStretch& h : e.stretches)
      per.push_back({{"utime_start", h.utime_start}, {"utime_end", h.utime_end},
                     {"t_start_s", Since(h.utime_start, origin)}, {"t_end_s", Since(h.utime_end, origin)},
                     {"before", Number(h.before)}, {"after", Number(h.after)}});
    je["heldout_stretch"] = {{"component", e.component}, {"stretches", e.stretches.size()},
                             {"rms_before", Number(e.heldout_stretch_before)},
                             {"rms_after", Number(e.heldout_stretch_after)}, {"per_stretch", per}};
  }
  je["heldout_measure"] = e.heldout_measure;
  if (e.heldout_disagrees) je["heldout_disagrees"] = {{"confirmed_by", e.heldout_confirmed_by}};
  je["where"] = Spans(e.where, origin);
  if (e.region) je["region"] = {(*e.region)[0], (*e.region)[1], (*e.region)[2], (*e.region)[3]};
  je["regime"] = e.regime;
  je["signature"] = {{"regressor", e.regressor}, {"component", e.signature_component}, {"bins", nlohmann::json::array()}};
  for (const SignatureBin& b : e.signature)
    je["signature"]["bins"].push_back({{"x", b.x}, {"before", b.before}, {"after", b.after},
                                       {"std_error", b.std_error}, {"count", b.count}});
  return je;
}

// What the selection decided beyond the effects found: discovered terms, the misfit, pairs it
// cannot tell apart, borderline decisions and effects that moved.
void AddDecisionSections(const DiagnoseReport& r, int64_t origin, nlohmann::json* j) {
  (*j)["discovered"] = nlohmann::json::array();
  for (const Discovered& d : r.discovered) {
    nlohmann::json terms = nlohmann::json::array();
    for (const DiscoveredTerm& t : d.terms)
      terms.push_back({{"regressor", t.regressor}, {"unit", t.unit},
                       {"coefficient", {{"value", Number(t.coefficient.value)}, {"std", Number(t.coefficient.std)}}}});
    (*j)["discovered"].push_back(
        {{"channel", d.channel}, {"terms", terms}, {"equation", d.equation}, {"interpretation", d.interpretation},
         {"evidence", {{"p_value", Number(d.p_adjusted)}, {"p_value_unadjusted", Number(d.p_value)},
                       {"wald", Number(d.wald)}, {"delta_bic", Number(d.delta_bic)}}},
         {"heldout_component", d.component}, {"heldout_rms_before", Number(d.heldout_rms_before)},
         {"heldout_rms_after", Number(d.heldout_rms_after)},
         {"heldout_drift", {{"component", "heading"}, {"window_s", d.drift_window_s}, {"windows", d.drift_windows},
                            {"rms_before", Number(d.heldout_drift_before)}, {"rms_after", Number(d.heldout_drift_after)}}},
         {"where", Spans(d.where, origin)}});
  }
  (*j)["misfit"] = {{"variance_factor", Number(r.misfit.variance_factor)},
                 {"heading_drift_ratio", Number(r.misfit.heading_drift_ratio)}, {"beyond", r.misfit.beyond}};
  (*j)["indistinguishable"] = nlohmann::json::array();
  for (const Indistinguishable& d : r.indistinguishable)
    (*j)["indistinguishable"].push_back({{"effects", {d.first, d.second}}, {"correlation", Number(d.correlation)},
                                      {"separating_motion", d.motion}});
  (*j)["borderline"] = nlohmann::json::array();
  for (const Borderline& b : r.borderline) {
    nlohmann::json jb = {{"name", b.name}, {"status", CandidateStatusName(b.status)}, {"p_value", Number(b.p_value)},
                         {"alpha", Number(b.alpha)}, {"heldout_change", Number(b.heldout_change)},
                         {"heldout_confirmed", b.heldout_confirmed}};
    if (!b.wheel.empty()) jb["wheel"] = b.wheel;
    (*j)["borderline"].push_back(jb);
  }
  (*j)["moved"] = nlohmann::json::array();
  for (const MovedEffect& m : r.moved) {
    nlohmann::json jm = {{"name", m.name},
                         {"alone", {{"value", Number(m.alone.value)}, {"std", Number(m.alone.std)}}},
                         {"with_others", {{"value", Number(m.with_others.value)}, {"std", Number(m.with_others.std)}}},
                         {"others", m.others}};
    if (!m.wheel.empty()) jm["wheel"] = m.wheel;
    (*j)["moved"].push_back(jm);
  }
}

nlohmann::json IntervalsJson(const DiagnoseReport& r) {
  nlohmann::json iv = nlohmann::json::array();
  for (const DiagnosedInterval& d : r.intervals) {
    const MotionConditions& m = d.motion;
    iv.push_back({{"utime_start", d.utime_start}, {"utime_end", d.utime_end}, {"heldout", d.heldout},
                  {"outlier", d.outlier},
                  {"before", {d.before[0], d.before[1], d.before[2]}},
                  {"after", {d.after[0], d.after[1], d.after[2]}},
                  {"sigma", {d.sigma[0], d.sigma[1], d.sigma[2]}},
                  {"motion", {{"speed", m.speed}, {"accel", m.accel}, {"turn_rate", m.turn_rate},
                              {"turn_accel", m.turn_accel}, {"centripetal", m.centripetal},
                              {"steer", m.steer}, {"steer_rate", m.steer_rate},
                              {"steer_direction", m.steer_direction}, {"route_m", m.route_m},
                              {"x", m.x}, {"y", m.y}}}});
  }
  return iv;
}

}  // namespace

std::string DiagnoseReportJson(const DiagnoseReport& r) {
  nlohmann::json j;
  const int64_t origin = ReportTimeOrigin(r);
  j["verdict"] = r.verdict;
  j["drive"] = DriveTypeName(r.drive);
  j["time_origin_utime"] = origin;  // t_*_s keys count seconds from here: the recording's first message
  j["effects"] = nlohmann::json::array();
  for (const FoundEffect& e : r.effects) j["effects"].push_back(EffectJson(e, origin));
  j["unexplained"] = nlohmann::json::array();
  for (const Unexplained& u : r.unexplained)
    j["unexplained"].push_back({{"where", Spans(u.where, origin)}, {"correlates_with", u.correlates_with},
                                {"p_value", Number(u.p_value)}, {"component", u.component}});
  AddDecisionSections(r, origin, &j);
  j["candidates"] = nlohmann::json::array();
  for (const CandidateOutcome& c : r.candidates) {
    nlohmann::json jc = {{"name", c.name}, {"layer", c.layer}, {"status", CandidateStatusName(c.status)},
                         {"estimate", {{"value", Number(c.estimate.value)}, {"std", Number(c.estimate.std)}}},
                         {"p_value", Number(c.p_adjusted)}, {"delta_bic", Number(c.delta_bic)},
                         {"detectable", Number(c.detectable)}};
    if (!c.wheel.empty()) jc["wheel"] = c.wheel;
    for (const auto& [other, size] : c.detectable_with) jc["detectable_with"][other] = Number(size);
    if (!c.note.empty()) jc["note"] = c.note;
    j["candidates"].push_back(jc);
  }
  j["calibration"] = Params(r.calibration);
  j["refitted"] = Params(r.refitted);
  j["heldout"] = {{"intervals", r.heldout_intervals},
                  {"rms_before", {r.heldout_rms_before[0], r.heldout_rms_before[1], r.heldout_rms_before[2]}},
                  {"rms_after", {r.heldout_rms_after[0], r.heldout_rms_after[1], r.heldout_rms_after[2]}},
                  {"chi2_per_interval_before", Number(r.heldout_chi2_before)},
                  {"chi2_per_interval_after", Number(r.heldout_chi2_after)},
                  {"drift", {{"windows", r.heldout_drift_after.windows},
                             {"translation_before", Number(r.heldout_drift_before.rms_translation_m)},
                             {"translation_after", Number(r.heldout_drift_after.rms_translation_m)},
                             {"heading_before", Number(r.heldout_drift_before.rms_heading_rad)},
                             {"heading_after", Number(r.heldout_drift_after.rms_heading_rad)}}}};
  j["fit"] = {{"intervals", r.fit_intervals}, {"outliers", r.outliers}, {"variance_factor", Number(r.variance_factor)},
              {"outlier_share", Number(r.outlier_share)}, {"outlier_correlation", nlohmann::json::object()}};
  for (const auto& [name, c] : r.outlier_correlation) j["fit"]["outlier_correlation"][name] = Number(c);
  j["notes"] = r.notes;
  if (!r.warnings.empty()) j["warnings"] = r.warnings;
  if (r.input_dropped > 0) j["input"] = {{"dropped", r.input_dropped}, {"notes", r.input_notes}};
  j["intervals"] = IntervalsJson(r);
  AddProvenance(&j);
  return j.dump(1) + "\n";
}

std::string DiagnoseVerdict(const DiagnoseReport& r) {
  std::string verdict;
  if (!r.effects.empty()) {
    const FoundEffect& e = r.effects.front();
    const auto offset = e.params.find("offset_s");
    if (e.name == "time_offset" && offset != e.params.end()) {
      verdict = "The sensor's stamps and the wheels' are " + FixedDecimals(std::abs(offset->second.value) * 1e3, 0) +
                " ms apart (± " + FixedDecimals(offset->second.std * 1e3, 0) +
                " ms): fix the stamps, or let agvcal model it (agvcal solve --time-offset).";
    } else {
      std::string size;
      for (const auto& [k, v] : e.params) size += (size.empty() ? "" : ", ") + k + " = " + EstimateText(v.value, v.std, ParamUnit(k));
      verdict = "The calibrated model leaves out " + e.name + (e.wheel.empty() ? "" : " (wheel " + e.wheel + ")") +
                " (" + size + ", " + PValueText(e.p_adjusted) + "; modelled, the held-out residual where it acts is " +
                Percent(e.heldout_rms_before, e.heldout_rms_after) + " lower): fix its cause on the robot, or model it "
                "(docs/spec/effects.md).";
    }
    if (r.effects.size() > 1)
      verdict += " " + std::to_string(r.effects.size() - 1) + " more effect" + (r.effects.size() > 2 ? "s" : "") +
                 " below.";
  } else if (!r.discovered.empty() && r.verdict != "unmodelled_structure") {
    verdict = "The robot carries physics outside the catalogue (DISCOVERED PHYSICS below: " + r.discovered.front().equation +
              "): find its cause, or let the simulator reproduce it (diagnose --write-sim).";
  } else if (r.misfit.beyond) {
    verdict = "The calibrated model does not fit this recording (UNMODELLED STRUCTURE below) and nothing the diagnosis "
              "knows explains it: do not trust the calibration's sigmas.";
  } else if (!r.unexplained.empty()) {
    verdict = "The residual holds structure no catalogued effect explains (UNEXPLAINED below): find its cause before "
              "trusting the calibration's sigmas.";
  } else {
    verdict = "Nothing missing: the calibrated model explains this recording within its noise; keep the calibration.";
  }
  if (!r.indistinguishable.empty()) {
    const Indistinguishable& d = r.indistinguishable.front();
    verdict += " " + d.first + " and " + d.second + " cannot be told apart here: to tell them apart, drive " +
               d.motion + ".";
  }
  return verdict;
}

namespace {

// A discovered term as summary.txt shows it: the equation, its coefficients, reading, evidence
// and held-out figures.
void AppendDiscoveredText(const Discovered& d, int64_t origin, std::ostringstream& s) {
  s << "\nDISCOVERED PHYSICS (not in effects.md), through the " << d.channel << " channel:\n  " << d.equation << "\n";
  for (const DiscoveredTerm& t : d.terms)
    s << "  coefficient of " << t.regressor << ": " << EstimateText(t.coefficient.value, t.coefficient.std, t.unit) << "\n";
  s << "  reading: " << d.interpretation << "\n  evidence: " << PValueText(d.p_adjusted)
    << " after the correction over the library, delta BIC " << d.delta_bic << "\n  where: " << d.where.size()
    << " time spans";
  if (!d.where.empty()) s << ", at " << SpanTimes(d.where, origin) << " (s since the recording's first message)";
  s << "\n  held-out " << d.component << " residual where it acts: "
    << BeforeAfter(d.heldout_rms_before, d.heldout_rms_after, ComponentUnit(d.component)) << " ("
    << Percent(d.heldout_rms_before, d.heldout_rms_after) << " lower); held-out heading error over "
    << d.drift_window_s << " s (" << d.drift_windows << " windows): "
    << BeforeAfter(d.heldout_drift_before, d.heldout_drift_after, "rad") << " ("
    << Percent(d.heldout_drift_before, d.heldout_drift_after) << " lower)\n";
}

// A found effect as summary.txt shows it; the held-out measure that judges it is marked.
void AppendEffectText(const FoundEffect& e, int64_t origin, std::ostringstream& s) {
  // The held-out measure that judges the effect is marked.
  auto judges = [&e](const char* measure) { return e.heldout_measure == measure ? "  <- judges it\n" : "\n"; };
  s << "\nMISSING PHYSICS: " << e.name << (e.wheel.empty() ? "" : " (wheel " + e.wheel + ")") << ", "
    << e.layer << " layer.\n  size:";
  for (const auto& [k, v] : e.params) s << " " << k << " = " << EstimateText(v.value, v.std, ParamUnit(k));
  s << "\n  evidence: " << PValueText(e.p_adjusted) << " after the catalogue-wide correction";
  if (e.delta_bic != 0) s << ", delta BIC " << e.delta_bic;
  s << "\n  where: " << e.where.size() << " time spans, " << e.regime << "\n";
  if (!e.where.empty())
    s << "  at " << SpanTimes(e.where, origin) << " (s since the recording's first message)\n";
  if (e.region)
    s << "  on the floor: x " << (*e.region)[0] << " to " << (*e.region)[2] << " m, y " << (*e.region)[1] << " to "
      << (*e.region)[3] << " m (odometry frame)\n";
  s << "  held-out " << e.component << " residual where it acts: "
    << BeforeAfter(e.heldout_rms_before, e.heldout_rms_after, ComponentUnit(e.component)) << " ("
    << Percent(e.heldout_rms_before, e.heldout_rms_after) << " lower); over all held-out data "
    << BeforeAfter(e.heldout_rms_all_before, e.heldout_rms_all_after, ComponentUnit(e.component)) << " ("
    << Percent(e.heldout_rms_all_before, e.heldout_rms_all_after) << ")" << judges("per_interval");
  if (!e.stretches.empty()) {
    s << "  held-out " << e.component << " error chained over the stretch of each held-out block where it acts most ("
      << e.stretches.size() << " stretches): "
      << BeforeAfter(e.heldout_stretch_before, e.heldout_stretch_after, ComponentUnit(e.component)) << " ("
      << Percent(e.heldout_stretch_before, e.heldout_stretch_after) << " lower)" << judges("stretch");
  }
  if (!e.drift_component.empty()) {
    s << "  held-out dead-reckoning " << e.drift_component << " error over " << e.drift_window_s << " s ("
      << e.drift_windows << " windows): "
      << BeforeAfter(e.heldout_drift_before, e.heldout_drift_after, ComponentUnit(e.drift_component)) << " ("
      << Percent(e.heldout_drift_before, e.heldout_drift_after) << " lower)" << judges("drift");
  }
  if (e.heldout_disagrees)
    s << "  held-out proofs disagree: the measure that judges it is not lower with it; "
      << (e.heldout_confirmed_by.empty() ? "no held-out test confirms it against the final model without it"
                                         : "the held-out " + e.heldout_confirmed_by + " test confirms it")
      << "\n";
}

}  // namespace

std::string DiagnoseSummaryText(const DiagnoseReport& r, bool verbose) {
  std::ostringstream s;
  s.precision(4);
  s << DiagnoseVerdict(r) << "\n\n" << DriveTypeName(r.drive) << " drive: " << r.fit_intervals << " intervals fitted, " << r.heldout_intervals
    << " held out (alternating blocks), " << r.outliers << " outliers set aside.\n";
  if (r.outlier_correlation.empty()) {
    s << "Set aside: " << 100.0 * r.outlier_share << " % of all intervals.\n";
  } else {
    // What the intervals set aside have in common: outliers that cluster where the turn rate
    // changes are a time offset left unmodelled.
    auto strongest = r.outlier_correlation.begin();
    for (auto it = r.outlier_correlation.begin(); it != r.outlier_correlation.end(); ++it)
      if (std::abs(it->second) > std::abs(strongest->second)) strongest = it;
    s << "Set aside: " << 100.0 * r.outlier_share << " % of all intervals; strongest correlation with |"
      << strongest->first << "| (" << strongest->second << ").\n";
  }
  if (r.effects.empty() && r.verdict == "unmodelled_structure") {
    s << "UNMODELLED STRUCTURE: the final model's residuals are far beyond a well-fitting recording's (variance factor "
      << r.misfit.variance_factor << ", near 1 for a model that fits; held-out heading error over drift windows "
      << r.misfit.heading_drift_ratio << " times what independent noise of that size gives), and no catalogued effect "
      << "or library term explains them" << (r.discovered.empty() ? "" : " (the terms below only in part)")
      << ": physics is missing that the diagnosis cannot name.\n";
  } else if (r.effects.empty() && r.discovered.empty()) {
    s << "No significant unmodelled physics: the calibrated model explains the recording within its noise.\n";
  }
  for (const Discovered& d : r.discovered) AppendDiscoveredText(d, ReportTimeOrigin(r), s);
  for (const FoundEffect& e : r.effects) AppendEffectText(e, ReportTimeOrigin(r), s);
  for (const Indistinguishable& d : r.indistinguishable)
    s << "\nINDISTINGUISHABLE: " << d.first << " and " << d.second << " (correlation " << d.correlation
      << "); to tell them apart drive " << d.motion << ".\n";
  bool header = false;
  for (const Borderline& b : r.borderline) {
    if (!header) s << "\nBORDERLINE decisions (p within a factor " << kBorderlineFactor
                   << " of the level: a small change to the recording can flip them):\n";
    header = true;
    s << "  " << b.name << (b.wheel.empty() ? "" : " (" + b.wheel + ")") << " " << CandidateStatusName(b.status) << ": "
      << PValueText(b.p_value) << " at alpha " << b.alpha << "; held-out chi2 " << FixedDecimals(-100 * b.heldout_change, 1)
      << " % change with it alone, " << (b.heldout_confirmed ? "confirmed" : "not confirmed") << " on the held-out blocks\n";
  }
  header = false;
  for (const MovedEffect& m : r.moved) {
    if (!header) s << "\nMOVED by the other effects found (size alone -> with them, more than 2 sigma apart):\n";
    header = true;
    const std::string unit = ParamUnit(EffectSizeKey(m.name));
    s << "  " << m.name << (m.wheel.empty() ? "" : " (" + m.wheel + ")") << ": "
      << EstimateText(m.alone.value, m.alone.std, unit) << " -> " << EstimateText(m.with_others.value, m.with_others.std, unit)
      << " with";
    for (std::size_t k = 0; k < m.others.size(); ++k) s << (k ? ", " : " ") << m.others[k];
    s << "\n";
  }
  header = false;
  // Candidates significant by their Wald statistic but not found: the look-alikes rejected,
  // and where the Wald test and the BIC gate or held-out proof disagree, why. Without
  // `verbose`, in words only: the status tokens and statistics, and the region test's
  // bookkeeping, are REPORT.json's (candidates[]).
  for (const CandidateOutcome& c : r.candidates) {
    if (c.status == CandidateStatus::kFound || c.status == CandidateStatus::kIndistinguishable || c.note.empty() ||
        c.status == CandidateStatus::kNotIdentifiable)
      continue;
    const std::string why = verbose ? c.note : CandidateNoteInWords(c.note);
    if (why.empty()) continue;
    if (!header) s << (verbose ? "\nRejected look-alikes and disagreeing tests:\n" : "\nTested and not named:\n");
    const std::string unit = ParamUnit(EffectSizeKey(c.name));
    header = true;
    const std::string name = c.name + (c.wheel.empty() ? "" : " (" + c.wheel + ")");
    if (!verbose) {
      s << "  " << name << " " << EstimateText(c.estimate.value, c.estimate.std, unit) << ": " << why << "\n";
      continue;
    }
    s << "  " << name << " " << CandidateStatusName(c.status) << ": estimate "
      << EstimateText(c.estimate.value, c.estimate.std, unit) << ", " << PValueText(c.p_adjusted) << ", delta BIC "
      << c.delta_bic << ", detectable " << QuantityText(c.detectable, unit, 3) << "; " << c.note << "\n";
  }
  header = false;
  for (const CandidateOutcome& c : r.candidates) {
    if (c.status != CandidateStatus::kNotIdentifiable) continue;
    if (!header) s << "\nNot identifiable with this recording (neither found nor ruled out):\n";
    header = true;
    s << "  " << c.name << (c.wheel.empty() ? "" : " (" + c.wheel + ")") << ": " << c.note << "\n";
  }
  for (const Unexplained& u : r.unexplained)
    s << "\nUNEXPLAINED residual structure (no catalogued effect): correlates with " << u.correlates_with
      << ", in " << u.where.size() << " spans: " << SpanTimes(u.where, ReportTimeOrigin(r))
      << " (s since the recording's first message).\n";
  s << "\nOverall held-out residual RMS: x " << BeforeAfter(r.heldout_rms_before[0], r.heldout_rms_after[0], "m")
    << ", y " << BeforeAfter(r.heldout_rms_before[1], r.heldout_rms_after[1], "m") << ", yaw "
    << BeforeAfter(r.heldout_rms_before[2], r.heldout_rms_after[2], "rad") << " (chi2 per interval "
    << r.heldout_chi2_before << " -> " << r.heldout_chi2_after << ")\n";
  const OdometryError& db = r.heldout_drift_before;
  const OdometryError& da = r.heldout_drift_after;
  if (da.windows > 0)
    s << "Held-out dead reckoning over " << da.windows << " windows: translation "
      << BeforeAfter(db.rms_translation_m, da.rms_translation_m, "m") << ", heading "
      << BeforeAfter(db.rms_heading_rad, da.rms_heading_rad, "rad") << "\n";
  if (verbose)
    for (const std::string& n : r.notes) s << "note: " << n << "\n";
  for (const std::string& w : r.warnings) s << "warning: " << w << "\n";
  return s.str();
}

std::string CompareWithSimJson(const DiagnoseReport& real, const DiagnoseReport& sim) {
  nlohmann::json j;
  j["params"] = nlohmann::json::object();
  for (const auto& [k, v] : real.refitted) {
    const auto it = sim.refitted.find(k);
    if (it == sim.refitted.end()) continue;
    const double sd = std::hypot(v.std, it->second.std);
    j["params"][k] = {{"real", Number(v.value)}, {"sim", Number(it->second.value)},
                      {"difference", Number(v.value - it->second.value)},
                      {"z", Number(sd > 0 ? (v.value - it->second.value) / sd : 0.0)}};
  }
  // The effects one recording shows and the other does not are what the simulator lacks (or adds).
  j["effects"] = nlohmann::json::array();
  auto find = [](const DiagnoseReport& r, const std::string& name, const std::string& wheel) -> const FoundEffect* {
    for (const FoundEffect& e : r.effects)
      if (e.name == name && e.wheel == wheel) return &e;
    return nullptr;
  };
  for (const FoundEffect& e : real.effects) {
    const FoundEffect* other = find(sim, e.name, e.wheel);
    nlohmann::json je = {{"name", e.name}, {"real", Params(e.params)},
                         {"sim", other ? Params(other->params) : nlohmann::json()}};
    je["verdict"] = other ? "in both" : "missing from the simulator";
    if (!e.wheel.empty()) je["wheel"] = e.wheel;
    j["effects"].push_back(je);
  }
  for (const FoundEffect& e : sim.effects) {
    if (find(real, e.name, e.wheel)) continue;
    j["effects"].push_back({{"name", e.name}, {"real", nullptr}, {"sim", Params(e.params)},
                            {"verdict", "in the simulator only"}});
  }
  j["heldout_rms_real"] = {real.heldout_rms_after[0], real.heldout_rms_after[1], real.heldout_rms_after[2]};
  j["heldout_rms_sim"] = {sim.heldout_rms_after[0], sim.heldout_rms_after[1], sim.heldout_rms_after[2]};
  return j.dump(1);
}

std::string SimConfigYaml(const DiagnoseReport& r, const std::string& robot_path) {
  std::ostringstream s;
  s.precision(10);
  s << "# Written by agvcal diagnose: the calibration and the effects found, so that the\n"
       "# simulator reproduces the recorded robot.\n";
  s << "robot: " << robot_path << "\ntruth:\n  params: {";
  bool first = true;
  for (const std::string& name : r.param_names) {
    s << (first ? "" : ", ") << name << ": " << r.refitted.at(name).value;
    first = false;
  }
  s << "}\n";
  const std::string mount = r.source == MotionSource::kPose ? "pose" : "lidar2d";
  s << "  " << mount << ": {x: " << r.refitted.at(mount + ".x").value << ", y: " << r.refitted.at(mount + ".y").value
    << ", yaw: " << r.refitted.at(mount + ".yaw").value << "}\n";
  std::ostringstream fx;
  fx.precision(10);
  for (const FoundEffect& e : r.effects) {
    fx << "  " << e.name << ": {";
    bool f = true;
    for (const auto& [k, v] : e.params) {
      fx << (f ? "" : ", ") << k << ": " << v.value;
      f = false;
    }
    if (!e.wheel.empty()) fx << ", wheel: " << e.wheel;
    fx << "}\n";
  }
  if (!fx.str().empty()) s << "effects:\n" << fx.str();
  if (!r.discovered.empty()) s << "terms:  # physics outside effects.md the diagnosis discovered\n";
  for (const Discovered& d : r.discovered)
    for (const DiscoveredTerm& t : d.terms)
      s << "  - {channel: " << d.channel << ", regressor: \"" << t.regressor << "\", coefficient: " << t.coefficient.value
        << "}\n";
  return s.str();
}

}  // namespace calib
