// One frame's floor (FitFloor, calib/ground/ground.h): the returns near the nominal floor,
// a consensus plane among them, and its refinement into the lidar's height, pitch and roll.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "calib/core/units.h"
#include "calib/ground/ground.h"
#include "ground/median.h"
#include "ground/sac_plane.h"

namespace calib {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

Eigen::Matrix3d Rotation(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Least-squares plane n.p + d = 0 (|n| = 1, n on the side of `up`) through the
// points selected by `selected`: centroid and smallest principal axis.
bool FitPlane(const std::vector<float>& xyz, const std::vector<uint32_t>& selected,
              const Eigen::Vector3d& up, Eigen::Vector3d* normal, double* d) {
  if (selected.size() < 3) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (uint32_t i : selected) mean += Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  mean /= static_cast<double>(selected.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (uint32_t i : selected) {
    const Eigen::Vector3d q = Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]) - mean;
    scatter.noalias() += q * q.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  if (eig.info() != Eigen::Success) return false;
  Eigen::Vector3d n = eig.eigenvectors().col(0);  // eigenvalues ascending
  if (n.dot(up) < 0) n = -n;
  *normal = n;
  *d = -n.dot(mean);
  return true;
}

// Marks the points near the foot of anything standing on the floor (walls,
// obstacles): the floor within one cell of a cell that holds a point between
// `low` and `high` above the plane n.p + d = 0. Such points may belong to the
// thing's base rather than the floor, and would lift the plane.
std::vector<uint8_t> NearObstacles(const std::vector<float>& xyz, const Eigen::Vector3d& n, double d,
                                   double floor_band, double low, double high, double cell) {
  const size_t count = xyz.size() / 3;
  const Eigen::Vector3d u = n.unitOrthogonal() / cell, v = n.cross(n.unitOrthogonal()) / cell;
  std::vector<float> h(count), a(count), b(count);
  double a_min = 1e300, a_max = -1e300, b_min = 1e300, b_max = -1e300;
  for (size_t i = 0; i < count; ++i) {
    Eigen::Vector3d p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    const double np = n.dot(p);
    h[i] = static_cast<float>(np + d);
    // A floor point is placed where its ray meets the plane, not where its
    // noisy range put it: otherwise noise along the ray would decide which
    // points near an obstacle are left out, and bias the plane.
    if (std::abs(h[i]) <= floor_band && np < 0) p *= -d / np;
    a[i] = static_cast<float>(u.dot(p));
    b[i] = static_cast<float>(v.dot(p));
    if (std::abs(h[i]) <= floor_band) {
      a_min = std::min<double>(a_min, a[i]), a_max = std::max<double>(a_max, a[i]);
      b_min = std::min<double>(b_min, b[i]), b_max = std::max<double>(b_max, b[i]);
    }
  }
  std::vector<uint8_t> near(count, 0);
  if (a_min > a_max) return near;
  const long a0 = static_cast<long>(std::floor(a_min)) - 1, b0 = static_cast<long>(std::floor(b_min)) - 1;
  const long nx = static_cast<long>(std::floor(a_max)) - a0 + 2, ny = static_cast<long>(std::floor(b_max)) - b0 + 2;
  if (nx * ny > (1L << 24)) return near;  // absurd extent: leave the floor as it is
  std::vector<uint8_t> occupied(static_cast<size_t>(nx * ny), 0);
  auto cell_of = [&](size_t i, long* ix, long* iy) {
    *ix = static_cast<long>(std::floor(a[i])) - a0;
    *iy = static_cast<long>(std::floor(b[i])) - b0;
    return *ix >= 0 && *ix < nx && *iy >= 0 && *iy < ny;
  };
  long ix, iy;
  for (size_t i = 0; i < count; ++i)
    if (h[i] > low && h[i] < high && cell_of(i, &ix, &iy)) occupied[iy * nx + ix] = 1;
  for (size_t i = 0; i < count; ++i) {
    if (std::abs(h[i]) > floor_band || !cell_of(i, &ix, &iy)) continue;
    for (long dy = -1; dy <= 1 && !near[i]; ++dy)
      for (long dx = -1; dx <= 1; ++dx) {
        const long x = ix + dx, y = iy + dy;
        if (x >= 0 && x < nx && y >= 0 && y < ny && occupied[y * nx + x]) {
          near[i] = 1;
          break;
        }
      }
  }
  return near;
}

// FitFloor, steps 1 and 2: the returns outside the body box (`kept`) and, of
// those, the ones near the nominal floor (`candidates`), xyz interleaved in
// the sensor frame; counts the points and body points into `fit`.
void SelectReturns(const float* xyz, size_t count, const Mount3d& nominal,
                   const FloorFitOptions& options, double mount_angle, std::vector<float>* kept,
                   std::vector<float>* candidates, FrameFit* fit) {
  // Nominal sensor-to-robot transform; a turret turns the sensor about the robot's vertical.
  const Eigen::Matrix3f rotation =
      Rotation(nominal.yaw + mount_angle, nominal.pitch, nominal.roll).cast<float>();
  const Eigen::Vector3f mount(static_cast<float>(nominal.x), static_cast<float>(nominal.y),
                              static_cast<float>(nominal.z));
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f hi = -lo;
  if (nominal.body) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = static_cast<float>(nominal.body->min[k] - options.body_margin_m);
      hi[k] = static_cast<float>(nominal.body->max[k] + options.body_margin_m);
    }
  }
  const float min_range2 = static_cast<float>(options.min_range_m * options.min_range_m);
  const float max_range2 = options.max_range_m > 0
                               ? static_cast<float>(options.max_range_m * options.max_range_m)
                               : std::numeric_limits<float>::infinity();
  const float window = static_cast<float>(options.window_m);

