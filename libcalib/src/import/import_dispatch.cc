// `agvcal import FORMAT INPUT`: the format table (importers.h).
#include "calib/core/errors.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"

namespace calib {

namespace {

// Bundled robot file of each dataset, for the hint when --robot is missing.
const char* RobotHint(const std::string& format) {
  if (format == "carmen") return "config/robots/datasets/mit_csail.yaml";
  if (format == "mines") return "config/robots/datasets/mines_rover.yaml";
  if (format == "lego") return "config/robots/datasets/lego_robot.yaml";
  if (format == "rosbag2" || format == "rosbag") return "ROBOT.yaml with a ros: block (docs/ros.md)";
  return "config/robots/datasets/optiodom_tricycle.yaml or optiodom_diff.yaml";
}

}  // namespace

const std::vector<std::string>& ImportFormats() {
  static const std::vector<std::string> kFormats{"carmen", "mines",    "lego",   "optiodom",
                                                    "pose-csv", "rosbag2", "rosbag"};
  return kFormats;
}

bool ImportNeedsRobot(const std::string& format) { return format != "pose-csv"; }

ImportSummary Import(const std::string& format, const std::string& input,
                     const RobotDescription* robot, MessageSink* sink) {
  bool known = false;
  for (const auto& name : ImportFormats()) known = known || name == format;
  if (!known) {
    std::string list;
    for (const auto& name : ImportFormats()) list += (list.empty() ? "" : ", ") + name;
    throw InputError("command line", "FORMAT", "unknown format '" + format + "' (known: " + list + ")");
  }
  if (ImportNeedsRobot(format) && !robot)
    throw InputError("command line", "--robot",
                     "format " + format + " needs the robot file (nominal values and wheel "
                     "names), e.g. --robot " + RobotHint(format));
  if (format == "carmen") return ImportCarmen(input, *robot, sink);
  if (format == "mines") return ImportMines(input, *robot, sink);
  if (format == "lego") return ImportLego(input, LegoScanPathFor(input), *robot, sink);
  if (format == "optiodom") return ImportOptiOdom(input, *robot, sink);
  if (format == "rosbag2") return ImportRosbag2(input, *robot, sink);
  if (format == "rosbag") return ImportRosbag(input, *robot, sink);
  return ImportPoseCsv(input, robot ? PoseChannel(*robot) : "POSE", sink);
}

}  // namespace calib
