// Fixtures and checks of the bridges' end-to-end tests:
//   bridge_check candump CONFIG TRUTH.log OUT.candump JITTER_MS
//       the CANopen frames of TRUTH.log's WHEELS (canopen.h's EmulateCanBus), as candump -l
//   bridge_check wheels TRUTH.log LIVE.log WARMUP_S TOL_US
//       LIVE's WHEELS equal TRUTH's (positions, steer exactly; velocity within its quantum;
//       stamps within TOL_US after WARMUP_S)
//   bridge_check scans TRUTH.log LIVE.log WARMUP_S TOL_US
//       LIVE's SCAN equal TRUTH's (geometry; ranges within 0.5 mm); stamps within TOL_US of
//       TRUTH's plus one constant after WARMUP_S, while the arrivals (logger stamps) spread more
// Prints one line per check and exits 1 if any fails.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "agvcal/laser_scan_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/devices/canopen.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"

namespace {

int failures = 0;
void Check(bool ok, const std::string& what) {
  std::cout << (ok ? "PASS " : "FAIL ") << what << "\n";
  if (!ok) ++failures;
}

template <typename Message>
std::vector<std::pair<int64_t, Message>> Read(const std::string& path, const std::string& channel) {
  std::vector<std::pair<int64_t, Message>> out;
  calib::LogReader reader(path);
  calib::LogEvent e;
  while (reader.Next(&e)) {
    if (e.channel != channel) continue;
    Message m;
    if (calib::Decode(e.data.data(), int(e.data.size()), &m)) out.push_back({e.timestamp, m});
  }
  return out;
}

int Candump(char** argv) {
  const calib::CanBridgeConfig config = calib::LoadCanBridgeConfig(argv[2]);
  std::vector<agvcal::wheel_state_t> states;
  for (auto& [t, m] : Read<agvcal::wheel_state_t>(argv[3], "WHEELS")) states.push_back(m);
  std::ofstream out(argv[4]);
  const auto frames = calib::EmulateCanBus(config, states, calib::CanEmulation{std::stod(argv[5]) * 1e-3, 0.0002, 1});
  for (const calib::CanFrame& f : frames) out << calib::FormatCandumpLine(f, "can0") << "\n";
  std::cout << "wrote " << frames.size() << " frames for " << states.size() << " wheel states\n";
  return out ? 0 : 1;
}

int Wheels(char** argv) {
  const auto truth = Read<agvcal::wheel_state_t>(argv[2], "WHEELS");
  const auto live = Read<agvcal::wheel_state_t>(argv[3], "WHEELS");
  const double warmup_us = std::stod(argv[4]) * 1e6, tol_us = std::stod(argv[5]);
  Check(live.size() == truth.size() && !truth.empty(),
        "wheel states: " + std::to_string(live.size()) + " of " + std::to_string(truth.size()));
  if (live.size() != truth.size() || truth.empty()) return 1;
  double position = 0, steer = 0, velocity = 0, stamp = 0;
  bool names = true;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const auto& a = truth[i].second;
    const auto& b = live[i].second;
    names = names && a.name == b.name;
    if (!names) break;
    for (int w = 0; w < a.num_wheels; ++w) {
      position = std::max(position, std::abs(a.position[w] - b.position[w]));
      steer = std::max(steer, std::abs(a.steer[w] - b.steer[w]));
      velocity = std::max(velocity, std::abs(a.velocity[w] - b.velocity[w]));
    }
    if (double(a.utime - truth[0].second.utime) >= warmup_us)
      stamp = std::max(stamp, std::abs(double(b.utime - a.utime)));
  }
  Check(names, "wheel names as in the config");
  Check(position < 1e-9, "positions equal (max difference " + std::to_string(position) + " rad)");
  Check(steer < 1e-9, "steer equal (max difference " + std::to_string(steer) + " rad)");
  Check(velocity <= M_PI / 4096 + 1e-12, "velocity within one increment/s (max " + std::to_string(velocity) + " rad/s)");
  Check(stamp <= tol_us, "stamps within " + std::to_string(tol_us) + " us after warm-up (max " +
                             std::to_string(stamp) + " us)");
  return failures ? 1 : 0;
}

double HalfSpread(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return 0.5 * (*hi - *lo);
}

int Scans(char** argv) {
  const auto truth = Read<agvcal::laser_scan_t>(argv[2], "SCAN");
  const auto live = Read<agvcal::laser_scan_t>(argv[3], "SCAN");
  const double warmup_us = std::stod(argv[4]) * 1e6, tol_us = std::stod(argv[5]);
  Check(live.size() == truth.size() && !truth.empty(),
        "scans: " + std::to_string(live.size()) + " of " + std::to_string(truth.size()));
  if (live.size() != truth.size() || truth.empty()) return 1;
  double range = 0, geometry = 0;
  int returns_differ = 0;
  std::vector<double> stamp_offsets, arrival_offsets;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const auto& a = truth[i].second;
    const auto& b = live[i].second;
    geometry = std::max({geometry, std::abs(double(a.angle_min - b.angle_min)),
                         std::abs(double(a.angle_increment - b.angle_increment)),
                         std::abs(double(a.time_increment - b.time_increment)) * 1e3,
                         std::abs(double(a.scan_time - b.scan_time)) * 1e3});
    if (a.nranges != b.nranges) {
      geometry = INFINITY;
      continue;
    }
    for (int j = 0; j < a.nranges; ++j) {
      const bool ha = std::isfinite(a.ranges[j]) && a.ranges[j] >= a.range_min && a.ranges[j] <= a.range_max;
      const bool hb = std::isfinite(b.ranges[j]) && b.ranges[j] >= b.range_min && b.ranges[j] <= b.range_max;
      if (ha != hb) ++returns_differ;
      if (ha && hb) range = std::max(range, std::abs(double(a.ranges[j] - b.ranges[j])));
    }
    if (double(a.utime - truth[0].second.utime) >= warmup_us) {
      stamp_offsets.push_back(double(b.utime - a.utime));
      arrival_offsets.push_back(double(live[i].first - a.utime));
    }
  }
  Check(geometry < 1e-6, "angles and timing per beam equal (max difference " + std::to_string(geometry) + ")");
  Check(range <= 0.0005 + 1e-5, "ranges within 0.5 mm (max " + std::to_string(range * 1e3) + " mm)");
  Check(returns_differ == 0, "the same beams return (" + std::to_string(returns_differ) + " differ)");
  // "Plus a constant": the constant that minimises the largest difference is the
  // midrange, so the figure is half the spread. A loaded machine delays some
  // arrivals more than the emulator's jitter, and the stamps' errors are one-sided.
  const double stamp = HalfSpread(stamp_offsets), arrival = HalfSpread(arrival_offsets);
  Check(stamp <= tol_us, "stamps within " + std::to_string(tol_us) + " us of the recording's (plus a constant) after " +
                             "warm-up (max " + std::to_string(stamp) + " us)");
  Check(arrival > 2.0 * tol_us, "the arrivals carried jitter: max " + std::to_string(arrival) + " us");
  return failures ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  try {
    if (mode == "candump" && argc == 6) return Candump(argv);
    if (mode == "wheels" && argc == 6) return Wheels(argv);
    if (mode == "scans" && argc == 6) return Scans(argv);
  } catch (const std::exception& e) {
    std::cerr << "bridge_check: " << e.what() << "\n";
    return 1;
  }
  std::cerr << "usage: see the top of tests/tools/bridge_check.cc\n";
  return 2;
}
