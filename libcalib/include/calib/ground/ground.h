#pragma once
// 3D lidar: height, pitch and roll above the floor (docs/ground.md), from
// plain point arrays. No bus, no files here (ground_session.h reads those).
//
// Convention (spec/robot.md, the simulator): the sensor's orientation in the
// robot frame is R = Rz(yaw) Ry(pitch) Rx(roll) and it stands z above the
// floor, so a floor point p in the sensor frame satisfies
//     n(pitch, roll) . p + z = 0,   n = (-sin pitch, cos pitch sin roll, cos pitch cos roll),
// n being the floor's upward normal seen from the sensor (the third row of R).
// The floor determines z, pitch and roll; x, y and yaw are not observable from it.
//
// One frame (FitFloor):
//  1. points inside the robot's body box (robot file lidar3d.body, mapped with
//     the nominal mount and grown by a margin) are dropped;
//  2. candidates: points within a window of the floor of the nominal mount;
//  3. random sample consensus (PCL) for a plane whose normal is within
//     max_tilt of the nominal one, on a subsample of the candidates: walls and
//     obstacles do not fit it;
//  4. least squares on the inliers: every non-body point within a band of the
//     plane is refitted, a few times, so the nominal mount only has to be
//     roughly right. A point's height noise is modelled as range noise seen at
//     the ray's incidence plus floor roughness, var(h) = s_r^2 (n.u)^2 + s_f^2,
//     both estimated; the band is band_sigmas of that (at least min_band),
//     the weights its inverse. The Jacobian is taken at the predicted floor
//     point of each ray, so that range noise does not bias the angles; from the
//     second pass on, floor points next to anything standing on the floor
//     (walls, obstacles: points well above the plane in the same or a
//     neighbouring cell of a grid on the floor) are left out, as the foot of
//     a wall seen within the band would lift the plane;
//  5. checks: enough floor points, spread over enough floor, and no large
//     surface below the plane (then the plane is a platform, not the floor).
// The covariance of (z, pitch, roll) is the weighted least squares' sandwich
// estimate A^-1 B A^-1, A = sum w_i J_i J_i', B = sum w_i^2 h_i^2 J_i J_i',
// which stays honest when the noise model is only roughly right.
//
// Many frames (GroundCalibrator): a frame whose floor pose differs from the
// median of the frames by more than a limit is "tilted" (the robot stood on a
// slope or a bump); too many tilted frames refuse the answer (a sloped or
// uneven floor), otherwise they are left out. The rest are combined with
// inverse-covariance weights; when they scatter more than their own sigmas
// say (Birge ratio > 1, e.g. a floor that is not perfectly flat), the
// covariance is inflated by that ratio.
//
// The grid search (GridSearch), the method we support for users who ask for
// it and as a cross-check: candidate (z, pitch, roll) on a grid around a
// start, each scored by the mean of min(h^2, band^2) over the floor points
// (those the fit above kept: body, walls and obstacles are already out), h
// being a point's height above the floor under that candidate; the
// best is kept (the first found on ties, in the order pitch, roll, z, each
// ascending). It is accepted when the RMS height of the points within the
// band is within a tolerance; otherwise the ranges are re-set (re-centred on
// the best when it lies on a range's edge, else narrowed to one old step
// around it with five times finer steps) and the search repeated.
//
// A lidar that turns on its mount (Mount3d::rotation): frames are sorted into
// sectors of the rotation range by the angle they were taken at, and each
// sector is calibrated on its own, as a parabola in the angle through its
// frames (the pose changes within a sector when the turret's axis is not
// plumb), evaluated at their mean angle; the table is what the robot uses for
// the angle its lidar stands at.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/core/robot.h"

