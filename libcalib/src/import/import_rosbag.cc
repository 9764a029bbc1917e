// ROS bags -> WHEELS, SCAN, IMU, POSE, DRIVE_CMD (importers.h: ImportRosbag2, ImportRosbag).
// The robot file's ros: block says which topic is which; the storage readers (ros_bag.h) give
// the messages in record order, ros_messages.h decodes them.
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"
#include "import/ros_bag.h"
#include "import/ros_messages.h"

namespace calib {

namespace {

using namespace import_internal;

// A drive command holds this long unless a newer one replaces it (a recording does not say).
constexpr double kCommandTimeoutS = 0.5;

const RosTopics& RequireRos(const RobotDescription& robot) {
  if (!robot.ros)
    throw InputError(robot.source_file, "ros",
                     "the robot file has no ros: block naming the bag's topics (docs/ros.md)");
  return *robot.ros;
}

std::set<std::string> WantedTopics(const RosTopics& ros) {
  std::set<std::string> wanted;
  for (const auto* topic : {&ros.joint_states, &ros.scan, &ros.imu, &ros.odom, &ros.cmd_vel, &ros.tf_static})
    if (!topic->empty()) wanted.insert(*topic);
  return wanted;
}

int64_t MicrosecondsOf(int64_t ns) { return ns >= 0 ? ns / 1000 : -((-ns + 999) / 1000); }

// The topic's type, checked against the types it may have.
RosType CheckTopic(const Bag& bag, const std::string& source, const std::string& topic,
                   const std::string& key, std::vector<RosType> allowed) {
  std::string expected;
  for (RosType type : allowed) expected += (expected.empty() ? "" : " or ") + std::string(RosTypeName(type));
  const auto found = bag.topics.find(topic);
  if (found == bag.topics.end()) {
    std::string names;
    for (const auto& [name, t] : bag.topics) names += (names.empty() ? "" : ", ") + name + " (" + t.type + ")";
    throw InputError(source, "topic " + topic + " (robot file ros." + key + ")",
                     "not in the bag; its topics: " + (names.empty() ? "none" : names));
  }
  RosType type;
  if (!FindRosType(found->second.type, &type) ||
      std::find(allowed.begin(), allowed.end(), type) == allowed.end())
    throw InputError(source, "topic " + topic + " (robot file ros." + key + ")",
                     "is " + found->second.type + ", expected " + expected);
  return type;
}

class BagConverter {
 public:
  BagConverter(const Bag& bag, const std::string& source, const RobotDescription& robot)
      : bag_(bag), source_(source), robot_(robot), ros_(*robot.ros) {}

  ImportSummary Convert(MessageSink* sink) {
    if (!ros_.joint_states.empty()) CheckTopic(bag_, source_, ros_.joint_states, "joint_states", {RosType::kJointState});
    if (!ros_.scan.empty()) CheckTopic(bag_, source_, ros_.scan, "scan", {RosType::kLaserScan});
    if (!ros_.imu.empty()) CheckTopic(bag_, source_, ros_.imu, "imu", {RosType::kImu});
    if (!ros_.odom.empty()) CheckTopic(bag_, source_, ros_.odom, "odom", {RosType::kOdometry});
    if (!ros_.cmd_vel.empty())
      CheckTopic(bag_, source_, ros_.cmd_vel, "cmd_vel", {RosType::kTwist, RosType::kTwistStamped});
    const bool tf = bag_.topics.count(ros_.tf_static) &&
                    CheckTopic(bag_, source_, ros_.tf_static, "tf_static", {RosType::kTfMessage}) ==
                        RosType::kTfMessage;
    for (const BagMessage& message : bag_.messages) {
      const std::string& topic = message.topic->name;
      if (topic == ros_.joint_states) Wheels(message);
      if (topic == ros_.scan) Scan(message);
      if (topic == ros_.imu) Imu(message);
      if (topic == ros_.odom) Odometry(message);
      if (topic == ros_.cmd_vel) Command(message);
      if (tf && topic == ros_.tf_static) static_transforms_.push_back(&message);
    }
    for (const BagMessage* message : static_transforms_) Transforms(*message);  // knowing the scan's frame
    if (ros_.odom_as_wheels) {
      AddWheelsFromOdometry(odometry_, robot_, &events_, &summary_);
      summary_.notes.push_back("wheel states from " + ros_.odom + "'s poses, inverted with " + robot_.source_file +
                               "'s nominal radii and track");
    }
    summary_.lines = static_cast<int64_t>(bag_.messages.size());
    for (const auto* order : {&wheels_order_, &scan_order_, &imu_order_, &pose_order_, &command_order_})
      summary_.duplicates_dropped += order->duplicates;
    summary_.notes.push_back(ros_.header_stamps ? "stamped with the messages' header stamps"
                                                : "stamped with the bag's record times");
    if (skipped_joint_states_)
      summary_.notes.push_back(std::to_string(skipped_joint_states_) +
                               " joint_states messages without the robot's joints left out");
    events_.Publish(sink, &summary_);
    return summary_;
  }

