#pragma once
// YAML readers shared by the bridge config files (canopen.h, sick_cola.h), on
// top of yaml_checked.h. Internal to libcalib.

#include <cstdint>

#include "calib/devices/device_clock.h"
#include "core/yaml_checked.h"

namespace calib::bridge_internal {

// An integer, decimal or 0x hex, within [min, max].
int64_t ReadInteger(const yaml::Reporter& reporter, const yaml::Field& field, int64_t min, int64_t max);
bool ReadBool(const yaml::Reporter& reporter, const yaml::Field& field);
// The optional `clock:` map into DeviceClockOptions (keys window_s, min_span_s,
// max_drift_ppm, max_gap_s).
void ReadClockOptions(const yaml::Reporter& reporter, const yaml::CheckedMap& top, DeviceClockOptions* options);

}  // namespace calib::bridge_internal
