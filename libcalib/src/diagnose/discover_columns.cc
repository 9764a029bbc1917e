#include "diagnose/discover_columns.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>
#include <ceres/jet.h>

#include "calib/calibrate/interval_model.h"
#include "calib/core/kinematics_generic.h"

namespace calib::diag {
namespace {

// Library terms the integration differentiates at once (the timing channel is not integrated).
constexpr int kMaxIntegrated = 8;
using TermJet = ceres::Jet<double, kMaxIntegrated>;

// The steering offset's index into the drive parameters for wheel w (-1 unsteered).
int SteerOffsetIndex(DriveType drive, int w) {
  const std::string name = SteerOffsetParamName(WheelRoles(drive)[w]);
  const std::vector<std::string>& names = ParamNames(drive);
  const auto it = std::find(names.begin(), names.end(), name);
  return name.empty() || it == names.end() ? -1 : int(it - names.begin());
}

struct Integrated {
  generic::Pose<TermJet> q;  // body motion over the window, by each integrated term's coefficient
  double mid_time = 0;       // s since the recording's start, the window's middle
};

// The wheel odometry of `it` over its window, each library term `terms[k]` (k < kMaxIntegrated,
// not timing) entering through its channel at `coefficients[k]` (none: all 0) with the
// derivative in the Jet's component k.
Integrated Integrate(const Recording& recording, const Interval& it, const Model& m,
                     const std::vector<LibraryTerm>& terms, const std::vector<double>& coefficients) {
  const Track& tr = recording.track;
  const int nw = tr.wheels;
  const int64_t t0 = it.motion->utime_start;
  const double duration = (it.motion->utime_end - t0) * 1e-6;
  const double a = -m.beta[kTimeOffset], b = duration - m.beta[kTimeOffset];
  const double recording_start = tr.size() ? tr.utime(0) * 1e-6 : 0.0;
  int steered_wheel = -1, offset_index = -1;
  for (int w = 0; w < nw && steered_wheel < 0; ++w)
    if (tr.steered[w]) steered_wheel = w, offset_index = SteerOffsetIndex(tr.drive, w);
  TermJet params[5];
  for (int p = 0; p < 5; ++p) params[p] = TermJet(m.params[p]);
  Integrated out;
  out.q = {TermJet(0.0), TermJet(0.0), TermJet(0.0)};
  out.mid_time = t0 * 1e-6 + 0.5 * (a + b) - recording_start;
  const std::size_t first = it.cost->first(), last = it.cost->last();
  auto time = [&](std::size_t i) { return (tr.utime(i) - t0) * 1e-6; };
  for (std::size_t i = first; i < last; ++i) {
    const double ti = time(i), tn = time(i + 1);
    const double ts = std::max(a, ti), te = std::min(b, tn);
    if (te - ts <= 1e-9 || tn - ti <= 1e-9) continue;
    const double fs = (ts - ti) / (tn - ti), fe = (te - ti) / (tn - ti), fm = 0.5 * (fs + fe);
    double rotation[2] = {0, 0}, steer[2] = {0, 0}, speed[2] = {0, 0};
    for (int w = 0; w < nw; ++w) {
      rotation[w] = (tr.pos(i + 1, w) - tr.pos(i, w)) * (fe - fs);
      steer[w] = tr.steer(i, w) + fm * (tr.steer(i + 1, w) - tr.steer(i, w));
      speed[w] = tr.speed[i][w] + fm * (tr.speed[i + 1][w] - tr.speed[i][w]);
    }
    TermMotion motion;
    double vy = 0;
    generic::BodyDisplacement(tr.drive, m.params, speed, steer, &motion.speed, &vy, &motion.turn_rate);
    if (steered_wheel >= 0) motion.steer = steer[steered_wheel] - (offset_index >= 0 ? m.params[offset_index] : 0.0);
    motion.time = t0 * 1e-6 + 0.5 * (ts + te) - recording_start;
    TermJet rot[2] = {TermJet(rotation[0]), TermJet(rotation[1])};
    TermJet st[2] = {TermJet(steer[0]), TermJet(steer[1])};
    TermJet yaw_extra(0.0);
    for (std::size_t k = 0; k < terms.size() && k < std::size_t(kMaxIntegrated); ++k) {
      const double g = FindTermRegressor(terms[k].regressor)->value(motion);
      TermJet eps(coefficients.empty() ? 0.0 : coefficients[k], int(k));
      if (terms[k].channel == TermChannel::kYawRate) yaw_extra += eps * (g * (te - ts));
      if (terms[k].channel == TermChannel::kRadius)
        for (int w = 0; w < nw; ++w) rot[w] += eps * (g * rotation[w]);
      if (terms[k].channel == TermChannel::kSteer)
        for (int w = 0; w < nw; ++w)
          if (tr.steered[w]) st[w] += eps * g;
    }
    TermJet dx, dy, dtheta;
    generic::BodyDisplacement(tr.drive, params, rot, st, &dx, &dy, &dtheta);
    out.q = generic::Compose(out.q, generic::Exp(dx, dy, TermJet(dtheta + yaw_extra)));
  }
  return out;
}

}  // namespace

std::vector<int> FreeParams(const Recording& recording) {
  std::vector<int> free_params;
  for (int p = 0; p < recording.num_params; ++p)
    if (std::find(recording.held_params.begin(), recording.held_params.end(), p) == recording.held_params.end())
      free_params.push_back(p);
  return free_params;
}

Model Updated(const Recording& recording, const Model& m, const std::vector<int>& free_betas, const double* change) {
  Model out = m;
  int c = 0;
  for (int p : FreeParams(recording)) out.params[p] += change[c++];
  for (int k = 0; k < 3; ++k) out.mount[k] += change[c++];
  for (int j : free_betas) out.beta[j] += change[c++];
  return out;
}

std::vector<DiscoveryRow> DiscoveryRows(const Recording& recording, const Model& m,
                                        const std::vector<LibraryTerm>& terms, const std::vector<int>& free_betas,
                                        const std::vector<double>& coefficients) {
  std::vector<int> all_betas;
  for (int j = 0; j < kNumBeta; ++j) all_betas.push_back(j);
  const std::vector<int> free_params = FreeParams(recording);
  const int na = int(free_params.size()) + 3 + int(free_betas.size());
  std::vector<DiscoveryRow> rows;
  for (const Interval& it : recording.intervals) {
    if (it.outlier) continue;
    DiscoveryRow row;
    row.heldout = it.heldout;
    row.block = it.block;
    row.utime_start = it.motion->utime_start;
    row.utime_end = it.motion->utime_end;
    row.sigma = it.sigma;
    double r[3];
    Jacobians jac;
    Residual(it, m, r, &jac, all_betas);
    row.r = Eigen::Vector3d(r[0], r[1], r[2]);
    const Eigen::Matrix3d U = SqrtInformation(it.motion->covariance);
    row.unwhiten = U.inverse();
    row.A.resize(3, na);
    int c = 0;
    for (int p : free_params) row.A.col(c++) = jac.params.col(p);
    for (int k = 0; k < 3; ++k) row.A.col(c++) = jac.mount.col(k);
    for (int j : free_betas) row.A.col(c++) = jac.beta.col(j);
    row.C = jac.beta;
    const Integrated in = Integrate(recording, it, m, terms, coefficients);
    // z = l^-1 q l, r = U (m - z): each term's column is -U dz/dc.
    using P = generic::Pose<TermJet>;
    const P l{TermJet(m.mount[0]), TermJet(m.mount[1]), TermJet(m.mount[2])};
    const P z = generic::Compose(generic::Compose(generic::Inverse(l), in.q), l);
    double timing = 0;  // the timing terms' offset at the interval
    if (!coefficients.empty()) {
      // The residual with the terms at their coefficients, to every order: the model's, moved by
      // the terms' change of the predicted motion.
      const P z0 = generic::Compose(generic::Compose(generic::Inverse(l), Integrate(recording, it, m, terms, {}).q), l);
      row.r -= U * Eigen::Vector3d(z.x.a - z0.x.a, z.y.a - z0.y.a, z.theta.a - z0.theta.a);
      for (std::size_t k = 0; k < terms.size(); ++k)
        if (terms[k].channel == TermChannel::kTiming) timing += coefficients[k] * in.mid_time;
      row.r += jac.beta.col(kTimeOffset) * timing;
    }
    row.G.resize(3, terms.size());
    for (std::size_t k = 0; k < terms.size(); ++k) {
      Eigen::Vector3d dz = Eigen::Vector3d::Zero();
      if (terms[k].channel == TermChannel::kTiming) {
        row.G.col(k) = jac.beta.col(kTimeOffset) * in.mid_time;
        continue;
      }
      if (k < std::size_t(kMaxIntegrated)) dz = Eigen::Vector3d(z.x.v[k], z.y.v[k], z.theta.v[k]);
      row.G.col(k) = -U * dz;
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace calib::diag