namespace calib {

inline constexpr double kDegree = 3.14159265358979323846 / 180.0;  // rad

// Pose of the sensor relative to the floor: m, rad, rad.
struct FloorPose {
  double z = 0.0, pitch = 0.0, roll = 0.0;
};

// The floor's upward unit normal in the sensor frame for (pitch, roll), see above.
Eigen::Vector3d FloorNormal(double pitch, double roll);
// (pitch, roll) of a floor normal (any length, pointing up from the floor).
void PitchRollOf(const Eigen::Vector3d& normal, double* pitch, double* roll);

struct FloorFitOptions {
  double body_margin_m = 0.10;      // body box grown by this (nominal mount errors, noise)
  double min_range_m = 0.3;         // nearer returns are ignored (housing, dust)
  double max_range_m = 0.0;         // farther returns are ignored; 0: none (a floor far away
                                    // that is not one plane with the near one: outdoors)
  double window_m = 0.40;           // candidates: |height under the nominal mount| <= this
  double max_tilt_rad = 10 * kDegree;  // floor normal within this of the nominal one
  double ransac_threshold_m = 0.05; // inlier distance of the consensus step
  int ransac_max_iterations = 200;
  int ransac_max_points = 4000;     // candidates subsampled to this for the consensus step
  double band_sigmas = 4.0;         // refinement band: this many robust sigmas...
  double min_band_m = 0.005;         // ...but at least this
  int refine_iterations = 3;
  // The floor within a cell of anything standing on it (a point between
  // obstacle_min_height_m, at least twice the band, and obstacle_max_height_m
  // above it) is left out: the foot of a wall or an obstacle would lift the plane.
  double obstacle_cell_m = 0.25;  // 0: keep it
  double obstacle_min_height_m = 0.05;
  double obstacle_max_height_m = 2.0;
  // A frame is usable when:
  int min_floor_points = 200;           // it has at least this many floor points,
  double min_floor_extent_m = 0.5;      // they spread at least this (std along the narrower floor axis),
  double max_below_share = 0.2;         // and fewer points than this share of them lie
  double below_margin_m = 0.10;         //   more than this below the plane.
};

struct GridSearchOptions {
  double z_range_m = 0.05, z_step_m = 0.01;                       // start +- range
  double pitch_range_rad = 5 * kDegree, pitch_step_rad = 0.5 * kDegree;
  double roll_range_rad = 2 * kDegree, roll_step_rad = 0.2 * kDegree;
  double tolerance_m = 0.01;  // accepted when the floor points' RMS height is within this
  double band_m = 0.10;       // a point is floor (in the score and the RMS) within this height
  int max_rounds = 6;
  // Floor points kept for the search (GroundCalibrator): at most points_per_frame
  // from each frame and max_points in all (each frame's share is halved
  // whenever the total would exceed it); max_points 0 = no grid search.
  int points_per_frame = 4000;
  int max_points = 100000;
};

struct FrameOptions {
  double max_tilt_rad = 0.25 * kDegree;  // frame pitch or roll this far from the median: tilted
  double max_height_m = 0.02;       // frame z this far from the median: tilted
  double max_tilted_share = 0.10;   // more tilted frames than this share: refused
  int max_frames = 0;               // newest frames kept (a live window); 0 = all
};

struct GroundOptions {
  FloorFitOptions fit;
  GridSearchOptions grid;
  FrameOptions frames;
};

// Reads options from YAML (config/ground.yaml documents every key; all are
// optional, unknown keys are errors). Throws InputError naming file, line, key.
GroundOptions LoadGroundOptions(const std::string& path);
GroundOptions ParseGroundOptions(const std::string& yaml_text, const std::string& origin);

// The floor fit of one frame.
struct FrameFit {
  bool usable = false;
  std::string problem;   // why the frame is not usable
  FloorPose pose;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // of (z, pitch, roll)
  int points = 0;        // finite returns beyond min_range
  int body_points = 0;   // of those, dropped as the robot's body
  int candidates = 0;    // within the window of the nominal floor
  int inliers = 0;       // on the fitted floor
  int near_obstacles = 0; // floor points left out at the foot of walls and obstacles
  double rms_m = 0.0;    // RMS distance of the inliers from the plane
  double range_noise_m = 0.0, floor_noise_m = 0.0;  // the fitted noise model (see FitFloor)
  double extent_m = 0.0;
  double below_share = 0.0;
};

// Fits the floor in one frame: `count` points, xyz interleaved (x0, y0, z0,
// x1, ...), sensor frame, m; non-finite points are skipped. `nominal` gives
// the start (z, pitch, roll), the body box and, with `mount_angle` (rad, for a
// lidar turning on its mount), where the body is seen. `floor_points`, if
// given, receives the floor points found (xyz interleaved), e.g. for a grid search.
FrameFit FitFloor(const float* xyz, size_t count, const Mount3d& nominal,
                  const FloorFitOptions& options, double mount_angle = 0.0,
                  std::vector<float>* floor_points = nullptr);

struct GridEstimate {
  FloorPose pose;
  double height_error_m = 0.0;  // RMS height of the points within the band, at `pose`
  bool accepted = false;        // height_error_m <= tolerance within max_rounds
  int rounds = 0;
  int64_t candidates_scored = 0;
  FloorPose step;               // the last round's steps: the resolution of `pose`
  int points = 0;
};

// The grid search described above, over `count` points (xyz interleaved,
// sensor frame), starting around `start`.
GridEstimate GridSearch(const float* xyz, size_t count, const FloorPose& start,
                        const GridSearchOptions& options);

// Frames combined into one estimate.
struct MountEstimate {
  FloorPose value, std;     // std: one standard deviation
  int frames = 0;           // frames combined
  int frames_tilted = 0;    // frames left out: their floor tilted against the others
  double inliers = 0.0;     // share of those frames' points that lie on the floor
  double rms_m = 0.0;       // RMS distance of the floor points from their frame's plane
  double birge_ratio = 1.0; // sqrt(chi^2/dof) of the frames about the estimate (std inflated by it when > 1)
  double angle = 0.0;       // a turning lidar's sector: the mean angle of its frames, where
                            // the estimate holds (0 for a fixed lidar)
};

struct SectorEstimate {
  int index = 0;
  double angle_min = 0.0, angle_max = 0.0;  // rad, [min, max)
  double angle_mean = 0.0;                  // rad, mean angle of the frames used
  MountEstimate estimate;
};

struct GroundResult {
  MountEstimate lidar3d;   // a fixed lidar: all frames; a rotating one: the sector holding angle 0
  int frames_seen = 0;     // frames offered (skipped ones included)
  int frames_unusable = 0; // frames whose floor fit failed its checks, or that were skipped
  std::optional<GridEstimate> grid;     // the grid search, for lidar3d's frames
  std::vector<SectorEstimate> sectors;  // a rotating lidar: every sector, in order
  // For the human report (ground --report): a sample of at most kReportFloorPoints floor points
  // (lidar frame, x y z) of the frames that went into lidar3d, and every kept frame's fit and
  // mount angle, in order.
  static constexpr std::size_t kReportFloorPoints = 3000;
  std::vector<float> floor_points;
  std::vector<FrameFit> frame_fits;
  std::vector<double> frame_angles;
};

class GroundCalibrator {
 public:
  // Throws InputError if a rotating mount's sectors make no sense.
  GroundCalibrator(Mount3d nominal, GroundOptions options);

