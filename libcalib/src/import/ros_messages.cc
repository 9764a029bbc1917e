// Decoding of the ROS messages of ros_messages.h. CDR (OMG DDS-XTypes, encapsulation
// CDR_LE/CDR_BE): primitives aligned to their size counted from after the 4-byte
// encapsulation header, strings with length and a terminating NUL, sequences with a uint32
// length. ROS 1: the same order, no alignment, strings without NUL, a Header with a seq.
#include "import/ros_messages.h"

#include <cmath>
#include <cstring>

#include "calib/core/errors.h"

namespace calib::import_internal {

namespace {

class Deserializer {
 public:
  explicit Deserializer(const BagMessage& message)
      : message_(message), data_(message.data.data()), size_(message.data.size()) {
    ros1_ = message.topic->encoding == "ros1";
    if (ros1_) return;
    if (message.topic->encoding != "cdr")
      Fail("unknown message encoding '" + message.topic->encoding + "' (known: cdr, ros1)");
    if (size_ < 4) Fail("shorter than the CDR encapsulation header");
    if (data_[0] != 0 || (data_[1] != 0 && data_[1] != 1))
      Fail("unknown CDR encapsulation " + std::to_string(data_[0]) + "," + std::to_string(data_[1]) +
           " (known: CDR_LE 0,1 and CDR_BE 0,0)");
    swap_ = (data_[1] == 1) != LittleEndianHost();
    origin_ = at_ = 4;
  }

  template <typename T>
  T Get() {
    Align(sizeof(T));
    const uint8_t* p = Take(sizeof(T));
    uint8_t bytes[sizeof(T)];
    for (size_t i = 0; i < sizeof(T); ++i) bytes[i] = p[swap_ ? sizeof(T) - 1 - i : i];
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
  }
  double F64() { return Get<double>(); }
  template <size_t N>
  std::array<double, N> F64s() {
    std::array<double, N> values;
    for (auto& v : values) v = F64();
    return values;
  }
  std::string String() {
    const uint32_t length = Length(1);
    const char* p = reinterpret_cast<const char*>(Take(length));
    if (ros1_) return std::string(p, length);
    if (length == 0 || p[length - 1] != '\0') Fail("CDR string without its terminating NUL");
    return std::string(p, length - 1);
  }
  // A sequence's length, checked against the bytes left (each element at least `element_size`).
  uint32_t Length(size_t element_size) {
    const uint32_t n = Get<uint32_t>();
    if (n > (size_ - at_) / element_size)
      Fail("array of " + std::to_string(n) + " elements longer than the message");
    return n;
  }
  template <typename T>
  std::vector<T> Sequence() {
    std::vector<T> values(Length(sizeof(T)));
    for (auto& v : values) v = Get<T>();
    return values;
  }
  RosHeader Header() {
    RosHeader header;
    if (ros1_) Get<uint32_t>();  // seq
    const int64_t sec = ros1_ ? int64_t{Get<uint32_t>()} : int64_t{Get<int32_t>()};
    const uint32_t nanosec = Get<uint32_t>();
    if (nanosec >= 1000000000u) Fail("header stamp nanoseconds " + std::to_string(nanosec) + " >= 1e9");
    header.stamp_ns = sec * 1000000000 + nanosec;
    header.frame_id = String();
    return header;
  }
  RosPose Pose() {
    RosPose pose;
    pose.position = F64s<3>();
    pose.orientation = F64s<4>();
    return pose;
  }
  [[noreturn]] void Fail(const std::string& problem) const {
    throw InputError(message_.file, message_.place + " (topic " + message_.topic->name + ", " +
                                        message_.topic->type + ")", problem);
  }

 private:
  static bool LittleEndianHost() {
    const uint16_t one = 1;
    uint8_t first;
    std::memcpy(&first, &one, 1);
    return first == 1;
  }
  void Align(size_t n) {
    if (ros1_) return;
    const size_t pad = (n - (at_ - origin_) % n) % n;
    Take(pad);
  }
  const uint8_t* Take(size_t n) {
    if (n > size_ - at_) Fail("message shorter than its fields (truncated, or not this type)");
    const uint8_t* p = data_ + at_;
    at_ += n;
    return p;
  }

