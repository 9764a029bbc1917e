// Lengths in encoded messages are checked against the bytes left before lcm-gen's
// decoders allocate (calib/io/message_layout.h): a corrupt array length is refused
// with the field, the length and the limit, and valid messages of every type pass.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/io/message_layout.h"
#include "calib/io/messages.h"

namespace calib {
namespace {

void PutInt32(std::vector<uint8_t>* bytes, size_t at, uint32_t value) {
  for (int i = 0; i < 4; ++i) (*bytes)[at + i] = static_cast<uint8_t>(value >> (24 - 8 * i));
}

agvcal::laser_scan_t Scan(int beams) {
  agvcal::laser_scan_t scan{};
  scan.utime = 1000;
  scan.angle_increment = 0.01f;
  scan.range_max = 30;
  scan.nranges = beams;
  scan.ranges.assign(beams, 2.0f);
  return scan;
}

agvcal::wheel_state_t Wheels() {
  agvcal::wheel_state_t w{};
  w.utime = 5;
  w.num_wheels = 2;
  w.name = {"left", "right"};
  w.position = {0.1, 0.2};
  w.velocity = {0, 0};
  w.steer = {0, 0};
  return w;
}

TEST(MessageLayout, ValidMessagesPass) {
  const std::vector<uint8_t> scan = Encode(Scan(540));
  EXPECT_EQ(CheckEncodedLengths("laser_scan_t", scan.data(), scan.size()), "");
  const std::vector<uint8_t> wheels = Encode(Wheels());
  EXPECT_EQ(CheckEncodedLengths("wheel_state_t", wheels.data(), wheels.size()), "");
  agvcal::calib_estimate_t estimate{};
  estimate.drive = "tricycle";
  estimate.num_values = 2;
  estimate.names = {"drive_radius", "wheelbase"};
  estimate.values = estimate.stds = estimate.nominal = {0.1, 1.4};
  estimate.num_weak = 1;
  estimate.weak = {"wheelbase"};
  const std::vector<uint8_t> e = Encode(estimate);
  EXPECT_EQ(CheckEncodedLengths("calib_estimate_t", e.data(), e.size()), "");
  agvcal::point_cloud_t cloud{};
  cloud.npoints = 3;
  cloud.xyz.assign(3, std::vector<float>{1.0f, 2.0f, 0.5f});
  const std::vector<uint8_t> c = Encode(cloud);
  EXPECT_EQ(CheckEncodedLengths("point_cloud_t", c.data(), c.size()), "");
}

TEST(MessageLayout, HugeArrayLengthIsRefusedBeforeDecoding) {
  std::vector<uint8_t> bytes = Encode(Scan(10));
  PutInt32(&bytes, 8 + 8 + 6 * 4, 0x7fffffff);  // nranges, after the hash, utime and six floats
  const std::string why = CheckEncodedLengths("laser_scan_t", bytes.data(), bytes.size());
  EXPECT_NE(why.find("nranges = 2147483647"), std::string::npos) << why;
  EXPECT_NE(why.find("ranges needs at least 8589934588 bytes"), std::string::npos) << why;
  agvcal::laser_scan_t scan;
  EXPECT_FALSE(Decode(bytes.data(), static_cast<int>(bytes.size()), &scan));  // and nothing allocated
}

TEST(MessageLayout, NegativeAndStringLengthsAreRefused) {
  std::vector<uint8_t> wheels = Encode(Wheels());
  PutInt32(&wheels, 16, 1u << 28);  // num_wheels
  std::string why = CheckEncodedLengths("wheel_state_t", wheels.data(), wheels.size());
  EXPECT_NE(why.find("num_wheels = 268435456"), std::string::npos) << why;
  PutInt32(&wheels, 16, 0xffffffffu);  // -1
  why = CheckEncodedLengths("wheel_state_t", wheels.data(), wheels.size());
  EXPECT_NE(why.find("num_wheels = -1: a negative length"), std::string::npos) << why;
  wheels = Encode(Wheels());
  PutInt32(&wheels, 20, 0x40000000);  // the length of the first name
  why = CheckEncodedLengths("wheel_state_t", wheels.data(), wheels.size());
  EXPECT_NE(why.find("name: a string of 1073741824 bytes"), std::string::npos) << why;
}

TEST(MessageLayout, TruncatedMessageIsRefusedAtItsField) {
  const std::vector<uint8_t> bytes = Encode(Scan(10));
  for (size_t cut : {size_t{12}, size_t{44}, bytes.size() - 3}) {
    const std::string why = CheckEncodedLengths("laser_scan_t", bytes.data(), cut);
    EXPECT_FALSE(why.empty()) << "cut at " << cut;
  }
  EXPECT_EQ(CheckEncodedLengths("no_such_t", bytes.data(), bytes.size()), "");
}

}  // namespace
}  // namespace calib
