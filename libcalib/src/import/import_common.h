#pragma once
// What the importers share (importers.h): collecting events and publishing them in time
// order, the per-stream stamp rule, scan messages, robot checks. Internal to libcalib.

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "agvcal/laser_scan_t.hpp"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/import/importers.h"
#include "calib/io/text_reader.h"

namespace calib::import_internal {

// Order among messages with equal stamps.
enum Stream { kWheelsStream = 0, kScanStream = 1, kPoseStream = 2, kImuStream = 3, kCommandStream = 4 };

// Holds an import's messages until the input has been read completely, then publishes
// them sorted by (utime, stream), keeping input order otherwise.
class EventBuffer {
 public:
  void Add(Stream stream, const std::string& channel, int64_t utime, std::vector<uint8_t> data);
  void Publish(MessageSink* sink, ImportSummary* summary);

 private:
  struct Event {
    int64_t utime;
    int stream;
    std::string channel;
    std::vector<uint8_t> data;
  };
  std::vector<Event> events_;
};

// The stamp rule of importers.h for one stream: Accept() is false for a repeated stamp
// (counted in `duplicates`) and throws InputError at the reader's line (or the given file and
// place) for one going back.
class StampOrder {
 public:
  explicit StampOrder(std::string what) : what_(std::move(what)) {}
  bool Accept(const TextReader& reader, int64_t utime);
  bool Accept(const std::string& file, const std::string& place, int64_t utime);
  int64_t duplicates = 0;

 private:
  // The problem with `utime`, or "" when it goes on; counts and remembers it.
  bool Check(int64_t utime, std::string* problem);
  std::string what_;
  bool any_ = false;
  int64_t last_ = 0;
};

// Cumulative encoder ticks of a differential drive's left and right wheels -> the
// WHEELS message, positions counted from the first reading (rad).
class DifferentialTicks {
 public:
  explicit DifferentialTicks(double ticks_per_revolution)
      : rad_per_tick_(2.0 * M_PI / ticks_per_revolution) {}
  std::vector<uint8_t> Message(int64_t utime, int64_t left, int64_t right,
                               const RobotDescription& robot);

 private:
  double rad_per_tick_;
  bool first_ = true;
  int64_t left0_ = 0, right0_ = 0;
};

// A scan with the geometry given; scan_time is set by SetScanTimes.
agvcal::laser_scan_t MakeScan(int64_t utime, double angle_min, double angle_increment,
                              double range_min, double range_max, std::vector<float> ranges);

// scan_time of every scan: `period` s when the device's is known (> 0), else the median
// interval between the scans.
void SetScanTimes(std::vector<agvcal::laser_scan_t>* scans, double period);

// A pose of a differential drive's own odometry, with its body velocity when known.
struct OdometryPose {
  int64_t utime = 0;
  Pose2 pose;
  bool has_velocity = false;
  double tv = 0.0, rv = 0.0;  // m/s, rad/s
};

// The WHEELS messages a differential drive with `robot`'s nominal radii and track turns its
// wheels through from pose to pose (the arc through each pair; the arc's sideways part, which
// no differential drive can make, is lost and its size given in a note of `summary`),
// positions counted from the first pose (rad).
void AddWheelsFromOdometry(const std::vector<OdometryPose>& poses, const RobotDescription& robot,
                           EventBuffer* events, ImportSummary* summary);

// Throws InputError naming the robot file unless it describes a `drive` robot.
void RequireDrive(const RobotDescription& robot, DriveType drive, const std::string& format);

// "field N (what)" with N 1-based, for error messages.
std::string FieldName(std::size_t index, const std::string& what);

}  // namespace calib::import_internal
