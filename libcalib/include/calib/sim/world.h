#pragma once
// The simulated world: a flat floor at z = 0 with vertical walls, blocks and
// pillars, read from a world file, and ray casting against it for the
// simulated 2D and 3D lidars.
//
// World file (text, one element per line, '#' starts a comment; units m):
//   height H                       default height of the elements that follow (initially 3.0)
//   wall X1 Y1 X2 Y2 [H]           thin wall from (X1,Y1) to (X2,Y2)
//   box XMIN YMIN XMAX YMAX [H]    solid axis-aligned block (rack, pallet, machine)
//   pillar CX CY R [H]             round column (a 16-sided prism)
// Bundled worlds live in config/worlds/NAME.world; "warehouse" (structured,
// for scan matching) and "corridor" (long and featureless, a degenerate case).

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace calib {

// A vertical face of the world: the segment a-b extruded from z = 0 to `height`.
struct WallSegment {
  Eigen::Vector2d a, b;
  double height = 3.0;
};

// Axis-aligned box in some frame (used for the robot's own body).
struct Box3 {
  Eigen::Vector3d min, max;
};

constexpr double kNoHit = std::numeric_limits<double>::infinity();

class World {
 public:
  // An empty world: only the floor.
  World() = default;
  // Throws std::invalid_argument for a non-finite coordinate or height.
  explicit World(std::vector<WallSegment> segments);

  // Reads a world file; a name without '/' and without extension is looked
  // up in the bundled config/worlds. Throws InputError naming file and line
  // (an unknown bundled name lists the bundled ones).
  static World Load(const std::string& path_or_name);
  // Parses world-file text; `origin` names it in errors. A text without any
  // wall, box or pillar is an error (most likely the wrong file).
  static World Parse(const std::string& text, const std::string& origin);

  const std::vector<WallSegment>& segments() const { return segments_; }

  // Distance from `origin` along the horizontal direction `angle` (world
  // frame, rad) to the first wall face, kNoHit if none within max_range.
  // The 2D lidar's scan plane is taken to be below every element's height
  // (low pallets are seen too). Faces have no thickness: a ray grazing a
  // face (within 1e-12 rad of its direction) passes it.
  double CastRay2d(const Eigen::Vector2d& origin, double angle, double max_range) const;

  // Distance along the unit direction `dir` from `origin` (world frame) to the
  // first hit on the floor (z = 0) or a wall face below its height, kNoHit if
  // none within max_range. Element tops are not modelled (rays from above a
  // block's top pass over it until they hit its side or the floor).
  double CastRay3d(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                   double max_range) const;

 private:
  void BuildIndex();
  // Nearest t in [0, t_max] at which o + t*d (horizontal part of the ray)
  // meets a wall face whose height range contains oz + t*dz; kNoHit if none.
  // Walks the grid cells along the ray and stops at the first cell that
  // holds a hit nearer than the cell's exit, so cost grows with the distance
  // to the hit, not with the number of segments.
  double Traverse(double ox, double oy, double dx, double dy, double t_max, double oz,
                  double dz) const;

  std::vector<WallSegment> segments_;
  double max_height_ = 0.0;  // rays climbing above it can hit nothing but the floor
  // Uniform grid over the segments' bounding box: cell (ix, iy) covers
  // grid_min_ + [ix, ix+1) x [iy, iy+1) * cell_, and holds the segments
  // cell_items_[cell_start_[iy*nx_+ix] .. cell_start_[iy*nx_+ix+1]).
  double cell_ = 1.0;
  Eigen::Vector2d grid_min_ = Eigen::Vector2d::Zero();
  int nx_ = 0, ny_ = 0;
  std::vector<int> cell_start_;
  std::vector<int> cell_items_;
};

// Distance along the unit direction `dir` from `origin` to the box, kNoHit if
// the ray misses it within max_range (origin and dir in the box's frame). A
// ray starting inside the box hits its far face.
double CastRayBox(const Box3& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                  double max_range);

}  // namespace calib
