// agvcal-bench-ground: time of the floor fit (calib::FitFloor) on one
// 120 000-point frame of the simulated 3D lidar (128 rings, the warehouse, the
// forklift's body in view), and of the grid search on the same frame, on one
// core (everything here is single-threaded).
//   agvcal-bench-ground [--points N] [--repeat R]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "agvcal/point_cloud_t.hpp"
#include "calib/ground/ground.h"
#include "calib/io/messages.h"
#include "calib/sim/simulator.h"

namespace {

double Millis(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

// Median and minimum of `repeat` runs of f, ms.
template <typename F>
std::pair<double, double> Time(int repeat, F&& f) {
  std::vector<double> ms;
  for (int k = 0; k < repeat; ++k) {
    const auto start = std::chrono::steady_clock::now();
    f();
    ms.push_back(Millis(std::chrono::steady_clock::now() - start));
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms.front()};
}

}  // namespace

int main(int argc, char** argv) {
  size_t points = 120000;
  int repeat = 30;
  for (int i = 1; i < argc; i += 2) {
    const std::string key = argv[i];
    const bool known = key == "--points" || key == "--repeat";
    if (!known || i + 1 >= argc) {
      const bool help = key == "--help" || key == "-h";
      std::fprintf(help ? stdout : stderr,
                   "usage: agvcal-bench-ground [--points N] [--repeat R]\n"
                   "Times the floor fit and the grid search on one simulated 3D lidar frame\n"
                   "(N points, default 120000; R repetitions, default 30), single-threaded.\n");
      return help ? 0 : 2;
    }
    if (key == "--points") points = std::strtoul(argv[i + 1], nullptr, 10);
    else repeat = std::max(1, std::atoi(argv[i + 1]));
  }
  const calib::SimConfig config = calib::ParseSimConfig(R"(
robot: ../robots/forklift.yaml
truth:
  lidar3d: {z: 1.912, pitch: 0.035, roll: -0.012}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 128, elevation_min: -0.3927, elevation_max: 0.3927,
            points_per_ring: 1400, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
)", "bench.yaml", std::string(AGVCAL_SOURCE_DIR) + "/config/sims");
  calib::Simulator sim(config);
  calib::MemorySink sink;
  sim.AdvanceTo(config.start_utime + 50000, &sink);  // the first cloud
  std::vector<float> xyz;
  for (const calib::LogEvent& e : sink.events) {
    if (e.channel != calib::kCloudChannel) continue;
    agvcal::point_cloud_t cloud;
    if (!calib::Decode(e.data.data(), static_cast<int>(e.data.size()), &cloud)) return 1;
    for (const auto& p : cloud.xyz) xyz.insert(xyz.end(), {p[0], p[1], p[2]});
  }
  if (xyz.size() / 3 < points) {
    std::fprintf(stderr, "the simulated frame has only %zu points\n", xyz.size() / 3);
    return 1;
  }
  xyz.resize(3 * points);  // ring by ring from the lowest: the cut drops upper rings only

  const calib::Mount3d& nominal = *config.robot.lidar3d;
  calib::FloorFitOptions fit_options;
  calib::FrameFit fit;
  std::vector<float> floor_points;
  const auto fit_time = Time(repeat, [&] {
    fit = calib::FitFloor(xyz.data(), points, nominal, fit_options, 0.0, &floor_points);
  });
  calib::GridEstimate grid;
  const calib::FloorPose start{nominal.z, nominal.pitch, nominal.roll};
  const calib::GridSearchOptions grid_options;
  const auto grid_time = Time(std::max(1, repeat / 10), [&] {
    grid = calib::GridSearch(floor_points.data(), floor_points.size() / 3, start, grid_options);
  });

  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  std::printf("frame: %zu points (128 rings, simulated warehouse, forklift body in view)\n", points);
  std::printf("floor fit      : median %7.2f ms, min %7.2f ms over %d runs; %d floor points "
              "(RMS %.1f mm), z %.4f m, pitch %.4f deg, roll %.4f deg%s\n",
              fit_time.first, fit_time.second, repeat, fit.inliers, 1000 * fit.rms_m, fit.pose.z,
              fit.pose.pitch / kDeg, fit.pose.roll / kDeg, fit.usable ? "" : " (NOT usable)");
  std::printf("grid search    : median %7.2f ms, min %7.2f ms; %lld candidates in %d rounds over "
              "the %d floor points, %s, z %.4f m, pitch %.4f deg, roll %.4f deg\n",
              grid_time.first, grid_time.second, static_cast<long long>(grid.candidates_scored),
              grid.rounds, grid.points, grid.accepted ? "accepted" : "not accepted", grid.pose.z,
              grid.pose.pitch / kDeg, grid.pose.roll / kDeg);
  std::printf("grid / fit     : %.1f (the grid search also needs the fit's floor points: "
              "fit + grid = %.2f ms)\n",
              grid_time.first / fit_time.first, fit_time.first + grid_time.first);
  // A tighter tolerance makes the grid refine further (more rounds, finer steps).
  calib::GridSearchOptions fine = grid_options;
  fine.tolerance_m = 1.05 * fit.rms_m;  // 5 % above the floor's own RMS
  calib::GridEstimate fine_grid;
  const auto fine_time = Time(std::max(1, repeat / 10), [&] {
    fine_grid = calib::GridSearch(floor_points.data(), floor_points.size() / 3, start, fine);
  });
  std::printf("grid, tol. %.1fmm: median %7.2f ms; %lld candidates in %d rounds, %s, steps %.2g m, "
              "%.2g deg, %.2g deg; grid / fit %.1f\n",
              1000 * fine.tolerance_m, fine_time.first, static_cast<long long>(fine_grid.candidates_scored),
              fine_grid.rounds,
              fine_grid.accepted ? "accepted" : "not accepted", fine_grid.step.z,
              fine_grid.step.pitch / kDeg, fine_grid.step.roll / kDeg, fine_time.first / fit_time.first);
  std::printf("target         : floor fit under 20 ms: %s\n", fit_time.first < 20.0 ? "met" : "NOT met");
  return 0;
}