  // Fits one frame (see FitFloor) and keeps the fit.
  const FrameFit& AddFrame(const float* xyz, size_t count, double mount_angle = 0.0);
  // Counts a frame that could not be used (e.g. its mount angle is unknown).
  void SkipFrame(const std::string& reason);

  // Estimate over the kept frames of `sector` (-1: a fixed lidar's frames).
  // Throws UnobservableError naming why the floor does not determine it.
  MountEstimate Estimate(int sector = -1) const;
  // Every estimate; with_grid adds the grid search. Throws UnobservableError
  // (also when a sector of a rotating lidar has no usable frame).
  GroundResult Result(bool with_grid) const;

  int num_sectors() const { return num_sectors_; }  // 0 for a fixed lidar
  // Sector of a mount angle (rad); -1 outside the rotation range or for a fixed lidar.
  int SectorOf(double angle) const;
  // Sector holding angle 0 (the robot file's mount); -1 for a fixed lidar.
  int HomeSector() const;
  int frames_seen() const { return frames_seen_; }
  const Mount3d& nominal() const { return nominal_; }

 private:
  struct Frame {
    FrameFit fit;
    int sector = -1;
    double angle = 0.0;
    std::vector<float> grid_points;
  };
  // Estimate of `sector` and the frames that went into it.
  MountEstimate Combine(int sector, std::vector<const Frame*>* used) const;
  void ReportSample(int home, GroundResult* result) const;
  Mount3d nominal_;
  GroundOptions options_;
  int num_sectors_ = 0;
  std::deque<Frame> frames_;
  int frames_seen_ = 0;
  int frames_skipped_ = 0;
  std::string last_skip_reason_;
  size_t grid_quota_ = 0;  // grid points kept per frame from now on
};

}  // namespace calib
