#include "calib/sim/world.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/world_file.h"

namespace calib {

namespace {

// Grid cells are this size unless the world is so large that the grid would
// exceed kMaxCells. Stepping from cell to cell costs about as much as a
// segment test, and most cells are empty; in the warehouse 2 m cells were
// faster than 1 m and no slower than 3 m.
constexpr double kDefaultCellM = 2.0;
constexpr double kMaxCells = 4e6;

double Cross(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

// Parameter t >= 0 at which o + t*d meets the segment a + u*e (u in [0, 1]),
// kNoHit if it does not; d need not be unit. A ray within 1e-12 rad of the
// segment's direction never hits it: the wall has no thickness, and for a
// ray along the wall's line the rounding in cos/sin would otherwise give a
// spurious hit at t = 0 from anywhere on that line.
double RaySegment(double ox, double oy, double dx, double dy, const WallSegment& s) {
  const double ex = s.b.x() - s.a.x(), ey = s.b.y() - s.a.y();
  const double denom = Cross(dx, dy, ex, ey);
  if (denom * denom <= 1e-24 * (dx * dx + dy * dy) * (ex * ex + ey * ey)) {
    return kNoHit;
  }
  const double wx = s.a.x() - ox, wy = s.a.y() - oy;
  const double t = Cross(wx, wy, ex, ey) / denom;
  const double u = Cross(wx, wy, dx, dy) / denom;
  if (t < 0.0 || u < 0.0 || u > 1.0) return kNoHit;
  return t;
}

}  // namespace

World::World(std::vector<WallSegment> segments) : segments_(std::move(segments)) {
  for (const WallSegment& s : segments_) {
    if (!s.a.allFinite() || !s.b.allFinite() || !std::isfinite(s.height)) {
      throw std::invalid_argument("World: non-finite wall segment");
    }
  }
  BuildIndex();
}

World World::Parse(const std::string& text, const std::string& origin) {
  return World(ParseWorldSegments(text, origin));
}

World World::Load(const std::string& path_or_name) {
  return World(LoadWorldSegments(path_or_name));
}

void World::BuildIndex() {
  cell_start_.clear();
  cell_items_.clear();
  nx_ = ny_ = 0;
  max_height_ = 0.0;
  if (segments_.empty()) return;

  Eigen::Vector2d lo = segments_[0].a, hi = segments_[0].a;
  for (const WallSegment& s : segments_) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b);
    hi = hi.cwiseMax(s.a).cwiseMax(s.b);
    max_height_ = std::max(max_height_, s.height);
  }
  // A margin so that no segment lies on the grid's outer boundary.
  const double margin = 1e-6 * std::max(1.0, (hi - lo).maxCoeff()) + 1e-9;
  lo.array() -= margin;
  hi.array() += margin;
  const Eigen::Vector2d extent = hi - lo;
  cell_ = std::max(kDefaultCellM, std::sqrt(extent.x() * extent.y() / kMaxCells));
  grid_min_ = lo;
  nx_ = std::max(1, static_cast<int>(std::ceil(extent.x() / cell_)));
  ny_ = std::max(1, static_cast<int>(std::ceil(extent.y() / cell_)));

  // Each segment goes into every cell it touches, cells grown by `pad` so that
  // rounding in the traversal (a hit exactly on a cell border) cannot skip it.
  // Segment/box overlap: bounding boxes overlap and the box's corners are not
  // all strictly on one side of the segment's line.
  const double pad = 1e-7 * cell_ + 1e-9;
  std::vector<std::vector<int>> cells(static_cast<size_t>(nx_) * ny_);
  for (int i = 0; i < static_cast<int>(segments_.size()); ++i) {
    const WallSegment& s = segments_[i];
    const Eigen::Vector2d smin = s.a.cwiseMin(s.b), smax = s.a.cwiseMax(s.b);
    auto cell_index = [&](double v, double g, int n) {
      return std::clamp(static_cast<int>(std::floor((v - g) / cell_)), 0, n - 1);
    };
    const int ix0 = cell_index(smin.x() - pad, grid_min_.x(), nx_);
    const int ix1 = cell_index(smax.x() + pad, grid_min_.x(), nx_);
    const int iy0 = cell_index(smin.y() - pad, grid_min_.y(), ny_);
    const int iy1 = cell_index(smax.y() + pad, grid_min_.y(), ny_);
    const Eigen::Vector2d e = s.b - s.a;
    for (int iy = iy0; iy <= iy1; ++iy) {
      for (int ix = ix0; ix <= ix1; ++ix) {
        const double x0 = grid_min_.x() + ix * cell_ - pad, x1 = x0 + cell_ + 2 * pad;
        const double y0 = grid_min_.y() + iy * cell_ - pad, y1 = y0 + cell_ + 2 * pad;
        int positive = 0, negative = 0;
        for (const Eigen::Vector2d& c : {Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0),
                                         Eigen::Vector2d(x0, y1), Eigen::Vector2d(x1, y1)}) {
          const double side = Cross(e.x(), e.y(), c.x() - s.a.x(), c.y() - s.a.y());
          positive += side > 0.0;
          negative += side < 0.0;
        }
        if (positive == 4 || negative == 4) continue;
        cells[static_cast<size_t>(iy) * nx_ + ix].push_back(i);
      }
    }
  }
  cell_start_.reserve(cells.size() + 1);
  cell_start_.push_back(0);
  for (const std::vector<int>& c : cells) {
    cell_items_.insert(cell_items_.end(), c.begin(), c.end());
    cell_start_.push_back(static_cast<int>(cell_items_.size()));
  }
}

