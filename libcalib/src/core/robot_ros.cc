#include "core/robot_ros.h"

#include <algorithm>
#include <set>

namespace calib::yaml {

namespace {

// Every wheel of a tricycle or dual steer drive steers, none of a differential drive.
bool Steers(DriveType drive) { return drive != DriveType::kDifferential; }

// role -> joint, roles of the drive only; `steering` limits them to steered wheels.
std::map<std::string, std::string> ReadJoints(const Reporter& reporter, const Field& field,
                                              DriveType drive, bool steering,
                                              std::set<std::string>* used) {
  std::vector<std::string> roles;
  for (const auto& role : WheelRoles(drive))
    if (!steering || Steers(drive)) roles.push_back(role);
  const std::string hint = roles.empty()
                               ? std::string("a ") + DriveTypeName(drive) + " drive has no steered wheel"
                               : std::string("wheel roles of a ") + DriveTypeName(drive) +
                                     " drive are " + Join(roles);
  const CheckedMap map(reporter, field, roles, hint);
  std::map<std::string, std::string> joints;
  for (const auto& role : roles) {
    const Field joint = steering ? map.Find(role).value_or(Field{}) : map.Get(role, hint);
    if (!joint.value) continue;
    const std::string name = ReadString(reporter, joint);
    if (!used->insert(name).second) reporter.Fail(joint, "joint '" + name + "' is named twice");
    joints[role] = name;
  }
  return joints;
}

std::string TopicOr(const Reporter& reporter, const CheckedMap& map, const std::string& key,
                    const std::string& fallback) {
  const auto field = map.Find(key);
  return field ? ReadString(reporter, *field) : fallback;
}

}  // namespace

RosTopics ReadRosTopics(const Reporter& reporter, const Field& field, DriveType drive) {
  static const std::vector<std::string> kKeys{"stamps", "joint_states", "scan",     "imu",
                                              "odom",   "cmd_vel",      "tf_static", "base_frame"};
  const CheckedMap map(reporter, field, kKeys, "expected " + Join(kKeys));
  RosTopics ros;
  if (const auto f = map.Find("stamps")) {
    const std::string stamps = ReadString(reporter, *f);
    if (stamps != "header" && stamps != "record")
      reporter.Fail(*f, "expected header (the messages' header stamps) or record (the bag's "
                        "record times), got '" + stamps + "'");
    ros.header_stamps = stamps == "header";
  }
  if (const auto f = map.Find("joint_states")) {
    const CheckedMap joints(reporter, *f, {"topic", "wheels", "steering"},
                            "expected topic, wheels (role -> joint) and steering (role -> joint)");
    std::set<std::string> used;
    ros.joint_states = TopicOr(reporter, joints, "topic", "/joint_states");
    ros.wheel_joints = ReadJoints(reporter, joints.Get("wheels", "wheel role -> joint name"), drive,
                                  false, &used);
    if (const auto s = joints.Find("steering"))
      ros.steering_joints = ReadJoints(reporter, *s, drive, true, &used);
  }
  ros.scan = TopicOr(reporter, map, "scan", "");
  ros.imu = TopicOr(reporter, map, "imu", "");
  ros.odom = TopicOr(reporter, map, "odom", "");
  ros.cmd_vel = TopicOr(reporter, map, "cmd_vel", "");
  ros.tf_static = TopicOr(reporter, map, "tf_static", ros.tf_static);
  ros.base_frame = TopicOr(reporter, map, "base_frame", ros.base_frame);
  return ros;
}

}  // namespace calib::yaml
