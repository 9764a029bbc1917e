// The simulation config (calib/sim/simulator.h ParseSimConfig); world files resolve against
// the checkout's config/sims, as for the bundled configs.
#include <cstdint>
#include <string>

#include "calib/sim/simulator.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::Expect([&] { calib::ParseSimConfig(text, "fuzz.yaml", std::string(AGVCAL_SOURCE_DIR) + "/config/sims"); });
  return 0;
}
