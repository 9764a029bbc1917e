// Parses a URDF with Debian's liburdfdom (as ROS does) and prints a joint's origin:
//   urdf_joint_origin FILE.urdf JOINT  ->  "x y z roll pitch yaw parent child"
// Exit 1 when the file does not parse or has no such joint (tests/e2e/rosbag.sh).
#include <urdf_parser/urdf_parser.h>

#include <cstdio>
#include <fstream>
#include <sstream>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: urdf_joint_origin FILE.urdf JOINT\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  std::stringstream text;
  text << in.rdbuf();
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(text.str());
  if (!model) return 1;
  const urdf::JointConstSharedPtr joint = model->getJoint(argv[2]);
  if (!joint) return 1;
  const urdf::Pose& pose = joint->parent_to_joint_origin_transform;
  double roll = 0, pitch = 0, yaw = 0;
  pose.rotation.getRPY(roll, pitch, yaw);
  std::printf("%.17g %.17g %.17g %.17g %.17g %.17g %s %s\n", pose.position.x, pose.position.y,
              pose.position.z, roll, pitch, yaw, joint->parent_link_name.c_str(),
              joint->child_link_name.c_str());
  return 0;
}
