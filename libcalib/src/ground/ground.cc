#include "calib/ground/ground.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "calib/core/errors.h"
#include "calib/core/units.h"
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

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double m = values[mid];
  if (values.size() % 2 == 0) m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + mid));
  return m;
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

Eigen::Vector3d PoseOf(const FrameFit& fit) { return Eigen::Vector3d(fit.pose.z, fit.pose.pitch, fit.pose.roll); }

// Why none of `offered` frames shows enough floor: the most common problem
// (`problems`, grouped by their wording up to the numbers) and its first
// instance among `failed`, the unusable frames' problems in order.
std::string NoFloorReason(const std::map<std::string, int>& problems,
                          const std::vector<const std::string*>& failed, int offered) {
  const auto worst = std::max_element(problems.begin(), problems.end(),
                                      [](const auto& a, const auto& b) { return a.second < b.second; });
  std::string example;
  for (const std::string* problem : failed)
    if (problem->compare(0, worst->first.size(), worst->first) == 0) {
      example = *problem;
      break;
    }
  return "none of " + std::to_string(offered) + " frames shows enough floor (" +
         std::to_string(worst->second) + " of them: " + example + ")";
}

struct LevelFrames {
  std::vector<size_t> level;  // indices of the frames level with the others
  double worst_tilt = 0.0, worst_height = 0.0;  // the largest deviations of the others
};

// Frames whose floor tilts against the others: the robot stood on a slope or a bump.
// Deviation from the median, after an unweighted straight-line trend in the angle
// offsets (turning lidar, `trend`).
LevelFrames FindLevelFrames(const std::vector<const FrameFit*>& fits, const std::vector<double>& offsets,
                            bool trend, const FrameOptions& fo) {
  Eigen::Vector3d slope0 = Eigen::Vector3d::Zero();
  if (trend) {
    double sa = 0, saa = 0;
    Eigen::Vector3d sx = Eigen::Vector3d::Zero(), sax = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < fits.size(); ++k) {
      const double da = offsets[k];
      sa += da, saa += da * da, sx += PoseOf(*fits[k]), sax += da * PoseOf(*fits[k]);
    }
    const double nf = static_cast<double>(fits.size()), det = nf * saa - sa * sa;
    if (det > 1e-12) slope0 = (nf * sax - sa * sx) / det;
  }
  std::vector<double> zs, pitches, rolls;
  for (size_t k = 0; k < fits.size(); ++k) {
    const Eigen::Vector3d p = PoseOf(*fits[k]) - offsets[k] * slope0;
    zs.push_back(p[0]), pitches.push_back(p[1]), rolls.push_back(p[2]);
  }
  const double mz = Median(zs), mp = Median(pitches), mr = Median(rolls);
  LevelFrames out;
  for (size_t k = 0; k < fits.size(); ++k) {
    const double tilt = std::max(std::abs(pitches[k] - mp), std::abs(rolls[k] - mr));
    const double height = std::abs(zs[k] - mz);
    if (tilt > fo.max_tilt_rad || height > fo.max_height_m) {
      out.worst_tilt = std::max(out.worst_tilt, tilt);
      out.worst_height = std::max(out.worst_height, height);
    } else {
      out.level.push_back(k);
    }
  }
  return out;
}

