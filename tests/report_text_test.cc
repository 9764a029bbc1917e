// What a person reads first, without a recording: each writer's verdict sentence, the run's
// provenance at the top of a page and summary.txt, and the diagnosis's bookkeeping kept off the
// plain summary (REPORT.json and --verbose keep it).

#include <gtest/gtest.h>

#include <string>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/calibration_report.h"
#include "calib/diagnose/diagnose.h"
#include "calib/io/provenance.h"
#include "io/report_page.h"

namespace calib {
namespace {

// A calibration with a held-out comparison: the calibrated model better in `better` of 20
// windows, from 12.4 to 5.3 mm per metre.
CalibrationResult WithHeldout(int better, double p) {
  CalibrationResult r;
  r.drive = DriveType::kTricycle;
  HeldoutComparison h;
  h.nominal.error_per_metre = 0.0124;
  h.calibrated.error_per_metre = 0.0053;
  h.paired.windows = 20;
  h.paired.second_better = better;
  h.paired.sign_test_p = p;
  r.heldout = h;
  return r;
}

TEST(Verdict, SolveSaysWhatToDoFirst) {
  EXPECT_EQ(SolveVerdict(WithHeldout(18, 0.0004)).rfind("Write the calibration (--write-robot): on the held-out part", 0),
            0u)
      << SolveVerdict(WithHeldout(18, 0.0004));
  EXPECT_NE(SolveVerdict(WithHeldout(18, 0.0004)).find("from 12.4 to 5.3 mm per metre"), std::string::npos);
  EXPECT_EQ(SolveVerdict(WithHeldout(3, 0.0026)).rfind("Keep the robot file's values", 0), 0u);
  EXPECT_EQ(SolveVerdict(WithHeldout(11, 0.82)).rfind("The calibration is not measurably better", 0), 0u);
  // A weak value: what to drive to determine it.
  CalibrationResult weak = WithHeldout(18, 0.0004);
  weak.drive = DriveType::kDifferential;
  weak.weak = {"track"};
  EXPECT_NE(SolveVerdict(weak).find("determines track only weakly: to pin it down, turn"), std::string::npos)
      << SolveVerdict(weak);
  // Halves that disagree come first: a single calibration may not fit the robot.
  CalibrationResult apart = WithHeldout(18, 0.0004);
  apart.heldout->halves = HalvesAgreement{};
  apart.heldout->halves->p = 1e-7;
  apart.heldout->halves->largest = "wheelbase";
  EXPECT_EQ(SolveVerdict(apart).rfind("Check before writing the calibration", 0), 0u) << SolveVerdict(apart);
  // The summary opens with the verdict.
  EXPECT_EQ(SolveReportSummary(WithHeldout(18, 0.0004), "x.log").rfind(SolveVerdict(WithHeldout(18, 0.0004)) + "\n\n", 0),
            0u);
}

TEST(Verdict, DiagnoseKeepsItsBookkeepingOffThePlainSummary) {
  DiagnoseReport r;
  r.verdict = "no_significant_effect";
  r.notes.push_back("actuation: the setpoint is held (log SSE -20057.950523 held, -9865.652972 ramped)");
  CandidateOutcome lag;
  lag.name = "steering_lag";
  lag.status = CandidateStatus::kNotSignificant;
  lag.estimate = {0.1719, 0.0034};
  lag.p_adjusted = 1e-13;
  lag.note = "significant by its Wald statistic but the fit does not pay for its parameter (delta BIC 1.7)";
  CandidateOutcome slip;
  slip.name = "longitudinal_slip";
  slip.status = CandidateStatus::kNotSignificant;
  slip.note = "not confined to a region either: the best of 3 boxes of the route (x 0 .. 0, y 0 .. 0 m) gives 0 s²/m";
  r.candidates = {lag, slip};
  const std::string plain = DiagnoseSummaryText(r);
  EXPECT_EQ(plain.rfind("Nothing missing: the calibrated model explains this recording within its noise", 0), 0u) << plain;
  for (const char* internal : {"log SSE", "note: ", "not_significant", "p < 1e-12", "x 0 .. 0", "longitudinal_slip"})
    EXPECT_EQ(plain.find(internal), std::string::npos) << internal << " in:\n" << plain;
  EXPECT_NE(plain.find("steering_lag 0.1719 ± 0.0034 s: significant by its Wald statistic but the fit does not pay"),
            std::string::npos)
      << plain;
  const std::string verbose = DiagnoseSummaryText(r, true);
  for (const char* internal : {"note: actuation: the setpoint is held (log SSE", "steering_lag not_significant",
                               "x 0 .. 0"})
    EXPECT_NE(verbose.find(internal), std::string::npos) << internal << " not in:\n" << verbose;
  // A note with the region clause between others keeps the others.
  EXPECT_EQ(CandidateNoteInWords("a; not confined to a region either: the best of 3 boxes (x 0 .. 0); b"), "a; b");
  EXPECT_EQ(CandidateNoteInWords("not confined to a region either: x"), "");
}

TEST(Provenance, OnTopOfThePageAndTheSummary) {
  ReportPage before("agvcal solve: test");
  before.Verdict("Write the calibration.");
  before.Paragraph("body");
  const std::string without = before.Render();
  EXPECT_NE(without.find("</h1>\n<p class=\"verdict\">Write the calibration.</p>\n<p>body</p>"), std::string::npos)
      << without;
  Provenance p;
  p.command = "build/agvcal solve config/robots/forklift.yaml logs/forklift_demo.log --fit-fraction 0.7";
  p.robot_name = "forklift-07";
  p.robot_file = "config/robots/forklift.yaml";
  p.recording = "logs/forklift_demo.log";
  p.recording_sha256 = std::string(64, 'a');
  p.version = "0.1.0 (git abc1234)";
  p.date = "2026-11-27T17:00:00Z";
  SetRunProvenance(p);
  const std::string page = before.Render();
  const std::size_t verdict = page.find("class=\"verdict\""), command = page.find("<th>command</th><td>build/agvcal solve"),
                    body = page.find("<p>body</p>");
  ASSERT_NE(command, std::string::npos) << page;
  EXPECT_LT(verdict, command);
  EXPECT_LT(command, body);
  for (const char* row : {"<th>robot_name</th><td>forklift-07</td>", "<th>agvcal_version</th><td>0.1.0 (git abc1234)</td>",
                          "<th>date</th><td>2026-11-27T17:00:00Z</td>"})
    EXPECT_NE(page.find(row), std::string::npos) << row;
  const std::string summary = WithProvenance("Write the calibration.\n");
  EXPECT_EQ(summary.rfind("command: build/agvcal solve", 0), 0u) << summary;
  EXPECT_NE(summary.find("\nrecording_sha256: " + std::string(64, 'a') + "\n"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\n\nWrite the calibration.\n"), std::string::npos) << summary;
}

}  // namespace
}  // namespace calib
