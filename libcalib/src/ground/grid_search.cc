// The grid search over the floor's height, pitch and roll (GridSearch, calib/ground/ground.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "calib/ground/ground.h"

namespace calib {

GridEstimate GridSearch(const float* xyz, size_t count, const FloorPose& start,
                        const GridSearchOptions& options) {
  if (!(options.z_step_m > 0 && options.pitch_step_rad > 0 && options.roll_step_rad > 0) ||
      !(options.z_range_m >= 0 && options.pitch_range_rad >= 0 && options.roll_range_rad >= 0) ||
      !(options.band_m > 0) || options.max_rounds < 1)
    throw std::invalid_argument("GridSearch: steps and band must be > 0, ranges >= 0, rounds >= 1");
  GridEstimate out;
  out.points = static_cast<int>(count);
  if (count == 0) return out;
  const float tau2 = static_cast<float>(options.band_m * options.band_m);
  FloorPose center = start;
  FloorPose half{options.z_range_m, options.pitch_range_rad, options.roll_range_rad};
  FloorPose step{options.z_step_m, options.pitch_step_rad, options.roll_step_rad};
  std::vector<float> s(count);
  auto steps_of = [](double h, double st) { return static_cast<int>(std::llround(2.0 * h / st)) + 1; };
  for (int round = 1; round <= options.max_rounds; ++round) {
    const int nz = steps_of(half.z, step.z), np = steps_of(half.pitch, step.pitch),
              nr = steps_of(half.roll, step.roll);
    double best_score = std::numeric_limits<double>::infinity();
    int best_p = 0, best_r = 0, best_z = 0;
    for (int ip = 0; ip < np; ++ip) {
      const double pitch = center.pitch - half.pitch + ip * step.pitch;
      for (int ir = 0; ir < nr; ++ir) {
        const double roll = center.roll - half.roll + ir * step.roll;
        const Eigen::Vector3f n = FloorNormal(pitch, roll).cast<float>();
        for (size_t i = 0; i < count; ++i)
          s[i] = n.x() * xyz[3 * i] + n.y() * xyz[3 * i + 1] + n.z() * xyz[3 * i + 2];
        for (int iz = 0; iz < nz; ++iz) {
          const float z = static_cast<float>(center.z - half.z + iz * step.z);
          double acc[4] = {0, 0, 0, 0};
          size_t i = 0;
          for (; i + 4 <= count; i += 4) {
            for (int k = 0; k < 4; ++k) {
              const float h = s[i + k] + z;
              acc[k] += std::min(h * h, tau2);
            }
          }
          for (; i < count; ++i) {
            const float h = s[i] + z;
            acc[0] += std::min(h * h, tau2);
          }
          const double score = (acc[0] + acc[1] + acc[2] + acc[3]) / static_cast<double>(count);
          if (score < best_score) {  // strict: the first one found wins ties
            best_score = score;
            best_p = ip, best_r = ir, best_z = iz;
          }
        }
      }
    }
    out.candidates_scored += static_cast<int64_t>(np) * nr * nz;
    out.rounds = round;
    out.step = step;
    const FloorPose best{center.z - half.z + best_z * step.z,
                         center.pitch - half.pitch + best_p * step.pitch,
                         center.roll - half.roll + best_r * step.roll};
    out.pose = best;
    // Height error: RMS height of the floor points (within the band) at the best candidate.
    const Eigen::Vector3d n = FloorNormal(best.pitch, best.roll);
    double sum = 0.0;
    int within = 0;
    for (size_t i = 0; i < count; ++i) {
      const double h = n.x() * xyz[3 * i] + n.y() * xyz[3 * i + 1] + n.z() * xyz[3 * i + 2] + best.z;
      if (h * h < tau2) sum += h * h, ++within;
    }
    out.height_error_m = within ? std::sqrt(sum / within) : options.band_m;
    auto on_edge = [](int index, int n_steps) { return n_steps > 1 && (index == 0 || index == n_steps - 1); };
    center = best;
    if (on_edge(best_z, nz) || on_edge(best_p, np) || on_edge(best_r, nr)) continue;  // re-centre
    if (out.height_error_m <= options.tolerance_m) {
      out.accepted = true;
      break;
    }
    half = step;
    step = FloorPose{step.z / 5.0, step.pitch / 5.0, step.roll / 5.0};
  }
  return out;
}

}  // namespace calib
