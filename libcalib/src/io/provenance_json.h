#pragma once
// The run's provenance (calib/io/provenance.h) as the `provenance` object of a result file.

#include <nlohmann/json.hpp>

#include "calib/io/provenance.h"

namespace calib {

// Sets (*j)["provenance"] when the run's provenance is set.
inline void AddProvenance(nlohmann::json* j) {
  const Provenance* p = RunProvenance();
  if (!p) return;
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [key, value] : ProvenanceFields(*p)) out[key] = value;
  (*j)["provenance"] = out;
}

}  // namespace calib
