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
  if (const auto f = map.Find("odom")) {
    if (f->value.IsMap()) {
      const CheckedMap odom(reporter, *f, {"topic", "as"}, "expected topic and as (pose or wheels)");
      ros.odom = TopicOr(reporter, odom, "topic", "/odom");
      if (const auto as = odom.Find("as")) {
        const std::string use = ReadString(reporter, *as);
        if (use != "pose" && use != "wheels")
          reporter.Fail(*as, "expected pose (an external pose source -> POSE) or wheels (the drive's own "
                             "odometry -> WHEELS), got '" + use + "'");
        ros.odom_as_wheels = use == "wheels";
      }
    } else {
      ros.odom = ReadString(reporter, *f);
    }
  }
  if (ros.odom_as_wheels && drive != DriveType::kDifferential)
    reporter.Fail(*map.Find("odom"), std::string("odom as wheels: only a differential drive's wheels follow from "
                                                 "its poses, this is a ") + DriveTypeName(drive) + " drive");
  if (ros.odom_as_wheels && !ros.joint_states.empty())
    reporter.Fail(*map.Find("odom"), "odom as wheels and joint_states both give WHEELS: keep one");
  ros.cmd_vel = TopicOr(reporter, map, "cmd_vel", "");
  ros.tf_static = TopicOr(reporter, map, "tf_static", ros.tf_static);
  ros.base_frame = TopicOr(reporter, map, "base_frame", ros.base_frame);
  return ros;
}

}  // namespace calib::yaml