 private:
  int64_t Stamp(const BagMessage& message, const RosHeader& header) const {
    return MicrosecondsOf(ros_.header_stamps ? header.stamp_ns : message.record_ns);
  }

  // Position of `joint` in the message, or -1.
  static int IndexOf(const RosJointState& state, const std::string& joint) {
    const auto found = std::find(state.name.begin(), state.name.end(), joint);
    return found == state.name.end() ? -1 : static_cast<int>(found - state.name.begin());
  }

  void Wheels(const BagMessage& message) {
    const RosJointState state = DecodeJointState(message);
    const std::string place = message.place + " (topic " + message.topic->name + ")";
    if (state.position.size() != state.name.size() ||
        (!state.velocity.empty() && state.velocity.size() != state.name.size()))
      throw InputError(message.file, place,
                       std::to_string(state.name.size()) + " joint names but " +
                           std::to_string(state.position.size()) + " positions and " +
                           std::to_string(state.velocity.size()) + " velocities");
    const std::vector<std::string>& roles = WheelRoles(robot_.drive);
    int present = 0;
    for (const auto& role : roles) present += IndexOf(state, ros_.wheel_joints.at(role)) >= 0;
    if (present == 0) {
      ++skipped_joint_states_;
      return;
    }
    WheelSample sample;
    sample.utime = Stamp(message, state.header);
    std::vector<double> velocity;
    for (const auto& role : roles) {
      const int i = IndexOf(state, ros_.wheel_joints.at(role));
      if (i < 0) throw InputError(message.file, place, "no joint " + ros_.wheel_joints.at(role) + " (wheel " + role + ")");
      sample.position.push_back(state.position[i]);
      if (!state.velocity.empty()) velocity.push_back(state.velocity[i]);
      const auto steering = ros_.steering_joints.find(role);
      int s = steering == ros_.steering_joints.end() ? -1 : IndexOf(state, steering->second);
      if (steering != ros_.steering_joints.end() && s < 0)
        throw InputError(message.file, place, "no joint " + steering->second + " (steering of " + role + ")");
      sample.steer.push_back(s < 0 ? 0.0 : state.position[s]);
    }
    if (!wheels_order_.Accept(message.file, place, sample.utime)) return;
    if (first_position_.empty()) first_position_ = sample.position;
    for (size_t i = 0; i < roles.size(); ++i) sample.position[i] -= first_position_[i];
    auto wheel_state = WheelStateMessage(sample, robot_, velocity);
    try {
      WheelSampleFromMessage(wheel_state, robot_, message.file);
    } catch (const InputError& e) {
      throw InputError(message.file, place, e.problem());
    }
    events_.Add(kWheelsStream, kWheelsChannel, sample.utime, Encode(wheel_state));
  }

