// The solver on Censi et al.'s published calibration tuples (a Khepera-class
// differential drive with a Hokuyo, three laser mountings): our estimates
// against theirs, within their reported one sigma.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "calib/calibrate/calibration.h"
#include "calib/io/text_reader.h"

namespace calib {
namespace {

std::string DataDir() { return std::string(AGVCAL_SOURCE_DIR) + "/../shared/data/censi-calibration-tuples/"; }

// Each tuple becomes one interval of constant wheel speeds; a gap separates tuples, so
// no two intervals share an observation (the tuples' scan pairs need not be consecutive).
void LoadTuples(const std::string& path, WheelTrack* track, std::vector<SensorMotion>* motions) {
  // One JSON object per tuple; some lines hold two.
  TextReader reader(path);
  std::string text, line;
  while (reader.Next(&line)) text += line + "\n";
  std::istringstream in(text);
  int64_t t = 0;
  double left = 0, right = 0;
  for (nlohmann::json j; (in >> std::ws).peek() != EOF;) {
    in >> j;
    const double T = j["T"], phi_l = j["phi_l"], phi_r = j["phi_r"];
    const int64_t start = t, end = t + std::llround(T * 1e6);
    track->Append({start, {left, right}, {0.0, 0.0}});
    left += phi_l * T;
    right += phi_r * T;
    track->Append({end, {left, right}, {0.0, 0.0}});
    SensorMotion m;
    m.utime_start = start;
    m.utime_end = end;
    m.delta = {j["sm"][0], j["sm"][1], j["sm"][2]};
    m.covariance = Eigen::Vector3d(1e-6, 1e-6, 1e-5).asDiagonal();  // rescaled by the solver
    motions->push_back(m);
    t = end + 1000000;
  }
}

class CensiTuples : public ::testing::TestWithParam<std::string> {};

TEST_P(CensiTuples, ReproducesPublishedCalibrationWithinTheirSigma) {
  WheelTrack track;
  std::vector<SensorMotion> motions;
  LoadTuples(DataDir() + GetParam() + ".tuple.gz", &track, &motions);
  ASSERT_GT(motions.size(), 3000u);
  std::ifstream in(DataDir() + GetParam() + "_results.json");
  const nlohmann::json ref = nlohmann::json::parse(in);

  RobotDescription robot;
  robot.drive = DriveType::kDifferential;
  robot.params = {{"left_radius", 0.021}, {"right_radius", 0.021}, {"track", 0.09}};
  robot.lidar2d = Mount2d{"SCAN", 0.0, 0.0, 0.0};
  const CalibrationResult r =
      Calibrate(robot, track, motions, MotionSource::kLidar2d, CalibrationOptions{}, GetParam());

  // Their covariance is over (r_L, r_R, axle, l_x, l_y, l_theta) in metres and radians.
  auto sigma = [&](int i) { return std::sqrt(ref["covariance"][i][i].get<double>()); };
  struct Row { const char* name; double ours, our_std, theirs, their_std; };
  const Row rows[] = {
      {"left_radius", r.params.at("left_radius").value, r.params.at("left_radius").std, ref["l_diam"].get<double>() / 2, sigma(0)},
      {"right_radius", r.params.at("right_radius").value, r.params.at("right_radius").std, ref["r_diam"].get<double>() / 2, sigma(1)},
      {"track", r.params.at("track").value, r.params.at("track").std, ref["axle"], sigma(2)},
      {"lidar.x", r.mount_x.value, r.mount_x.std, ref["l_x"], sigma(3)},
      {"lidar.y", r.mount_y.value, r.mount_y.std, ref["l_y"], sigma(4)},
      {"lidar.yaw", r.mount_yaw.value, r.mount_yaw.std, ref["l_theta"], sigma(5)},
  };
  std::cout << GetParam() << ": " << r.residual.intervals << " tuples, " << r.residual.outliers << " outliers\n";
  for (const Row& row : rows) {
    std::printf("  %-13s ours %.6f ± %.6f   Censi %.6f ± %.6f\n", row.name, row.ours, row.our_std,
                row.theirs, row.their_std);
    EXPECT_NEAR(row.ours, row.theirs, row.their_std) << row.name;
    // Our sigma is no worse than theirs. (It matches theirs on lstraight; on l90 and lmov
    // theirs is about ten times larger, which their files do not explain: docs/calibration.md.)
    EXPECT_LT(row.our_std, 1.5 * row.their_std) << row.name;
    EXPECT_GT(row.our_std, 0.0) << row.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Configurations, CensiTuples, ::testing::Values("lstraight", "l90", "lmov"));

}  // namespace
}  // namespace calib