// Inverse-covariance weighted least squares of the frames' poses on
// [I, da I, da^2 I] (a constant; for a turning lidar, `trend`, also the trend
// and its curvature, so the constant is the pose at the mean angle, da being
// the frames' `offsets` from it); the covariance is inflated by the scatter
// about it (Birge ratio) when > 1.
MountEstimate WeightedMount(const std::vector<const FrameFit*>& fits, const std::vector<double>& offsets,
                            bool trend) {
  const int order = !trend ? 0 : fits.size() >= 4 ? 2 : fits.size() >= 3 ? 1 : 0;
  const int unknowns = 3 * (order + 1);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(unknowns, unknowns);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
  std::vector<Eigen::Matrix3d> weights;
  weights.reserve(fits.size());
  long points = 0, inliers = 0;
  double sum_r2 = 0.0;
  for (size_t k = 0; k < fits.size(); ++k) {
    const FrameFit& f = *fits[k];
    const Eigen::Matrix3d w = f.cov.inverse();
    weights.push_back(w);
    const double da = offsets[k];
    Eigen::MatrixXd j(3, unknowns);
    for (int o = 0; o <= order; ++o) j.middleCols<3>(3 * o) = std::pow(da, o) * Eigen::Matrix3d::Identity();
    a += j.transpose() * w * j;
    rhs += j.transpose() * w * PoseOf(f);
    points += f.points;
    inliers += f.inliers;
    sum_r2 += f.rms_m * f.rms_m * f.inliers;
  }
  const Eigen::MatrixXd a_inv = a.inverse();
  const Eigen::VectorXd x = a_inv * rhs;
  double chi2 = 0.0;
  for (size_t k = 0; k < fits.size(); ++k) {
    Eigen::Vector3d e = PoseOf(*fits[k]);
    for (int o = 0; o <= order; ++o) e -= std::pow(offsets[k], o) * x.segment<3>(3 * o);
    chi2 += e.dot(weights[k] * e);
  }
  MountEstimate est;
  const int dof = 3 * static_cast<int>(fits.size()) - unknowns;
  est.birge_ratio = dof > 0 ? std::sqrt(chi2 / dof) : 1.0;
  const Eigen::Matrix3d cov = a_inv.topLeftCorner<3, 3>() * std::max(1.0, est.birge_ratio * est.birge_ratio);
  est.value = {x[0], x[1], x[2]};
  est.std = {std::sqrt(cov(0, 0)), std::sqrt(cov(1, 1)), std::sqrt(cov(2, 2))};
  est.frames = static_cast<int>(fits.size());
  est.inliers = points > 0 ? static_cast<double>(inliers) / static_cast<double>(points) : 0.0;
  est.rms_m = inliers > 0 ? std::sqrt(sum_r2 / static_cast<double>(inliers)) : 0.0;
  return est;
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

GridEstimate GridSearch(const float* xyz, size_t count, const FloorPose& start,
                        const GridSearchOptions& options) {
  if (!(options.z_step_m > 0 && options.pitch_step_rad > 0 && options.roll_step_rad > 0) ||
      !(options.z_range_m >= 0 && options.pitch_range_rad >= 0 && options.roll_range_rad >= 0) ||
      !(options.band_m > 0) || options.max_rounds < 1)
    throw std::invalid_argument("GridSearch: steps and band must be > 0, ranges >= 0, rounds >= 1");
  GridEstimate out;
  out.points = static_cast<int>(count);
  if (count == 0) return out;
  const float tau2 = static_cast<float>(options.band_m * options.band_m);
  FloorPose center = start;
  FloorPose half{options.z_range_m, options.pitch_range_rad, options.roll_range_rad};
  FloorPose step{options.z_step_m, options.pitch_step_rad, options.roll_step_rad};
  std::vector<float> s(count);
  auto steps_of = [](double h, double st) { return static_cast<int>(std::llround(2.0 * h / st)) + 1; };
  for (int round = 1; round <= options.max_rounds; ++round) {
    const int nz = steps_of(half.z, step.z), np = steps_of(half.pitch, step.pitch),
              nr = steps_of(half.roll, step.roll);
    double best_score = std::numeric_limits<double>::infinity();
    int best_p = 0, best_r = 0, best_z = 0;
    for (int ip = 0; ip < np; ++ip) {
      const double pitch = center.pitch - half.pitch + ip * step.pitch;
      for (int ir = 0; ir < nr; ++ir) {
        const double roll = center.roll - half.roll + ir * step.roll;
        const Eigen::Vector3f n = FloorNormal(pitch, roll).cast<float>();
        for (size_t i = 0; i < count; ++i)
          s[i] = n.x() * xyz[3 * i] + n.y() * xyz[3 * i + 1] + n.z() * xyz[3 * i + 2];
        for (int iz = 0; iz < nz; ++iz) {
          const float z = static_cast<float>(center.z - half.z + iz * step.z);
          double acc[4] = {0, 0, 0, 0};
          size_t i = 0;
          for (; i + 4 <= count; i += 4) {
            for (int k = 0; k < 4; ++k) {
              const float h = s[i + k] + z;
              acc[k] += std::min(h * h, tau2);
            }
          }
          for (; i < count; ++i) {
            const float h = s[i] + z;
            acc[0] += std::min(h * h, tau2);
          }
          const double score = (acc[0] + acc[1] + acc[2] + acc[3]) / static_cast<double>(count);
          if (score < best_score) {  // strict: the first one found wins ties
            best_score = score;
            best_p = ip, best_r = ir, best_z = iz;
          }
        }
      }
    }
    out.candidates_scored += static_cast<int64_t>(np) * nr * nz;
    out.rounds = round;
    out.step = step;
    const FloorPose best{center.z - half.z + best_z * step.z,
                         center.pitch - half.pitch + best_p * step.pitch,
                         center.roll - half.roll + best_r * step.roll};
    out.pose = best;
    // Height error: RMS height of the floor points (within the band) at the best candidate.
    const Eigen::Vector3d n = FloorNormal(best.pitch, best.roll);
    double sum = 0.0;
    int within = 0;
    for (size_t i = 0; i < count; ++i) {
      const double h = n.x() * xyz[3 * i] + n.y() * xyz[3 * i + 1] + n.z() * xyz[3 * i + 2] + best.z;
      if (h * h < tau2) sum += h * h, ++within;
    }
    out.height_error_m = within ? std::sqrt(sum / within) : options.band_m;
    auto on_edge = [](int index, int n_steps) { return n_steps > 1 && (index == 0 || index == n_steps - 1); };
    center = best;
    if (on_edge(best_z, nz) || on_edge(best_p, np) || on_edge(best_r, nr)) continue;  // re-centre
    if (out.height_error_m <= options.tolerance_m) {
      out.accepted = true;
      break;
    }
    half = step;
    step = FloorPose{step.z / 5.0, step.pitch / 5.0, step.roll / 5.0};
  }
  return out;
}

GroundCalibrator::GroundCalibrator(Mount3d nominal, GroundOptions options)
    : nominal_(std::move(nominal)), options_(std::move(options)) {
  if (nominal_.rotation) {
    const MountRotation& r = *nominal_.rotation;
    if (!(r.sector_width > 0) || !(r.max > r.min))
      throw InputError("robot file", "lidar3d.rotation", "needs min < max and sector_width > 0");
    num_sectors_ = static_cast<int>(std::ceil((r.max - r.min) / r.sector_width - 1e-9));
  }
  grid_quota_ = options_.grid.points_per_frame > 0 ? static_cast<size_t>(options_.grid.points_per_frame)
                                                    : std::numeric_limits<size_t>::max();
}

int GroundCalibrator::SectorOf(double angle) const {
  if (!nominal_.rotation || !std::isfinite(angle)) return -1;
  const MountRotation& r = *nominal_.rotation;
  double a = angle;
  if (r.max - r.min >= 2 * kPi - 1e-9) {
    a = r.min + std::fmod(a - r.min, 2 * kPi);
    if (a < r.min) a += 2 * kPi;
  } else if (a < r.min || a > r.max) {
    return -1;
  }
  const int index = static_cast<int>(std::floor((a - r.min) / r.sector_width));
  return std::clamp(index, 0, num_sectors_ - 1);
}

int GroundCalibrator::HomeSector() const {
  if (!nominal_.rotation) return -1;
  const int home = SectorOf(0.0);
  if (home >= 0) return home;
  return std::abs(nominal_.rotation->min) < std::abs(nominal_.rotation->max) ? 0 : num_sectors_ - 1;
}

const FrameFit& GroundCalibrator::AddFrame(const float* xyz, size_t count, double mount_angle) {
  ++frames_seen_;
  Frame frame;
  frame.sector = SectorOf(mount_angle);
  frame.angle = mount_angle;
  const bool for_grid = options_.grid.max_points > 0 && frame.sector == HomeSector();
  std::vector<float> floor_points;
  if (nominal_.rotation && frame.sector < 0) {
    frame.fit.problem = "mount angle outside the rotation range";
  } else {
    frame.fit = FitFloor(xyz, count, nominal_, options_.fit, mount_angle,
                         for_grid ? &floor_points : nullptr);
  }
  if (for_grid && frame.fit.usable) {
    // An even share of each frame; every frame's share is halved when the total grows too big.
    auto thin = [](std::vector<float>* points, size_t keep) {
      const size_t n = points->size() / 3;
      if (n <= keep) return;
      const size_t stride = (n + keep - 1) / std::max<size_t>(keep, 1);
      std::vector<float> out;
      out.reserve(3 * (n / stride + 1));
      for (size_t i = 0; i < n; i += stride)
        out.insert(out.end(), points->begin() + 3 * i, points->begin() + 3 * i + 3);
      points->swap(out);
    };
    thin(&floor_points, grid_quota_);
    frame.grid_points = std::move(floor_points);
    size_t total = frame.grid_points.size() / 3;
    for (const Frame& f : frames_) total += f.grid_points.size() / 3;
    while (total > static_cast<size_t>(options_.grid.max_points) && grid_quota_ > 1) {
      size_t largest = frame.grid_points.size() / 3;
      for (const Frame& f : frames_) largest = std::max(largest, f.grid_points.size() / 3);
      grid_quota_ = largest / 2;
      total = 0;
      for (Frame& f : frames_) {
        thin(&f.grid_points, grid_quota_);
        total += f.grid_points.size() / 3;
      }
      thin(&frame.grid_points, grid_quota_);
      total += frame.grid_points.size() / 3;
    }
  }
  frames_.push_back(std::move(frame));
  if (options_.frames.max_frames > 0 && frames_.size() > static_cast<size_t>(options_.frames.max_frames))
    frames_.pop_front();
  return frames_.back().fit;
}

void GroundCalibrator::SkipFrame(const std::string& reason) {
  ++frames_seen_;
  ++frames_skipped_;
  last_skip_reason_ = reason;
}

MountEstimate GroundCalibrator::Estimate(int sector) const { return Combine(sector, nullptr); }

MountEstimate GroundCalibrator::Combine(int sector, std::vector<const Frame*>* used) const {
  std::vector<const Frame*> usable;
  std::map<std::string, int> problems;
  std::vector<const std::string*> failed;
  int offered = 0;
  for (const Frame& f : frames_) {
    if (f.sector != sector) continue;
    ++offered;
    if (f.fit.usable) {
      usable.push_back(&f);
    } else {
      // Group problems by their wording up to the numbers, for the message.
      ++problems[f.fit.problem.substr(0, f.fit.problem.find(" ("))];
      failed.push_back(&f.fit.problem);
    }
  }
  const std::string where =
      sector < 0 ? std::string() : " in sector " + std::to_string(sector);
  if (usable.empty()) {
    std::string why;
    if (offered == 0) {
      why = frames_skipped_ > 0 && sector < 0 ? "no frame could be used (" + last_skip_reason_ + ")"
                                              : "no frames";
    } else {
      why = NoFloorReason(problems, failed, offered);
    }
    throw UnobservableError(
        "3D lidar height, pitch and roll" + where + ": the floor is not visible enough: " + why,
        "record where the lidar sees open, level floor around the robot (not among obstacles or "
        "against walls), and check lidar3d.z, pitch, roll and body in the robot file");
  }

  // A turning lidar's pose changes with its angle within a sector: there each
  // frame is compared with a straight line in the angle about the frames' mean
  // angle, and the estimate is a parabola's value at that angle.
  const bool trend = sector >= 0 && usable.size() >= 3;
  double sum_sin = 0.0, sum_cos = 0.0;
  for (const Frame* f : usable) sum_sin += std::sin(f->angle), sum_cos += std::cos(f->angle);
  const double angle_mean = sector >= 0 ? std::atan2(sum_sin, sum_cos) : 0.0;
  std::vector<const FrameFit*> fits;
  std::vector<double> offsets;
  for (const Frame* f : usable) {
    fits.push_back(&f->fit);
    offsets.push_back(trend ? std::remainder(f->angle - angle_mean, 2 * kPi) : 0.0);
  }

  const FrameOptions& fo = options_.frames;
  const LevelFrames split = FindLevelFrames(fits, offsets, trend, fo);
  std::vector<const Frame*> level;
  std::vector<const FrameFit*> level_fits;
  std::vector<double> level_offsets;
  for (size_t k : split.level) {
    level.push_back(usable[k]);
    level_fits.push_back(fits[k]);
    level_offsets.push_back(offsets[k]);
  }
  const int tilted = static_cast<int>(usable.size() - level.size());
  if (level.empty() || tilted > fo.max_tilted_share * static_cast<double>(usable.size())) {
    throw UnobservableError(
        "3D lidar height, pitch and roll" + where + ": the floor is not one level plane across frames: " +
            std::to_string(tilted) + " of " + std::to_string(usable.size()) +
            " frames tilt against the others by up to " + FixedDecimals(split.worst_tilt / kDeg, 2) + " deg / " +
            FixedDecimals(split.worst_height, 3) + " m (limits " + FixedDecimals(fo.max_tilt_rad / kDeg, 2) + " deg, " +
            FixedDecimals(fo.max_height_m, 3) + " m)",
        "the robot stood on a slope, ramp or uneven floor in part of the recording: record on a "
        "level floor");
  }

  MountEstimate est = WeightedMount(level_fits, level_offsets, trend);
  est.angle = angle_mean;
  est.frames_tilted = tilted;
  if (used) *used = level;
  return est;
}

void GroundCalibrator::ReportSample(int home, GroundResult* result) const {
  for (const Frame& f : frames_) {
    result->frame_fits.push_back(f.fit);
    result->frame_angles.push_back(f.angle);
  }
  std::vector<const Frame*> used;
  Combine(home, &used);
  size_t total = 0;
  for (const Frame* f : used) total += f->grid_points.size() / 3;
  const size_t stride = std::max<size_t>(1, (total + GroundResult::kReportFloorPoints - 1) / GroundResult::kReportFloorPoints);
  size_t k = 0;
  for (const Frame* f : used)
    for (size_t i = 0; i < f->grid_points.size() / 3; ++i, ++k)
      if (k % stride == 0)
        result->floor_points.insert(result->floor_points.end(), f->grid_points.begin() + 3 * i, f->grid_points.begin() + 3 * i + 3);
}

GroundResult GroundCalibrator::Result(bool with_grid) const {
  GroundResult result;
  result.frames_seen = frames_seen_;
  result.frames_unusable = frames_skipped_;
  for (const Frame& f : frames_)
    if (!f.fit.usable) ++result.frames_unusable;
  const int home = HomeSector();
  if (nominal_.rotation) {
    std::vector<std::string> missing;
    std::string first_problem;
    for (int s = 0; s < num_sectors_; ++s) {
      SectorEstimate sector;
      sector.index = s;
      sector.angle_min = nominal_.rotation->min + s * nominal_.rotation->sector_width;
      sector.angle_max = std::min(nominal_.rotation->max, sector.angle_min + nominal_.rotation->sector_width);
      try {
        sector.estimate = Estimate(s);
      } catch (const UnobservableError& e) {
        missing.push_back(std::to_string(s) + " (" + FixedDecimals(sector.angle_min / kDeg, 1) + ".." +
                          FixedDecimals(sector.angle_max / kDeg, 1) + " deg)");
        if (first_problem.empty()) first_problem = e.what();
        continue;
      }
      sector.angle_mean = sector.estimate.angle;
      result.sectors.push_back(sector);
    }
    if (!missing.empty()) {
      std::string list;
      for (size_t i = 0; i < missing.size() && i < 8; ++i) list += (i ? ", " : "") + missing[i];
      if (missing.size() > 8) list += ", ... (" + std::to_string(missing.size()) + " in all)";
      throw UnobservableError(
          "3D lidar height, pitch and roll per sector: no estimate for sector " + list +
              " of " + std::to_string(num_sectors_) + "; first problem: " + first_problem,
          "turn the lidar through every sector of its rotation range while it sees open, level "
          "floor");
    }
    for (const SectorEstimate& s : result.sectors)
      if (s.index == home) result.lidar3d = s.estimate;
  } else {
    result.lidar3d = Estimate(-1);
  }
  ReportSample(home, &result);
  if (with_grid && options_.grid.max_points > 0) {
    // The grid scores the floor points of the frames that went into lidar3d.
    std::vector<const Frame*> used;
    Combine(home, &used);
    std::vector<float> points;
    for (const Frame* f : used) points.insert(points.end(), f->grid_points.begin(), f->grid_points.end());
    if (!points.empty()) {
      const FloorPose start{nominal_.z, nominal_.pitch, nominal_.roll};
      result.grid = GridSearch(points.data(), points.size() / 3, start, options_.grid);
    }
  }
  return result;
}

}  // namespace calib