  void Scan(const BagMessage& message) {
    RosLaserScan in = DecodeLaserScan(message);
    agvcal::laser_scan_t scan{};
    scan.utime = Stamp(message, in.header);
    scan.angle_min = in.angle_min;
    scan.angle_increment = in.angle_increment;
    scan.time_increment = in.time_increment;
    scan.scan_time = in.scan_time;
    scan.range_min = in.range_min;
    scan.range_max = in.range_max;
    scan.nranges = static_cast<int32_t>(in.ranges.size());
    scan.ranges = std::move(in.ranges);
    scan.nintensities = in.intensities.size() == scan.ranges.size() ? scan.nranges : 0;
    if (scan.nintensities) scan.intensities = std::move(in.intensities);
    const std::string place = message.place + " (topic " + message.topic->name + ")";
    try {
      LaserScanFromMessage(scan, message.file);
    } catch (const InputError& e) {
      throw InputError(message.file, place, e.problem());
    }
    if (scan_frame_.empty()) scan_frame_ = in.header.frame_id;
    if (scan_order_.Accept(message.file, place, scan.utime))
      events_.Add(kScanStream, ScanChannel(robot_), scan.utime, Encode(scan));
  }

  void Imu(const BagMessage& message) {
    const RosImu in = DecodeImu(message);
    agvcal::imu_t imu{};
    imu.utime = Stamp(message, in.header);
    for (int i = 0; i < 3; ++i) {
      imu.angular_velocity[i] = in.angular_velocity[i];
      imu.linear_acceleration[i] = in.linear_acceleration[i];
    }
    if (imu_order_.Accept(message.file, message.place, imu.utime))
      events_.Add(kImuStream, ImuChannel(robot_), imu.utime, Encode(imu));
  }

  void Odometry(const BagMessage& message) {
    const RosOdometry in = DecodeOdometry(message);
    if (ros_.odom_as_wheels) {
      const int64_t utime = Stamp(message, in.header);
      if (pose_order_.Accept(message.file, message.place, utime))
        odometry_.push_back({utime, {in.pose.position[0], in.pose.position[1], YawOf(in.pose.orientation)}});
      return;
    }
    agvcal::pose2d_t pose{};
    pose.utime = Stamp(message, in.header);
    pose.x = in.pose.position[0];
    pose.y = in.pose.position[1];
    pose.theta = YawOf(in.pose.orientation);
    const int kPlanar[3] = {0, 1, 5};  // x, y, yaw in the 6x6 (x, y, z, roll, pitch, yaw)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) pose.cov[3 * r + c] = in.pose_covariance[6 * kPlanar[r] + kPlanar[c]];
    if (pose_order_.Accept(message.file, message.place, pose.utime))
      events_.Add(kPoseStream, PoseChannel(robot_), pose.utime, Encode(pose));
  }

  void Command(const BagMessage& message) {
    const RosTwist in = DecodeTwist(message, message.topic->type.find("TwistStamped") != std::string::npos);
    agvcal::drive_command_t command{};
    command.utime = in.stamped ? Stamp(message, in.header) : MicrosecondsOf(message.record_ns);
    command.seq = ++command_seq_;
    command.mode = agvcal::drive_command_t::MODE_TWIST;
    command.vx = in.linear[0];
    command.vy = in.linear[1];
    command.omega = in.angular[2];
    command.timeout = kCommandTimeoutS;
    if (command_order_.Accept(message.file, message.place, command.utime))
      events_.Add(kCommandStream, kDriveCmdChannel, command.utime, Encode(command));
  }

  void Transforms(const BagMessage& message) {
    auto bare = [](std::string frame) { return frame.empty() || frame[0] != '/' ? frame : frame.substr(1); };
    for (const RosTransform& t : DecodeTfMessage(message)) {
      if (bare(t.header.frame_id) != bare(ros_.base_frame)) continue;
      const auto& p = t.transform.position;
      char text[256];
      std::snprintf(text, sizeof text, "tf_static %s -> %s: x %.4f y %.4f z %.4f m, yaw %.5f rad",
                    t.header.frame_id.c_str(), t.child_frame_id.c_str(), p[0], p[1], p[2],
                    YawOf(t.transform.orientation));
      std::string note = text;
      const bool scan_frame = !scan_frame_.empty() && bare(t.child_frame_id) == bare(scan_frame_);
      if (scan_frame) summary_.scan_mount_tf = std::array<double, 3>{p[0], p[1], YawOf(t.transform.orientation)};
      if (robot_.lidar2d && scan_frame) {
        std::snprintf(text, sizeof text, " (the scan's frame; robot file lidar2d: x %.4f y %.4f yaw %.5f)",
                      robot_.lidar2d->x, robot_.lidar2d->y, robot_.lidar2d->yaw);
        note += text;
      }
      summary_.notes.push_back(note);
    }
  }