  kept->reserve(3 * count);
  candidates->reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const Eigen::Vector3f p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    if (!p.allFinite() || p.squaredNorm() < min_range2 || p.squaredNorm() > max_range2) continue;
    ++fit->points;
    const Eigen::Vector3f q = rotation * p + mount;
    if ((q.array() > lo.array()).all() && (q.array() < hi.array()).all()) {
      ++fit->body_points;
      continue;
    }
    kept->insert(kept->end(), {p.x(), p.y(), p.z()});
    if (std::abs(q.z()) <= window) candidates->insert(candidates->end(), {p.x(), p.y(), p.z()});
  }
}

// FitFloor, step 3: consensus on an evenly spread subsample of the candidates
// (speed; the refinement uses every point).
std::optional<SacPlane> ConsensusPlane(const std::vector<float>& candidates, int num_candidates,
                                       const Eigen::Vector3d& up0, const FloorFitOptions& options) {
  const size_t stride = (static_cast<size_t>(num_candidates) +
                         static_cast<size_t>(std::max(options.ransac_max_points, 3)) - 1) /
                        static_cast<size_t>(std::max(options.ransac_max_points, 3));
  std::vector<float> sample;
  if (stride > 1) {
    sample.reserve(3 * (candidates.size() / 3 / stride + 1));
    for (size_t i = 0; i < candidates.size() / 3; i += stride)
      sample.insert(sample.end(), candidates.begin() + 3 * i, candidates.begin() + 3 * i + 3);
  }
  const std::vector<float>& consensus_points = stride > 1 ? sample : candidates;
  return FindPlaneSac(consensus_points.data(), consensus_points.size() / 3, up0,
                      options.max_tilt_rad, options.ransac_threshold_m,
                      options.ransac_max_iterations);
}

// FitFloor, step 4: the refinement. Each point is a range r along an exactly
// known ray u = p/|p|; its height above the floor is h = c r + z with c = n.u,
// and its variance is modelled as var(h) = s_r^2 c^2 + s_f^2 (range noise seen
// at the ray's incidence, plus floor roughness), both estimated from the
// residuals. Points within band_sigmas of that (at least min_band) are the
// floor. The first pass fits by principal axes; later ones by Gauss-Newton
// with weights 1/var(h) and the Jacobian taken at the predicted floor point
// (range -z/c), not the measured one: a Jacobian holding the measured, noisy
// range would correlate with the residual and bias the fit.
class FloorRefiner {
 public:
  // `kept`: the non-body returns (xyz interleaved); (normal, d): the consensus plane.
  FloorRefiner(const std::vector<float>& kept, const Eigen::Vector3d& normal, double d,
               const FloorFitOptions& options)
      : kept_(kept),
        options_(options),
        n_kept_(kept.size() / 3),
        range_(n_kept_),
        n_(normal),
        d_(d),
        var_floor_(std::pow(options.ransac_threshold_m / options.band_sigmas, 2)),
        min_band2_(options.min_band_m * options.min_band_m),
        sigmas2_(options.band_sigmas * options.band_sigmas) {
    for (size_t i = 0; i < n_kept_; ++i)
      range_[i] = std::sqrt(kept[3 * i] * kept[3 * i] + kept[3 * i + 1] * kept[3 * i + 1] +
                            kept[3 * i + 2] * kept[3 * i + 2]);
  }

