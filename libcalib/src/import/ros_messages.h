#pragma once
// The ROS messages the bag importers read, decoded from ROS 2's CDR (little or big endian,
// XCDR1 alignment) or ROS 1's serialization into plain structs. Internal to libcalib.
// Every problem (a message shorter than its fields, an array longer than the message, an
// unknown CDR encapsulation) throws InputError naming the message's file and place.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "import/ros_bag.h"

namespace calib::import_internal {

struct RosHeader {
  int64_t stamp_ns = 0;
  std::string frame_id;
};

struct RosJointState {
  RosHeader header;
  std::vector<std::string> name;
  std::vector<double> position, velocity, effort;
};

struct RosLaserScan {
  RosHeader header;
  float angle_min = 0, angle_max = 0, angle_increment = 0, time_increment = 0, scan_time = 0;
  float range_min = 0, range_max = 0;
  std::vector<float> ranges, intensities;
};

struct RosImu {
  RosHeader header;
  std::array<double, 3> angular_velocity{}, linear_acceleration{};
};

struct RosPose {  // position and orientation (x, y, z, w)
  std::array<double, 3> position{};
  std::array<double, 4> orientation{};
};

struct RosOdometry {
  RosHeader header;
  std::string child_frame_id;
  RosPose pose;
  std::array<double, 36> pose_covariance{};
};

struct RosTwist {
  bool stamped = false;
  RosHeader header;  // TwistStamped only
  std::array<double, 3> linear{}, angular{};
};

struct RosTransform {
  RosHeader header;
  std::string child_frame_id;
  RosPose transform;  // translation and rotation
};

// The message types, as ROS 2 names them (ROS 1 names drop the "/msg").
enum class RosType { kJointState, kLaserScan, kImu, kOdometry, kTwist, kTwistStamped, kTfMessage };
// The type a topic's type name (ROS 1 or ROS 2 spelling) names; false for another type.
bool FindRosType(const std::string& type_name, RosType* type);
const char* RosTypeName(RosType type);

RosJointState DecodeJointState(const BagMessage& message);
RosLaserScan DecodeLaserScan(const BagMessage& message);
RosImu DecodeImu(const BagMessage& message);
RosOdometry DecodeOdometry(const BagMessage& message);
RosTwist DecodeTwist(const BagMessage& message, bool stamped);
std::vector<RosTransform> DecodeTfMessage(const BagMessage& message);

// Yaw (rad) of a quaternion (x, y, z, w).
double YawOf(const std::array<double, 4>& q);

}  // namespace calib::import_internal
