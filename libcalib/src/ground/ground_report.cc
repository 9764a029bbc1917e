// agvcal ground --report DIR: the floor the calibration stands on, as a person looks at it.

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "calib/core/units.h"
#include "calib/ground/ground.h"
#include "calib/ground/ground_session.h"
#include "calib/io/atomic_file.h"
#include "calib/io/provenance.h"
#include "io/report_page.h"
#include "io/svg_plot.h"

namespace calib {
namespace {

// Height of each sampled floor point above the floor of `pose` (m).
std::vector<double> Heights(const std::vector<float>& xyz, const FloorPose& pose) {
  const Eigen::Vector3d n = FloorNormal(pose.pitch, pose.roll);
  std::vector<double> h;
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) h.push_back(n.x() * xyz[i] + n.y() * xyz[i + 1] + n.z() * xyz[i + 2] + pose.z);
  return h;
}

double Range(const std::vector<double>& mm) {
  std::vector<double> mag;
  for (double v : mm) mag.push_back(std::abs(v));
  std::sort(mag.begin(), mag.end());
  const double r = mag.empty() ? 1.0 : mag[std::min(mag.size() - 1, mag.size() * 98 / 100)];
  return r > 0 ? r : 1.0;
}

std::string FloorPointsPlot(const GroundResult& r, const std::vector<double>& mm) {
  const double range = Range(mm);
  SvgPlot plot("Floor points seen from the lidar, coloured by their height above the calibrated floor", 900, 560);
  SvgPlot::Panel& p = plot.AddPanel("floor points (a sample of " + std::to_string(mm.size()) +
                                        " from the frames used), lidar frame seen from above",
                                    "x (m)", "y (m)");
  p.equal_axes = true;
  SvgPlot::Series s{{}, {}, "#000000", "", true, {}, {}};
  for (std::size_t i = 0; i < mm.size(); ++i) {
    s.x.push_back(r.floor_points[3 * i]), s.y.push_back(r.floor_points[3 * i + 1]);
    s.colors.push_back(ColorRamp(mm[i], -range, range));
  }
  p.series = {s};
  p.color_bar_label = "height (mm)";
  p.color_bar_lo = -range, p.color_bar_hi = range;
  return plot.Render();
}

std::string HeightHistogram(const std::vector<double>& mm) {
  const double range = 2 * Range(mm);
  SvgPlot plot("Height of the floor points above the calibrated floor");
  SvgPlot::Panel& p = plot.AddPanel("height (mm; the outermost bins hold the tails)", "mm", "share of points");
  p.series = {HistogramSeries(mm, -range, range, 41, "#1f5fbf", "floor points")};
  return plot.Render();
}

std::string FramesPlot(const GroundResult& r) {
  SvgPlot plot("Each usable frame's own floor fit (dots, ±1σ) and the combined estimate (line)", 900, 200);
  const MountEstimate& e = r.lidar3d;
  const char* names[3] = {"height z (mm)", "pitch (mrad)", "roll (mrad)"};
  const double value[3] = {e.value.z, e.value.pitch, e.value.roll};
  for (int c = 0; c < 3; ++c) {
    SvgPlot::Panel& p = plot.AddPanel(names[c], "frame (in recording order)", c ? "mrad" : "mm");
    SvgPlot::Series f{{}, {}, "#1f5fbf", "frame", true, {}, {}}, line{{}, {}, "#000000", "combined", false, {}, {}};
    for (std::size_t i = 0; i < r.frame_fits.size(); ++i) {
      const FrameFit& fit = r.frame_fits[i];
      if (!fit.usable) continue;
      const double v[3] = {fit.pose.z, fit.pose.pitch, fit.pose.roll};
      f.x.push_back(i), f.y.push_back(v[c] * 1e3), f.error.push_back(std::sqrt(std::max(0.0, fit.cov(c, c))) * 1e3);
    }
    if (!f.x.empty()) line.x = {f.x.front(), f.x.back()}, line.y = {value[c] * 1e3, value[c] * 1e3};
    p.series = {f, line};
  }
  return plot.Render();
}

std::vector<std::string> MountRow(const std::string& name, double value, double sigma, double nominal, bool angle) {
  const double k = angle ? 180 / M_PI : 1e3;
  return {name, ValueWithSigma(value, sigma) + (angle ? " rad" : " m"),
          ValueWithSigma(value * k, sigma * k) + (angle ? " deg" : " mm"), FixedDecimals(nominal, 6) + (angle ? " rad" : " m"),
          FixedDecimals((value - nominal) * k, angle ? 3 : 1) + (angle ? " deg" : " mm")};
}

std::vector<std::vector<std::string>> SectorRows(const GroundResult& r) {
  std::vector<std::vector<std::string>> rows;
  for (const SectorEstimate& s : r.sectors) {
    const MountEstimate& e = s.estimate;
    rows.push_back({std::to_string(s.index), FixedDecimals(s.angle_min * 180 / M_PI, 1) + " .. " + FixedDecimals(s.angle_max * 180 / M_PI, 1),
                    std::to_string(e.frames), ValueWithSigma(e.value.z * 1e3, e.std.z * 1e3),
                    ValueWithSigma(e.value.pitch * 180 / M_PI, e.std.pitch * 180 / M_PI),
                    ValueWithSigma(e.value.roll * 180 / M_PI, e.std.roll * 180 / M_PI), FixedDecimals(100 * e.inliers, 1),
                    FixedDecimals(1e3 * e.rms_m, 1)});
  }
  return rows;
}

}  // namespace