  // The passes; false, with fit->problem, when the plane loses its points.
  bool Refine(const Eigen::Vector3d& up0, FrameFit* fit) {
    for (int iteration = 0; iteration <= options_.refine_iterations; ++iteration) {
      inliers_.clear();
      for (size_t i = 0; i < n_kept_; ++i) {
        double c;
        const double h = Height(i, &c);
        // c < 0: the ray goes down (every floor point's does, c = -z/r).
        if (c < -1e-3 && h * h <= Band2Of(c) && (near_obstacle_.empty() || !near_obstacle_[i]))
          inliers_.push_back(static_cast<uint32_t>(i));
      }
      if (inliers_.size() < 3) {
        fit->problem = "the floor plane lost its points while refining";
        return false;
      }
      if (iteration == 0) {
        if (!FitPlane(kept_, inliers_, up0, &n_, &d_)) {
          fit->problem = "the floor plane lost its points while refining";
          return false;
        }
      } else {
        Accumulate(false);  // one Gauss-Newton step per pass: the start is close
        const Eigen::Vector3d delta = a_.ldlt().solve(-g_);
        if (delta.allFinite()) {
          double pitch, roll;
          PitchRollOf(n_, &pitch, &roll);
          d_ += delta[0];
          n_ = FloorNormal(pitch + delta[1], roll + delta[2]);
        }
      }
      EstimateVariances();
      if (iteration == 0 && options_.obstacle_cell_m > 0) {
        const double band = std::sqrt(Band2Of(-1.0));  // the widest band: near, steep rays
        near_obstacle_ = NearObstacles(kept_, n_, d_, band, std::max(2 * band, options_.obstacle_min_height_m),
                                       options_.obstacle_max_height_m, options_.obstacle_cell_m);
        fit->near_obstacles = static_cast<int>(std::count(near_obstacle_.begin(), near_obstacle_.end(), 1));
      }
    }
    return true;
  }

  // After Refine: the inliers, the pose, and the sandwich covariance of
  // (z, pitch, roll), A^-1 B A^-1 with A = sum w J J', B = sum w^2 h^2 J J'.
  void Finish(FrameFit* fit, std::vector<float>* floor_points) {
    fit->inliers = static_cast<int>(inliers_.size());
    if (floor_points) {
      floor_points->clear();
      floor_points->reserve(3 * inliers_.size());
      for (uint32_t i : inliers_) floor_points->insert(floor_points->end(), kept_.begin() + 3 * i, kept_.begin() + 3 * i + 3);
    }
    fit->pose.z = d_;
    PitchRollOf(n_, &fit->pose.pitch, &fit->pose.roll);

    Accumulate(true);
    const double m = static_cast<double>(inliers_.size());
    fit->rms_m = std::sqrt(sum_h2_ / m);
    const Eigen::Matrix3d a_inv = a_.inverse();
    fit->cov = a_inv * b_ * a_inv * (m / std::max(m - 3.0, 1.0));
    fit->range_noise_m = std::sqrt(var_range_);
    fit->floor_noise_m = std::sqrt(var_floor_);
  }

  const Eigen::Vector3d& normal() const { return n_; }
  double d() const { return d_; }
  const std::vector<uint32_t>& inliers() const { return inliers_; }
  // Half width of the widest band: near, steep rays.
  double widest_band() const { return std::sqrt(Band2Of(-1.0)); }

 private:
  static constexpr int kBins = 7;

  // Height and incidence of point i under (n, d).
  double Height(size_t i, double* c) const {
    const double h = n_.x() * kept_[3 * i] + n_.y() * kept_[3 * i + 1] + n_.z() * kept_[3 * i + 2];
    *c = h / range_[i];
    return h + d_;
  }

  double Band2Of(double c) const {
    return std::max(sigmas2_ * (var_range_ * c * c + var_floor_), min_band2_);
  }