  const Bag& bag_;
  const std::string& source_;
  const RobotDescription& robot_;
  const RosTopics& ros_;
  ImportSummary summary_;
  EventBuffer events_;
  StampOrder wheels_order_{"joint_states"}, scan_order_{"scan"}, imu_order_{"imu"},
      pose_order_{"odom"}, command_order_{"cmd_vel"};
  std::vector<double> first_position_;
  std::string scan_frame_;
  std::vector<const BagMessage*> static_transforms_;
  std::vector<OdometryPose> odometry_;  // odom as wheels: converted once all are read
  int64_t skipped_joint_states_ = 0, command_seq_ = 0;
};

bool IsDirectory(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

// The storage files of a rosbag2 directory: its .mcap and .db3 files in name order.
std::vector<std::string> BagFiles(const std::string& dir) {
  std::vector<std::string> files;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (const dirent* entry = ::readdir(d)) {
      const std::string name = entry->d_name;
      auto ends = [&](const std::string& tail) {
        return name.size() > tail.size() && name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
      };
      if (ends(".mcap") || ends(".db3")) files.push_back(dir + "/" + name);
    }
    ::closedir(d);
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) throw InputError(dir, "", "a rosbag2 directory without .mcap or .db3 files");
  return files;
}

// The first bytes of a regular file.
std::string Head(const std::string& path) {
  const InputFile file = OpenInputFile(path, "rosbag2 storage file");
  char bytes[16];
  const ssize_t n = ::read(file.fd, bytes, sizeof bytes);
  ::close(file.fd);
  if (file.stream) throw InputError(path, "", "a bag must be a regular file, not a pipe");
  return std::string(bytes, n > 0 ? static_cast<size_t>(n) : 0);
}

// Reads one storage file, told by its first bytes.
void ReadRosbag2File(const std::string& path, const std::set<std::string>& wanted, Bag* bag) {
  const std::string head = Head(path);
  if (head.compare(0, 5, "\x89MCAP") == 0) return ReadMcap(path, wanted, bag);
  if (head.compare(0, 16, std::string("SQLite format 3\0", 16)) == 0)
    return ReadRosbag2Sqlite(path, wanted, bag);
  throw InputError(path, "byte 0", "neither an MCAP nor an SQLite3 file (rosbag2 storage)");
}

}  // namespace

ImportSummary ImportRosbag2(const std::string& input, const RobotDescription& robot,
                           MessageSink* sink) {
  const std::set<std::string> wanted = WantedTopics(RequireRos(robot));
  Bag bag;
  for (const auto& file : IsDirectory(input) ? BagFiles(input) : std::vector<std::string>{input})
    ReadRosbag2File(file, wanted, &bag);
  SortByRecordTime(&bag);
  return BagConverter(bag, input, robot).Convert(sink);
}

ImportSummary ImportRosbag(const std::string& path, const RobotDescription& robot, MessageSink* sink) {
  const std::set<std::string> wanted = WantedTopics(RequireRos(robot));
  Bag bag;
  ReadRosbag1(path, wanted, &bag);
  return BagConverter(bag, path, robot).Convert(sink);
}

namespace import_internal {

void SortByRecordTime(Bag* bag) {
  std::stable_sort(bag->messages.begin(), bag->messages.end(),
                   [](const BagMessage& a, const BagMessage& b) { return a.record_ns < b.record_ns; });
}

}  // namespace import_internal

}  // namespace calib
