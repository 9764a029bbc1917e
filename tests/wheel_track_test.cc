// WheelTrack's compact storage (issue 17 item 7, docs/live.md "Memory over long runs"): it
// keeps exactly the samples appended, in a fixed number of bytes per sample, and interpolates
// and cuts increments with the arithmetic of the plain list of samples it replaced, bit for bit.
#include "calib/core/wheel_track.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace calib {
namespace {

// Samples at 100 Hz with jittered stamps; steering from sample `steer_from` on (never if < 0).
std::vector<WheelSample> Samples(int n, int roles, int steer_from, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> step(-0.05, 0.2), angle(-0.5, 0.5);
  std::uniform_int_distribution<int> jitter(-300, 300);
  std::vector<WheelSample> out;
  std::vector<double> position(roles, 1e4);  // large accumulated rotations, as on a robot after days
  for (int i = 0; i < n; ++i) {
    WheelSample s;
    s.utime = 1'700'000'000'000'000 + int64_t(i) * 10'000 + jitter(rng);
    for (int r = 0; r < roles; ++r) {
      position[r] += step(rng);
      s.position.push_back(position[r]);
      s.steer.push_back(steer_from >= 0 && i >= steer_from ? angle(rng) : 0.0);
    }
    out.push_back(s);
  }
  return out;
}

WheelTrack Track(const std::vector<WheelSample>& samples) {
  WheelTrack track;
  for (const WheelSample& s : samples) EXPECT_TRUE(track.Append(s));
  return track;
}

void ExpectSame(const WheelSample& a, const WheelSample& b) {
  EXPECT_EQ(a.utime, b.utime);
  ASSERT_EQ(a.position.size(), b.position.size());
  ASSERT_EQ(a.steer.size(), b.steer.size());
  for (std::size_t r = 0; r < a.position.size(); ++r) {
    EXPECT_EQ(a.position[r], b.position[r]);  // bit for bit: no tolerance
    EXPECT_EQ(a.steer[r], b.steer[r]);
    EXPECT_EQ(std::signbit(a.steer[r]), std::signbit(b.steer[r]));
  }
}

// The interpolation of the list of samples WheelTrack used to hold (the reference).
WheelSample ReferenceAt(const std::vector<WheelSample>& s, double t) {
  if (t <= double(s.front().utime)) return s.front();
  if (t >= double(s.back().utime)) return s.back();
  std::size_t i = 0;
  while (i + 1 < s.size() && double(s[i + 1].utime) <= t) ++i;
  const WheelSample &a = s[i], &b = s[i + 1];
  const double f = (t - double(a.utime)) / double(b.utime - a.utime);
  WheelSample out;
  out.utime = std::llround(t);
  for (std::size_t r = 0; r < a.position.size(); ++r) {
    out.position.push_back(a.position[r] + f * (b.position[r] - a.position[r]));
    out.steer.push_back(a.steer[r] + f * (b.steer[r] - a.steer[r]));
  }
  return out;
}

TEST(WheelTrack, KeepsEverySampleExactly) {
  for (int steer_from : {-1, 0, 300}) {
    const std::vector<WheelSample> samples = Samples(1000, 2, steer_from);
    const WheelTrack track = Track(samples);
    ASSERT_EQ(track.size(), samples.size());
    EXPECT_EQ(track.roles(), 2u);
    for (std::size_t i = 0; i < samples.size(); ++i) ExpectSame(track.sample(i), samples[i]);
  }
}

TEST(WheelTrack, NegativeZeroSteeringIsKept) {
  std::vector<WheelSample> samples = Samples(10, 1, -1);
  samples[4].steer[0] = -0.0;
  const WheelTrack track = Track(samples);
  EXPECT_TRUE(std::signbit(track.sample(4).steer[0]));
  EXPECT_FALSE(std::signbit(track.sample(3).steer[0]));
}

// 8 bytes of stamp and 8 per wheel reading: 24 bytes per sample of an unsteered two-wheel drive,
// 40 with steering (vector growth may hold up to twice that in reserve).
TEST(WheelTrack, BytesPerSample) {
  const int n = 100000;
  const WheelTrack unsteered = Track(Samples(n, 2, -1)), steered = Track(Samples(n, 2, 0));
  EXPECT_GE(unsteered.bytes(), 24u * n);
  EXPECT_LE(unsteered.bytes(), 2 * 24u * n);
  EXPECT_GE(steered.bytes(), 40u * n);
  EXPECT_LE(steered.bytes(), 2 * 40u * n);
}

TEST(WheelTrack, RefusesOutOfOrderStampsAndOtherWheelCounts) {
  std::vector<WheelSample> samples = Samples(3, 2, -1);
  WheelTrack track = Track({samples[0], samples[1]});
  EXPECT_FALSE(track.Append(samples[1]));  // repeated stamp
  EXPECT_FALSE(track.Append(samples[0]));  // older
  WheelSample three = samples[2];
  three.position.push_back(0.0);
  three.steer.push_back(0.0);
  EXPECT_FALSE(track.Append(three));
  EXPECT_EQ(track.size(), 2u);
  EXPECT_TRUE(track.Append(samples[2]));
}

// At and Increments give what the plain list of samples gave, bit for bit, so a solve on the
// compact track equals the solve before the change (docs/live.md: live = offline).
TEST(WheelTrack, InterpolatesAsTheListOfSamples) {
  for (int steer_from : {-1, 200}) {
    const std::vector<WheelSample> samples = Samples(500, 2, steer_from, 7);
    const WheelTrack track = Track(samples);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> when(double(samples.front().utime) - 5e4,
                                                double(samples.back().utime) + 5e4);
    for (int k = 0; k < 300; ++k) {
      const double t = when(rng);
      ExpectSame(track.At(t), ReferenceAt(samples, t));
    }
    // An increment list: the cut ends and the samples between, as steps.
    const double t0 = double(samples[100].utime) + 1234.5, t1 = double(samples[180].utime) - 77.25;
    const std::vector<WheelIncrement> steps = track.Increments(t0, t1);
    ASSERT_EQ(steps.size(), 80u);
    WheelSample previous = ReferenceAt(samples, t0);
    for (std::size_t k = 0; k < steps.size(); ++k) {
      const WheelSample next = k + 1 < steps.size() ? samples[101 + k] : ReferenceAt(samples, t1);
      for (int r = 0; r < 2; ++r) {
        EXPECT_EQ(steps[k].rotation[r], next.position[r] - previous.position[r]);
        EXPECT_EQ(steps[k].steer_start[r], previous.steer[r]);
        EXPECT_EQ(steps[k].steer_end[r], next.steer[r]);
      }
      previous = next;
    }
  }
}

TEST(WheelTrack, DropBeforeKeepsTheRest) {
  const std::vector<WheelSample> samples = Samples(50, 2, 10);
  WheelTrack track = Track(samples);
  track.DropBefore(20);
  ASSERT_EQ(track.size(), 30u);
  for (std::size_t i = 0; i < track.size(); ++i) ExpectSame(track.sample(i), samples[20 + i]);
  EXPECT_EQ(track.IndexBefore(double(samples[35].utime) + 1.0), 15u);
}

}  // namespace
}  // namespace calib