  // s_r^2 and s_f^2 (>= 0): the inliers in bins of |c| (steep to grazing
  // rays), a robust variance per bin ((1.4826 MAD)^2, so stray points near the
  // band's edge do not inflate it), and var = s_r^2 c^2 + s_f^2 fitted to the
  // bins by least squares.
  void EstimateVariances() {
    constexpr double kBinEdges[] = {0.0, 0.015, 0.03, 0.06, 0.12, 0.24, 0.48, 2.0};
    double bin_c2[kBins] = {};
    for (auto& v : bin_h_) v.clear();
    for (uint32_t i : inliers_) {
      double c;
      const double h = Height(i, &c);
      int k = 0;
      while (k + 1 < kBins && -c >= kBinEdges[k + 1]) ++k;
      bin_h_[k].push_back(std::abs(h));
      bin_c2[k] += c * c;
    }
    double s11 = 0, s12 = 0, s22 = 0, t1 = 0, t2 = 0;
    for (int k = 0; k < kBins; ++k) {
      if (bin_h_[k].size() < 20) continue;
      const double w = static_cast<double>(bin_h_[k].size());
      const double c2 = bin_c2[k] / w;
      const double var = std::pow(1.4826 * Median(bin_h_[k]), 2);
      s11 += w * c2 * c2, s12 += w * c2, s22 += w, t1 += w * c2 * var, t2 += w * var;
    }
    if (s22 == 0) return;  // too few points to tell: keep the previous model
    const double det = s11 * s22 - s12 * s12;
    const bool solvable = det > 1e-9 * s11 * s22;
    double vr = solvable ? (t1 * s22 - s12 * t2) / det : -1.0;
    double vf = solvable ? (s11 * t2 - s12 * t1) / det : -1.0;
    if (vr < 0) vr = 0.0, vf = t2 / s22;
    if (vf < 0) vf = 0.0, vr = t1 / s11;
    var_range_ = vr;
    var_floor_ = std::max(vf, 1e-12);  // (1 um)^2: keeps weights finite on perfect data
  }

  // Weighted normal equations at the current plane; theta = (z, pitch, roll).
  // With `sandwich`, also B = sum w^2 h^2 J J' for the covariance.
  void Accumulate(bool sandwich) {
    double pitch, roll;
    PitchRollOf(n_, &pitch, &roll);
    const double sp = std::sin(pitch), cp = std::cos(pitch), sr = std::sin(roll), cr = std::cos(roll);
    const Eigen::Vector3d dn_dpitch(-cp, -sp * sr, -sp * cr), dn_droll(0.0, cp * cr, -cp * sr);
    double sa[6] = {}, sb[6] = {}, sg[3] = {};  // upper triangles (00 01 02 11 12 22), g
    sum_h2_ = 0.0;
    for (uint32_t i : inliers_) {
      const double x = kept_[3 * i], y = kept_[3 * i + 1], zz = kept_[3 * i + 2];
      const double inv_r = 1.0 / range_[i];
      const double c = (n_.x() * x + n_.y() * y + n_.z() * zz) * inv_r;
      const double h = c * range_[i] + d_;
      const double scale = -d_ / c * inv_r;  // predicted range / measured range
      const double j1 = (dn_dpitch.x() * x + dn_dpitch.y() * y + dn_dpitch.z() * zz) * scale;
      const double j2 = (dn_droll.y() * y + dn_droll.z() * zz) * scale;
      const double w = 1.0 / (var_range_ * c * c + var_floor_);
      sa[0] += w, sa[1] += w * j1, sa[2] += w * j2, sa[3] += w * j1 * j1, sa[4] += w * j1 * j2,
          sa[5] += w * j2 * j2;
      const double wh = w * h;
      sg[0] += wh, sg[1] += wh * j1, sg[2] += wh * j2;
      sum_h2_ += h * h;
      if (sandwich) {
        const double v = wh * wh;
        sb[0] += v, sb[1] += v * j1, sb[2] += v * j2, sb[3] += v * j1 * j1, sb[4] += v * j1 * j2,
            sb[5] += v * j2 * j2;
      }
    }
    auto fill = [](const double* t, Eigen::Matrix3d* m) {
      *m << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
    };
    fill(sa, &a_);
    fill(sb, &b_);
    g_ << sg[0], sg[1], sg[2];
  }

  const std::vector<float>& kept_;
  const FloorFitOptions& options_;
  const size_t n_kept_;
  std::vector<float> range_;
  Eigen::Vector3d n_;
  double d_;
  double var_range_ = 0.0;  // s_r^2
  double var_floor_;        // s_f^2
  const double min_band2_, sigmas2_;
  std::vector<uint32_t> inliers_;
  std::vector<uint8_t> near_obstacle_;  // from the second pass on
  std::vector<double> bin_h_[kBins];
  Eigen::Matrix3d a_ = Eigen::Matrix3d::Zero(), b_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d g_ = Eigen::Vector3d::Zero();
  double sum_h2_ = 0.0;
};

