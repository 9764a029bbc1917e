#include "calib/calibrate/result_files.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/heldout.h"
#include "calib/core/robot_file_edit.h"
#include "calib/core/statistics.h"
#include "calib/core/units.h"
#include "io/provenance_json.h"

namespace calib {
namespace {

// JSON has no infinity: an undetermined sigma is written as null.
nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json EstimateJson(const Estimate& e, bool with_nominal) {
  nlohmann::json j = {{"value", Number(e.value)}, {"std", Number(e.std)}};
  if (with_nominal) j["nominal"] = Number(e.nominal);
  return j;
}

nlohmann::json OdometryJson(const OdometryError& e) {
  return {{"windows", e.windows},
          {"distance_m", e.distance_m},
          {"rms_translation_m", e.rms_translation_m},
          {"rms_heading_rad", e.rms_heading_rad},
          {"error_per_metre", e.error_per_metre},
          {"per_window_translation_m", [&] {
             std::vector<double> v;
             for (const WindowError& w : e.per_window) v.push_back(w.translation_m);
             return v;
           }()}};
}

}  // namespace

std::string CalibrationResultJson(const CalibrationResult& r) {
  nlohmann::json j;
  j["drive"] = DriveTypeName(r.drive);
  j["params"] = nlohmann::json::object();
  for (const std::string& name : r.param_names) j["params"][name] = EstimateJson(r.params.at(name), true);
  if (r.imu) {
    j["imu"] = {{"gyro_bias", EstimateJson(r.imu->gyro_bias, true)},
                {"gyro_scale", EstimateJson(r.imu->gyro_scale, true)},
                {"gyro_scale_estimated", r.imu->gyro_scale_estimated},
                {"yaw", EstimateJson(r.imu->yaw, true)},
                {"time_offset", EstimateJson(r.imu->time_offset, true)},
                {"gyro_noise", Number(r.imu->gyro_noise)},
                {"wheel_noise", Number(r.imu->wheel_noise)},
                {"distance", Number(r.imu->distance_m)}};
  } else {
    nlohmann::json mount = {{"x", EstimateJson(r.mount_x, true)},
                            {"y", EstimateJson(r.mount_y, true)},
                            {"yaw", EstimateJson(r.mount_yaw, true)}};
    if (r.source == MotionSource::kLidar2d) {
      mount["time_offset"] = r.time_offset ? EstimateJson(*r.time_offset, false)
                                           : nlohmann::json{{"value", 0.0}, {"std", 0.0}};
    }
    j[MotionSourceName(r.source)] = mount;
  }
  j["residual"] = {{"intervals", r.residual.intervals},
                   {"outliers", r.residual.outliers},
                   {"degenerate", r.residual.degenerate},
                   {"invalid", r.residual.invalid},
                   {"rms_x", r.residual.rms_x},
                   {"rms_y", r.residual.rms_y},
                   {"rms_yaw", r.residual.rms_yaw},
                   {"variance_factor", r.residual.variance_factor}};
  j["observability"] = {{"condition", Number(r.condition)}, {"weak", r.weak}};
  nlohmann::json closed_form = nlohmann::json::object();
  for (const auto& [name, value] : r.closed_form) closed_form[name] = Number(value);
  j["closed_form"] = closed_form;
  if (!r.closed_form_note.empty()) j["closed_form_note"] = r.closed_form_note;
  if (r.input_dropped > 0) j["input"] = {{"dropped", r.input_dropped}, {"notes", r.input_notes}};
  if (!r.warnings.empty()) j["warnings"] = r.warnings;
  if (r.heldout) {
    j["heldout"] = {{"intervals", r.heldout->intervals},
                    {"window_m", r.heldout->window_m},
                    {"nominal", OdometryJson(r.heldout->nominal)},
                    {"calibrated", OdometryJson(r.heldout->calibrated)}};
    auto paired = [](const PairedComparison& p) {
      return nlohmann::json{{"windows", p.windows},
                            {"calibrated_better", p.second_better},
                            {"ties", p.ties},
                            {"sign_test_p", p.sign_test_p},
                            {"mean_difference_m", p.mean_difference},
                            {"difference_sem_m", p.difference_sem}};
    };
    j["heldout"]["paired"] = paired(r.heldout->paired);
    j["heldout"]["paired_within_fit_range"] = paired(r.heldout->paired_within_fit_range);
    const MotionCoverage& c = r.heldout->coverage;
    j["heldout"]["motion"] = {{"regressor", c.regressor},
                              {"fit_range", {c.fit_low, c.fit_high}},
                              {"heldout_range", {c.heldout_low, c.heldout_high}},
                              {"heldout_outside_fit", c.heldout_outside}};
    if (const auto& halves = r.heldout->halves) {
      nlohmann::json fit = nlohmann::json::object();
      for (const auto& [name, e] : halves->heldout_fit) fit[name] = {{"value", e.value}, {"std", Number(e.std)}};
      j["heldout"]["halves"] = {{"d2", halves->d2},
                                {"dof", halves->dof},
                                {"p", halves->p},
                                {"largest", halves->largest},
                                {"largest_sigmas", halves->largest_sigmas},
                                {"heldout_fit", fit}};
    } else if (!r.heldout->halves_not_compared.empty()) {
      j["heldout"]["halves_not_compared"] = r.heldout->halves_not_compared;
    }
  }
  AddProvenance(&j);
  return j.dump(2) + "\n";
}

std::string CalibratedRobotYaml(const RobotDescription& robot, const CalibrationResult& r,
                                const std::string& log_path, const std::string& command) {
  std::vector<RobotFileValue> values;
  for (const std::string& name : r.param_names) {
    const Estimate& e = r.params.at(name);
    values.push_back({"params." + name, e.value, e.std});
  }
  if (r.imu) {
    const ImuMount imu = *Calibrated(robot, r).imu;
    values.push_back({"imu.yaw", imu.yaw, r.imu->yaw.std});
    values.push_back({"imu.gyro_bias", imu.gyro_bias, r.imu->gyro_bias.std});
    values.push_back({"imu.gyro_scale", imu.gyro_scale, r.imu->gyro_scale.std});
    values.push_back({"imu.time_offset", imu.time_offset, r.imu->time_offset.std});
    // Noise levels: no sigma of their own; three significant digits.
    values.push_back({"imu.gyro_noise", imu.gyro_noise, 0.0, 3});
    values.push_back({"imu.wheel_noise", imu.wheel_noise, 0.0, 3});
  } else {
    const std::string mount = MotionSourceName(r.source);
    values.push_back({mount + ".x", r.mount_x.value, r.mount_x.std});
    values.push_back({mount + ".y", r.mount_y.value, r.mount_y.std});
    values.push_back({mount + ".yaw", r.mount_yaw.value, r.mount_yaw.std});
  }
  // How much of the recording the values stand on: the rest, held out, only checked them.
  const int fitted = r.residual.intervals, held_out = r.heldout ? r.heldout->intervals : 0;
  std::string fraction = "fitted on all " + std::to_string(fitted) + " usable intervals of the recording";
  if (held_out > 0)
    fraction = "fitted on the first " + std::to_string(fitted) + " of " + std::to_string(fitted + held_out) +
               " usable intervals (" + FixedDecimals(100.0 * fitted / (fitted + held_out), 0) +
               " %); the other " + std::to_string(held_out) + " held out to check them";
  return WriteCalibratedRobotFile(robot.source_file, values, command, log_path, ProvenanceText() + fraction);
}

}  // namespace calib