void WriteGroundReportDir(const RobotDescription& robot, const GroundResult& r, const GroundInput& input,
                          const std::string& dir) {
  MakeReportDir(dir);
  const std::string summary = GroundResultText(r, input);
  const MountEstimate& e = r.lidar3d;
  const std::string verdict = "Write the mount (--write-robot): the floor puts the 3D lidar " +
                              MillimetresText(e.value.z, 1) + " above it (± " + MillimetresText(e.std.z, 1) +
                              "), pitched " + AngleText(e.value.pitch) + " and rolled " + AngleText(e.value.roll) +
                              ", from " + std::to_string(e.frames) + " frames.";
  WriteFileAtomically(dir + "/summary.txt", WithProvenance(verdict + "\n\n" + summary));
  ReportPage page("agvcal ground: the 3D lidar above the floor");
  page.Verdict(verdict);
  page.Text(summary);
  const Mount3d nominal = robot.lidar3d.value_or(Mount3d{});
  page.Heading("Mount");
  page.Table({"parameter", "calibrated ± 1σ", "the same in", "nominal (robot file)", "change"},
             {MountRow("lidar3d.z", e.value.z, e.std.z, nominal.z, false),
              MountRow("lidar3d.pitch", e.value.pitch, e.std.pitch, nominal.pitch, true),
              MountRow("lidar3d.roll", e.value.roll, e.std.roll, nominal.roll, true)});
  page.Paragraph(std::to_string(e.frames) + " frames combined (" + std::to_string(e.frames_tilted) +
                 " left out as tilted against the others); frames scatter " + FixedDecimals(e.birge_ratio, 2) +
                 " times their own sigmas" + (e.birge_ratio > 1 ? " (sigmas inflated by that)" : "") + ".");
  if (!r.sectors.empty()) {
    page.Heading("Per sector of the lidar's rotation");
    page.Table({"sector", "angle (deg)", "frames", "z (mm)", "pitch (deg)", "roll (deg)", "floor inliers (%)", "floor RMS (mm)"},
               SectorRows(r));
  }
  if (!r.floor_points.empty()) {
    std::vector<double> mm = Heights(r.floor_points, e.value);
    for (double& v : mm) v *= 1e3;
    page.Heading("Floor points");
    WriteFileAtomically(dir + "/floor_points.svg", FloorPointsPlot(r, mm));
    page.Figure("floor_points.svg", "Floor points coloured by their height above the calibrated floor: a tilt left "
                                    "in the calibration shows as a colour gradient across the floor");
    WriteFileAtomically(dir + "/floor_height_histogram.svg", HeightHistogram(mm));
    page.Figure("floor_height_histogram.svg", "Distribution of the floor points' height above the calibrated floor");
  }
  if (!r.frame_fits.empty()) {
    page.Heading("Frames");
    WriteFileAtomically(dir + "/frames.svg", FramesPlot(r));
    page.Figure("frames.svg", "Every usable frame's own fit against the combined estimate (frames of all sectors)");
  }
  WriteFileAtomically(dir + "/index.html", page.Render());
}

}  // namespace calib
