#pragma once
// Importers: datasets recorded elsewhere -> the messages of spec/messages.md, so that
// real data go through the same calibration path as live recordings (`agvcal import`,
// spec/cli.md; each dataset, its robot file and what was assumed: docs/datasets.md).
//
// Contract shared by every importer:
// - Input: a path, plain text or gzip (told from the content). The robot description
//   gives the wheel names, the nominal values used to convert what the input holds into
//   wheel rotations, and the channels (lidar2d.channel, pose.channel; default SCAN, POSE).
// - Output: WHEELS (wheel_state_t), SCAN (laser_scan_t) and POSE (pose2d_t) published into
//   the sink in time order (equal stamps: WHEELS, then SCAN, then POSE), stamped with the
//   input's own clock in microseconds. Wheel positions start at 0 at the first sample.
//   A range with no return is +inf (the device's max-range code) or kept below range_min
//   (error codes such as 0), as spec/messages.md allows.
// - Stamps: within one stream (the odometry lines, the laser lines, ...), a record whose
//   stamp equals its predecessor's is dropped and counted (real logs repeat records:
//   docs/datasets.md); a stamp that goes backwards is refused.
// - Bad input (unknown record, wrong field count, a field that is not a finite number, a
//   stamp going backwards, a truncated or corrupt .gz, a robot file of the wrong drive
//   type) throws InputError naming the file, "line N" and the problem. The whole input is
//   converted before the first message is published, so nothing is published on error;
//   the input is held in memory (the datasets are a few MB).

#include <cstdint>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calib/core/robot.h"
#include "calib/io/recording.h"