// Spread of the floor points (`selected` of `xyz`) along the plane's narrower axis.
double FloorExtent(const std::vector<float>& xyz, const std::vector<uint32_t>& selected,
                   const Eigen::Vector3d& n) {
  const double m = static_cast<double>(selected.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (uint32_t i : selected) mean += Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  mean /= m;
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  for (uint32_t i : selected) {
    const Eigen::Vector3d q = Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]) - mean;
    const Eigen::Vector2d w(u.dot(q), v.dot(q));
    spread.noalias() += w * w.transpose();
  }
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(spread / m)
                                     .eigenvalues()(0)));
}

// FitFloor, step 5: why the fit is not the floor, or empty when it is. `below`:
// points well below the plane.
std::string FloorProblem(const FrameFit& fit, const Mount3d& nominal, const FloorFitOptions& options,
                         const Eigen::Vector3d& n, double d, const Eigen::Vector3d& up0, int below) {
  const double tilt = std::acos(std::clamp(n.dot(up0), -1.0, 1.0));
  if (fit.inliers < options.min_floor_points) {
    return "too few floor points (" + std::to_string(fit.inliers) + " < " +
           std::to_string(options.min_floor_points) + ")";
  } else if (tilt > options.max_tilt_rad || std::abs(d - nominal.z) > options.window_m) {
    return "the plane found is " + FixedDecimals(tilt / kDeg, 2) + " deg and " +
           FixedDecimals(d - nominal.z, 3) + " m away from the nominal floor";
  } else if (fit.extent_m < options.min_floor_extent_m) {
    return "the floor is seen only in a narrow strip (spread " + FixedDecimals(fit.extent_m, 2) +
           " m < " + FixedDecimals(options.min_floor_extent_m, 2) + " m)";
  } else if (fit.below_share > options.max_below_share) {
    return "many points lie below the plane found (" + std::to_string(below) +
           " against " + std::to_string(fit.inliers) + " on it): it is not the floor";
  } else if (!fit.cov.allFinite()) {
    return "the floor points do not determine the plane";
  }
  return "";
}

}  // namespace

Eigen::Vector3d FloorNormal(double pitch, double roll) {
  return {-std::sin(pitch), std::cos(pitch) * std::sin(roll), std::cos(pitch) * std::cos(roll)};
}

void PitchRollOf(const Eigen::Vector3d& normal, double* pitch, double* roll) {
  *pitch = std::atan2(-normal.x(), std::hypot(normal.y(), normal.z()));
  *roll = std::atan2(normal.y(), normal.z());
}

FrameFit FitFloor(const float* xyz, size_t count, const Mount3d& nominal,
                  const FloorFitOptions& options, double mount_angle,
                  std::vector<float>* floor_points) {
  FrameFit fit;
  const Eigen::Vector3d up0 = FloorNormal(nominal.pitch, nominal.roll);
  std::vector<float> kept;        // non-body returns
  std::vector<float> candidates;  // of those, near the nominal floor
  SelectReturns(xyz, count, nominal, options, mount_angle, &kept, &candidates, &fit);
  fit.candidates = static_cast<int>(candidates.size() / 3);
  if (fit.candidates < options.min_floor_points) {
    fit.problem = "too few points near the floor (" + std::to_string(fit.candidates) + " < " +
                  std::to_string(options.min_floor_points) + ")";
    return fit;
  }

  const auto sac = ConsensusPlane(candidates, fit.candidates, up0, options);
  if (!sac) {
    fit.problem = "no plane within " + FixedDecimals(options.max_tilt_rad / kDeg, 1) +
                  " deg of the nominal floor among the points near it";
    return fit;
  }

  FloorRefiner refiner(kept, sac->normal, sac->d, options);
  if (!refiner.Refine(up0, &fit)) return fit;
  refiner.Finish(&fit, floor_points);
  const Eigen::Vector3d& n = refiner.normal();
  const double d = refiner.d();
  const double m = static_cast<double>(refiner.inliers().size());
  const double band = refiner.widest_band();
  fit.extent_m = FloorExtent(kept, refiner.inliers(), n);

  // A surface well below the plane: the plane is not the floor.
  const double below_limit = -std::max(options.below_margin_m, band);
  int below = 0;
  for (size_t i = 0; i < kept.size() / 3; ++i)
    if (n.dot(Eigen::Vector3d(kept[3 * i], kept[3 * i + 1], kept[3 * i + 2])) + d < below_limit) ++below;
  fit.below_share = static_cast<double>(below) / m;

  fit.problem = FloorProblem(fit, nominal, options, n, d, up0, below);
  fit.usable = fit.problem.empty();
  return fit;
}

}  // namespace calib
