#include "calib/live/estimate_messages.h"

#include <cmath>

namespace calib {

agvcal::calib_estimate_t ToMessage(const CalibrationResult& result, int64_t utime,
                                   const std::string& status) {
  agvcal::calib_estimate_t m{};
  m.utime = utime;
  m.drive = DriveTypeName(result.drive);
  m.status = status;
  auto add = [&](const std::string& name, const Estimate& e) {
    m.names.push_back(name);
    m.values.push_back(e.value);
    m.stds.push_back(std::isfinite(e.std) ? e.std : -1.0);
    m.nominal.push_back(e.nominal);
  };
  for (const std::string& name : result.param_names) add(name, result.params.at(name));
  const std::string mount = MotionSourceName(result.source);
  add(mount + ".x", result.mount_x);
  add(mount + ".y", result.mount_y);
  add(mount + ".yaw", result.mount_yaw);
  if (result.time_offset) add("time_offset", *result.time_offset);
  m.num_values = static_cast<int32_t>(m.names.size());
  m.intervals = result.residual.intervals;
  m.outliers = result.residual.outliers;
  m.condition = std::isfinite(result.condition) ? result.condition : -1.0;
  m.weak = result.weak;
  m.num_weak = static_cast<int32_t>(m.weak.size());
  return m;
}

agvcal::calib_residual_t ToMessage(const IntervalResidual& r) {
  agvcal::calib_residual_t m{};
  m.utime_start = r.utime_start;
  m.utime_end = r.utime_end;
  for (int i = 0; i < 3; ++i) m.error[i] = r.error[i];
  m.chi2 = r.chi2;
  m.outlier = r.outlier;
  return m;
}

}  // namespace calib