  const BagMessage& message_;
  const uint8_t* data_;
  size_t size_, at_ = 0, origin_ = 0;
  bool ros1_ = false, swap_ = false;
};

struct TypeName {
  RosType type;
  const char* name;
};
constexpr TypeName kTypes[] = {
    {RosType::kJointState, "sensor_msgs/msg/JointState"},
    {RosType::kLaserScan, "sensor_msgs/msg/LaserScan"},
    {RosType::kImu, "sensor_msgs/msg/Imu"},
    {RosType::kOdometry, "nav_msgs/msg/Odometry"},
    {RosType::kTwist, "geometry_msgs/msg/Twist"},
    {RosType::kTwistStamped, "geometry_msgs/msg/TwistStamped"},
    {RosType::kTfMessage, "tf2_msgs/msg/TFMessage"},
};

}  // namespace

bool FindRosType(const std::string& type_name, RosType* type) {
  for (const auto& known : kTypes) {
    std::string ros1 = known.name;
    ros1.erase(ros1.find("/msg/"), 4);
    if (type_name == known.name || type_name == ros1) {
      *type = known.type;
      return true;
    }
  }
  return false;
}

const char* RosTypeName(RosType type) {
  for (const auto& known : kTypes)
    if (known.type == type) return known.name;
  return "";
}

RosJointState DecodeJointState(const BagMessage& message) {
  Deserializer in(message);
  RosJointState state;
  state.header = in.Header();
  state.name.resize(in.Length(4));
  for (auto& name : state.name) name = in.String();
  state.position = in.Sequence<double>();
  state.velocity = in.Sequence<double>();
  state.effort = in.Sequence<double>();
  return state;
}

RosLaserScan DecodeLaserScan(const BagMessage& message) {
  Deserializer in(message);
  RosLaserScan scan;
  scan.header = in.Header();
  for (float* field : {&scan.angle_min, &scan.angle_max, &scan.angle_increment, &scan.time_increment,
                       &scan.scan_time, &scan.range_min, &scan.range_max})
    *field = in.Get<float>();
  scan.ranges = in.Sequence<float>();
  scan.intensities = in.Sequence<float>();
  return scan;
}

RosImu DecodeImu(const BagMessage& message) {
  Deserializer in(message);
  RosImu imu;
  imu.header = in.Header();
  in.F64s<4>();  // orientation
  in.F64s<9>();
  imu.angular_velocity = in.F64s<3>();
  in.F64s<9>();
  imu.linear_acceleration = in.F64s<3>();
  in.F64s<9>();
  return imu;
}

RosOdometry DecodeOdometry(const BagMessage& message) {
  Deserializer in(message);
  RosOdometry odometry;
  odometry.header = in.Header();
  odometry.child_frame_id = in.String();
  odometry.pose = in.Pose();
  odometry.pose_covariance = in.F64s<36>();
  in.F64s<6>();  // twist
  in.F64s<36>();
  return odometry;
}

RosTwist DecodeTwist(const BagMessage& message, bool stamped) {
  Deserializer in(message);
  RosTwist twist;
  twist.stamped = stamped;
  if (stamped) twist.header = in.Header();
  twist.linear = in.F64s<3>();
  twist.angular = in.F64s<3>();
  return twist;
}

std::vector<RosTransform> DecodeTfMessage(const BagMessage& message) {
  Deserializer in(message);
  std::vector<RosTransform> transforms(in.Length(4 + 8 * 7));
  for (auto& t : transforms) {
    t.header = in.Header();
    t.child_frame_id = in.String();
    t.transform = in.Pose();
  }
  return transforms;
}

double YawOf(const std::array<double, 4>& q) {
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

}  // namespace calib::import_internal