double World::Traverse(double ox, double oy, double dx, double dy, double t_max, double oz,
                       double dz) const {
  double best = kNoHit;
  if (nx_ == 0 || (dx == 0.0 && dy == 0.0) || !(t_max >= 0.0)) return best;

  // Clip the ray to the grid's box (slab method) so the walk starts inside it.
  double t0 = 0.0, t1 = t_max;
  const double o[2] = {ox, oy}, d[2] = {dx, dy};
  const double g0[2] = {grid_min_.x(), grid_min_.y()};
  const double g1[2] = {grid_min_.x() + nx_ * cell_, grid_min_.y() + ny_ * cell_};
  for (int k = 0; k < 2; ++k) {
    if (d[k] == 0.0) {
      if (o[k] < g0[k] || o[k] > g1[k]) return best;
      continue;
    }
    double ta = (g0[k] - o[k]) / d[k], tb = (g1[k] - o[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return best;

  // Cell walk (Amanatides & Woo): visit the cells along the ray in order and
  // stop once the nearest hit so far lies within the cells already visited.
  auto cell_of = [&](double v, double g, int n) {
    return std::clamp(static_cast<int>(std::floor((v - g) / cell_)), 0, n - 1);
  };
  int ix = cell_of(ox + t0 * dx, g0[0], nx_);
  int iy = cell_of(oy + t0 * dy, g0[1], ny_);
  const int step_x = dx > 0.0 ? 1 : -1, step_y = dy > 0.0 ? 1 : -1;
  // Parameters at which the ray leaves the current cell through its x and y
  // borders; the grid's padding absorbs the rounding of the increments.
  const double delta_x = dx == 0.0 ? kNoHit : cell_ / std::abs(dx);
  const double delta_y = dy == 0.0 ? kNoHit : cell_ / std::abs(dy);
  double tx = dx == 0.0 ? kNoHit : (g0[0] + (ix + (dx > 0.0 ? 1 : 0)) * cell_ - ox) / dx;
  double ty = dy == 0.0 ? kNoHit : (g0[1] + (iy + (dy > 0.0 ? 1 : 0)) * cell_ - oy) / dy;
  const bool check_height = dz != 0.0 || oz != 0.0;
  for (;;) {
    const size_t c = static_cast<size_t>(iy) * nx_ + ix;
    for (int k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
      const WallSegment& s = segments_[cell_items_[k]];
      const double t = RaySegment(ox, oy, dx, dy, s);
      if (t >= best || t > t_max) continue;
      if (check_height) {
        const double z = oz + t * dz;
        if (z < 0.0 || z > s.height) continue;
      }
      best = t;
    }
    const double t_exit = std::min(tx, ty);
    if (best <= t_exit || t_exit >= t1) break;
    if (tx < ty) {
      ix += step_x;
      if (ix < 0 || ix >= nx_) break;
      tx += delta_x;
    } else {
      iy += step_y;
      if (iy < 0 || iy >= ny_) break;
      ty += delta_y;
    }
  }
  return best;
}

double World::CastRay2d(const Eigen::Vector2d& origin, double angle, double max_range) const {
  const double t =
      Traverse(origin.x(), origin.y(), std::cos(angle), std::sin(angle), max_range, 0.0, 0.0);
  return t <= max_range ? t : kNoHit;
}

double World::CastRay3d(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                        double max_range) const {
  double best = kNoHit;
  if (dir.z() < 0.0 && origin.z() >= 0.0) best = -origin.z() / dir.z();
  // Walls can only be hit before the floor, and below the tallest element.
  double t_max = std::min(max_range, best);
  if (dir.z() > 0.0) t_max = std::min(t_max, (max_height_ - origin.z()) / dir.z());
  if (dir.z() >= 0.0 && origin.z() > max_height_) t_max = -1.0;
  best = std::min(best,
                  Traverse(origin.x(), origin.y(), dir.x(), dir.y(), t_max, origin.z(), dir.z()));
  return best <= max_range ? best : kNoHit;
}

double CastRayBox(const Box3& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                  double max_range) {
  double t_enter = -kNoHit, t_exit = kNoHit;
  for (int k = 0; k < 3; ++k) {
    if (dir[k] == 0.0) {
      // Parallel to this slab: inside it for all t, or never.
      if (origin[k] < box.min[k] || origin[k] > box.max[k]) return kNoHit;
      continue;
    }
    double ta = (box.min[k] - origin[k]) / dir[k], tb = (box.max[k] - origin[k]) / dir[k];
    if (ta > tb) std::swap(ta, tb);
    t_enter = std::max(t_enter, ta);
    t_exit = std::min(t_exit, tb);
  }
  if (t_exit < t_enter || t_exit < 0.0) return kNoHit;
  const double t = t_enter >= 0.0 ? t_enter : t_exit;  // from inside: the far face
  return t <= max_range ? t : kNoHit;
}

}  // namespace calib
