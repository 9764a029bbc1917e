// Reading the options of the ground calibration (config/ground.yaml documents
// every key). Angles are given in degrees here, as people set them; lengths in m.
#include <cmath>
#include <string>

#include "calib/core/errors.h"
#include "calib/ground/ground.h"
#include "core/yaml_checked.h"

namespace calib {
namespace {

using yaml::CheckedMap;
using yaml::Field;
using yaml::ReadNumber;
using yaml::Reporter;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

void Positive(const Reporter& r, const CheckedMap& map, const std::string& key, double scale,
              double* value) {
  if (const auto f = map.Find(key)) *value = yaml::ReadPositive(r, *f) * scale;
}

void NonNegative(const Reporter& r, const CheckedMap& map, const std::string& key, double scale,
                 double* value) {
  if (const auto f = map.Find(key)) {
    const double v = ReadNumber(r, *f);
    if (v < 0) r.Fail(*f, "must be >= 0, got " + yaml::Describe(f->value));
    *value = v * scale;
  }
}

// A whole number >= `min`.
void Count(const Reporter& r, const CheckedMap& map, const std::string& key, int min, int* value) {
  if (const auto f = map.Find(key)) {
    const double v = ReadNumber(r, *f);
    if (v != std::floor(v) || v < min || v > 1e9)
      r.Fail(*f, "must be a whole number >= " + std::to_string(min) + ", got " + yaml::Describe(f->value));
    *value = static_cast<int>(v);
  }
}

void Share(const Reporter& r, const CheckedMap& map, const std::string& key, double* value) {
  if (const auto f = map.Find(key)) {
    const double v = ReadNumber(r, *f);
    if (v < 0 || v > 1) r.Fail(*f, "a share must be in [0, 1], got " + yaml::Describe(f->value));
    *value = v;
  }
}

void ReadFit(const Reporter& r, const Field& field, FloorFitOptions* o) {
  const CheckedMap m(r, field,
                     {"body_margin_m", "min_range_m", "max_range_m", "window_m", "max_tilt_deg", "ransac_threshold_m",
                      "ransac_max_iterations", "ransac_max_points", "band_sigmas", "min_band_m",
                      "refine_iterations", "obstacle_cell_m", "obstacle_min_height_m",
                      "obstacle_max_height_m", "min_floor_points", "min_floor_extent_m",
                      "max_below_share", "below_margin_m"});
  NonNegative(r, m, "body_margin_m", 1.0, &o->body_margin_m);
  NonNegative(r, m, "min_range_m", 1.0, &o->min_range_m);
  NonNegative(r, m, "max_range_m", 1.0, &o->max_range_m);
  Positive(r, m, "window_m", 1.0, &o->window_m);
  Positive(r, m, "max_tilt_deg", kDeg, &o->max_tilt_rad);
  if (o->max_tilt_rad >= 90 * kDeg) r.Fail(*m.Find("max_tilt_deg"), "must be < 90");
  Positive(r, m, "ransac_threshold_m", 1.0, &o->ransac_threshold_m);
  Count(r, m, "ransac_max_iterations", 1, &o->ransac_max_iterations);
  Count(r, m, "ransac_max_points", 3, &o->ransac_max_points);
  Positive(r, m, "band_sigmas", 1.0, &o->band_sigmas);
  Positive(r, m, "min_band_m", 1.0, &o->min_band_m);
  Count(r, m, "refine_iterations", 0, &o->refine_iterations);
  NonNegative(r, m, "obstacle_cell_m", 1.0, &o->obstacle_cell_m);
  NonNegative(r, m, "obstacle_min_height_m", 1.0, &o->obstacle_min_height_m);
  Positive(r, m, "obstacle_max_height_m", 1.0, &o->obstacle_max_height_m);
  Count(r, m, "min_floor_points", 3, &o->min_floor_points);
  NonNegative(r, m, "min_floor_extent_m", 1.0, &o->min_floor_extent_m);
  NonNegative(r, m, "max_below_share", 1.0, &o->max_below_share);
  NonNegative(r, m, "below_margin_m", 1.0, &o->below_margin_m);
}

void ReadFrames(const Reporter& r, const Field& field, FrameOptions* o) {
  const CheckedMap m(r, field, {"max_tilt_deg", "max_height_m", "max_tilted_share", "max_frames"});
  Positive(r, m, "max_tilt_deg", kDeg, &o->max_tilt_rad);
  Positive(r, m, "max_height_m", 1.0, &o->max_height_m);
  Share(r, m, "max_tilted_share", &o->max_tilted_share);
  Count(r, m, "max_frames", 0, &o->max_frames);
}

// {range_<unit>: R, step_<unit>: S} of one grid axis.
void ReadAxis(const Reporter& r, const Field& field, const std::string& unit, double scale,
              double* range, double* step) {
  const CheckedMap m(r, field, {"range_" + unit, "step_" + unit});
  NonNegative(r, m, "range_" + unit, scale, range);
  Positive(r, m, "step_" + unit, scale, step);
}

void ReadGrid(const Reporter& r, const Field& field, GridSearchOptions* o) {
  const CheckedMap m(r, field, {"z", "pitch", "roll", "tolerance_m", "band_m", "max_rounds",
                                "points_per_frame", "max_points"});
  if (const auto f = m.Find("z")) ReadAxis(r, *f, "m", 1.0, &o->z_range_m, &o->z_step_m);
  if (const auto f = m.Find("pitch")) ReadAxis(r, *f, "deg", kDeg, &o->pitch_range_rad, &o->pitch_step_rad);
  if (const auto f = m.Find("roll")) ReadAxis(r, *f, "deg", kDeg, &o->roll_range_rad, &o->roll_step_rad);
  Positive(r, m, "tolerance_m", 1.0, &o->tolerance_m);
  Positive(r, m, "band_m", 1.0, &o->band_m);
  Count(r, m, "max_rounds", 1, &o->max_rounds);
  Count(r, m, "points_per_frame", 0, &o->points_per_frame);
  Count(r, m, "max_points", 0, &o->max_points);
  // A grid of more than ~10^6 candidates per round is a typo, not a wish.
  const double candidates = (2 * o->z_range_m / o->z_step_m + 1) *
                            (2 * o->pitch_range_rad / o->pitch_step_rad + 1) *
                            (2 * o->roll_range_rad / o->roll_step_rad + 1);
  if (candidates > 1e6)
    r.Fail(field, "the grid has " + std::to_string(static_cast<long>(candidates)) +
                      " candidates per round (more than 10^6): widen the steps or narrow the ranges");
}

}  // namespace

GroundOptions ParseGroundOptions(const std::string& yaml_text, const std::string& origin) {
  const Reporter reporter(origin);
  const Field root = yaml::ParseSingleDocument(reporter, yaml_text, "ground options file");
  GroundOptions options;
  try {
    const CheckedMap top(reporter, root, {"fit", "frames", "grid"});
    if (const auto f = top.Find("fit")) ReadFit(reporter, *f, &options.fit);
    if (const auto f = top.Find("frames")) ReadFrames(reporter, *f, &options.frames);
    if (const auto f = top.Find("grid")) ReadGrid(reporter, *f, &options.grid);
  } catch (const YAML::Exception& e) {  // Not expected: every access is checked first.
    reporter.Fail(yaml::LineOf(e.mark), "", std::string("YAML error: ") + e.what());
  }
  return options;
}

GroundOptions LoadGroundOptions(const std::string& path) {
  return ParseGroundOptions(yaml::ReadTextFile(path, "ground options file"), path);
}

}  // namespace calib
