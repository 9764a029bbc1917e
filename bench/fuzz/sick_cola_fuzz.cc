// The SICK CoLa-A parser (calib/devices/sick_cola.h): a TCP byte stream split into telegrams,
// each parsed and turned into a scan message as agvcal-lidarbridge does.
#include <algorithm>
#include <cstdint>
#include <string>

#include "calib/devices/sick_cola.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::SickBridgeConfig config =
      calib::LoadSickBridgeConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/bridges/sick_lms1xx.yaml");
  calib::StxEtxFramer framer(1 << 16);
  calib::SickScanDecoder decoder(config);
  // In pieces, as TCP delivers them.
  for (size_t at = 0; at < size; at += 700) framer.Append(reinterpret_cast<const char*>(data) + at, std::min<size_t>(700, size - at));
  std::string telegram;
  int64_t number = 0, arrival = 1700000000000000;
  while (framer.Next(&telegram)) {
    ++number;
    arrival += 40000;
    if (!calib::IsLmdScandata(telegram)) continue;
    fuzz::Expect([&] {
      const calib::SickScan scan = calib::ParseLmdScandata(telegram, "fuzz", number);
      decoder.Decode(scan, arrival, "fuzz", number);
    });
  }
  return 0;
}