namespace calib {

struct ImportSummary {
  std::map<std::string, int64_t> messages;  // channel -> messages published
  int64_t first_utime = 0, last_utime = 0;  // span of the published messages, us
  int64_t lines = 0;                        // input lines read, every file
  int64_t duplicates_dropped = 0;           // records dropped for repeating their stamp
  int64_t skipped = 0;                      // lines left out on purpose (comments, other records)
  std::vector<std::string> notes;           // what the user should know, one sentence each
  // ROS bags: tf_static's transform from the base frame to the scan's frame (x, y m, yaw rad;
  // z, roll, pitch left out: the 2D lidar's nominal mount), when the bag has it.
  std::optional<std::array<double, 3>> scan_mount_tf;
};

// CARMEN log (.clf / .log). Front laser lines (FLASER, or RAWLASER1 when present) -> SCAN
// at their ipc_timestamp: FLASER 181/180/361/401 beams = 180/180/180/100 deg centred on x,
// readings >= 81.9 m (SICK max) = no return; RAWLASER carries its own geometry and max
// range. Odometry (ODOM lines, or when the log has none the odometry fields of the FLASER
// lines) -> WHEELS of a differential drive: each increment between consecutive poses is
// the arc LogTwist() fits, turned into left/right rotations by the robot's nominal radii
// and track (DriveModel::Inverse), so integrating WHEELS with the nominal model gives back
// the arc length and heading change of every increment exactly; the sideways part no
// arc can hold is lost (its largest value is reported in the notes). ODOM's tv/rv give the
// wheel velocities. Other record types (PARAM, SYNC, RLASER, RAWLASER2-4, ...) are skipped
// and counted. Needs a differential robot.
ImportSummary ImportCarmen(const std::string& path, const RobotDescription& robot,
                           MessageSink* sink);

// Mines rover log (CoreSLAM / BreezySLAM exp*.dat): 707 fields per line:
// t_us, ?, left_ticks, right_ticks, 20 unused, 682 ranges (mm, 0 = no return), 1 ignored.
// Cumulative ticks -> positions at 2000 ticks per wheel revolution; ranges -> m, 682 beams
// over 240 deg from -120 deg counterclockwise, range [0.02, 4.0] m, scan_time 0.1 s.
// Needs a differential robot.
ImportSummary ImportMines(const std::string& path, const RobotDescription& robot,
                          MessageSink* sink);

// Brenner's Lego robot: motor file (`M t_ms pos tacho accel speed` x 3 motors; left pos =
// field 3, right = field 7, absolute ticks, 360 ticks per revolution) -> WHEELS; scan file
// (`S t_ms 660 d0..d659`, mm) -> SCAN in the scanner's own frame: beam i at
// (i - 330) * 0.006135923151543 rad; the -4 deg mounting angle is the robot file's
// lidar2d.yaw, not folded into the scan. Readings <= 20 mm are invalid (range_min 0.02).
// The reference file (positions without heading) is not imported: see ReadLegoReference.
// Needs a differential robot.
ImportSummary ImportLego(const std::string& motors_path, const std::string& scan_path,
                         const RobotDescription& robot, MessageSink* sink);

// The scan file beside a Lego motor file: "motors" -> "scan" in the file name, plain or
// .gz. Throws InputError naming the names tried when there is none.
std::string LegoScanPathFor(const std::string& motors_path);

// OptiOdom run (`<id>_run-NN.csv`, 20 Hz, synchronised): `t, x_gt, y_gt, th_gt, a, b` with
// a, b = odoR, odoL (differential) or odoWh, ThWh (tricycle): encoder ticks counted over
// the interval that ends at the row, and the steering angle in rad (OptiOdom README;
// quantised to pi/400). The metadata file beside it (`<id>_metadata.csv`) gives the drive
// type, which must match the robot file's, and encRes * ngear = ticks per wheel
// revolution. Ticks are accumulated into positions (the first row's ticks are motion
// before the run and ignored, as OptiOdom does); ThWh -> steer unchanged (OptiOdom's
// ThOff adds to the reading, ours subtracts: steer_offset = -Thi). The OptiTrack pose of
// the robot's reference point -> POSE (theta wrapped, cov zero).
ImportSummary ImportOptiOdom(const std::string& run_path, const RobotDescription& robot,
                             MessageSink* sink);

// Generic external poses -> POSE on `channel`. Grammar (one pose per line):
//   time, x, y, theta [, cov]
// comma-separated, spaces around fields allowed; blank lines and lines starting with '#'
// are skipped; the first line may be a header (skipped when its first field is not a
// number). time: an integer = microseconds, a decimal or exponent form = seconds (one
// kind per file). x, y in m, theta in rad (wrapped). cov: none (all zero), 3 values
// (variances of x, y, theta) or 9 values (3x3 row-major, symmetric, variances >= 0).
ImportSummary ImportPoseCsv(const std::string& path, const std::string& channel,
                            MessageSink* sink);

// ROS 2 bag (docs/ros.md): INPUT = a bag directory (its .mcap and .db3 files in name order),
// an MCAP file or a rosbag2 SQLite3 file. The robot file's ros: block names the topics:
// joint_states (sensor_msgs/JointState: the wheel joints' positions and velocities, the
// steering joints' positions) -> WHEELS; scan (sensor_msgs/LaserScan, time_increment kept)
// -> lidar2d.channel; imu (sensor_msgs/Imu) -> imu.channel; odom (nav_msgs/Odometry, an
// external pose) -> pose.channel; cmd_vel (geometry_msgs/Twist or TwistStamped) -> DRIVE_CMD;
// tf_static (tf2_msgs/TFMessage): the base frame's transforms, in the notes. Stamps: the
// messages' header stamps (ros.stamps: record: the bag's record times; Twist has no header).
// A configured topic missing from the bag or of another type, a corrupt or truncated record,
// an unknown compression or encoding throws InputError naming the file and the record.
ImportSummary ImportRosbag2(const std::string& input, const RobotDescription& robot,
                           MessageSink* sink);

// ROS 1 bag (.bag), read through rosbag_storage; otherwise as ImportRosbag2.
ImportSummary ImportRosbag(const std::string& path, const RobotDescription& robot, MessageSink* sink);

// For `agvcal import`: the format names, whether a format needs a robot file, and the
// dispatch (INPUT = the file named by each format above; lego: the motor file). Throws
// InputError for an unknown format or a missing robot.
const std::vector<std::string>& ImportFormats();
bool ImportNeedsRobot(const std::string& format);
ImportSummary Import(const std::string& format, const std::string& input,
                     const RobotDescription* robot, MessageSink* sink);

// A position without heading from an external tracker (the Lego reference file:
// `P t_ms x_mm y_mm`), m. Kept out of recordings since POSE needs a heading; for
// evaluation only.
struct ReferencePosition {
  int64_t utime = 0;
  double x = 0.0, y = 0.0;
};
std::vector<ReferencePosition> ReadLegoReference(const std::string& path);

}  // namespace calib
