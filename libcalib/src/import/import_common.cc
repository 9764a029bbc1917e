#include "import/import_common.h"

#include <algorithm>
#include <sstream>

#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/wheel_track.h"
#include "calib/io/messages.h"

namespace calib::import_internal {

void EventBuffer::Add(Stream stream, const std::string& channel, int64_t utime,
                      std::vector<uint8_t> data) {
  events_.push_back({utime, stream, channel, std::move(data)});
}

void EventBuffer::Publish(MessageSink* sink, ImportSummary* summary) {
  std::stable_sort(events_.begin(), events_.end(), [](const Event& a, const Event& b) {
    return a.utime != b.utime ? a.utime < b.utime : a.stream < b.stream;
  });
  for (const Event& e : events_) {
    sink->Publish(e.channel, e.utime, e.data);
    ++summary->messages[e.channel];
  }
  if (!events_.empty()) {
    summary->first_utime = events_.front().utime;
    summary->last_utime = events_.back().utime;
  }
  events_.clear();
}

bool StampOrder::Check(int64_t utime, std::string* problem) {
  if (any_ && utime < last_) {
    *problem = what_ + " stamp " + std::to_string(utime) + " us goes back from " +
               std::to_string(last_) + " us";
    return false;
  }
  if (any_ && utime == last_) {
    ++duplicates;
    return false;
  }
  any_ = true;
  last_ = utime;
  return true;
}

bool StampOrder::Accept(const TextReader& reader, int64_t utime) {
  std::string problem;
  const bool accepted = Check(utime, &problem);
  if (!problem.empty()) reader.Fail(problem + " on an earlier line (records out of time order)");
  return accepted;
}

bool StampOrder::Accept(const std::string& file, const std::string& place, int64_t utime) {
  std::string problem;
  const bool accepted = Check(utime, &problem);
  if (!problem.empty())
    throw InputError(file, place, problem + " in an earlier record (records out of time order; "
                                            "ros: stamps: record uses the bag's record times)");
  return accepted;
}

agvcal::laser_scan_t MakeScan(int64_t utime, double angle_min, double angle_increment,
                              double range_min, double range_max, std::vector<float> ranges) {
  agvcal::laser_scan_t scan{};
  scan.utime = utime;
  scan.angle_min = static_cast<float>(angle_min);
  scan.angle_increment = static_cast<float>(angle_increment);
  scan.time_increment = 0.0f;  // none of the datasets reports per-beam timing
  scan.scan_time = 0.0f;
  scan.range_min = static_cast<float>(range_min);
  scan.range_max = static_cast<float>(range_max);
  scan.nranges = static_cast<int32_t>(ranges.size());
  scan.ranges = std::move(ranges);
  scan.nintensities = 0;
  return scan;
}

void SetScanTimes(std::vector<agvcal::laser_scan_t>* scans, double period) {
  if (period <= 0.0 && scans->size() >= 2) {
    std::vector<int64_t> gaps;
    for (std::size_t i = 1; i < scans->size(); ++i)
      gaps.push_back((*scans)[i].utime - (*scans)[i - 1].utime);
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    period = gaps[gaps.size() / 2] * 1e-6;
  }
  for (auto& scan : *scans) scan.scan_time = static_cast<float>(std::max(period, 0.0));
}

void RequireDrive(const RobotDescription& robot, DriveType drive, const std::string& format) {
  if (robot.drive != drive) {
    throw InputError(robot.source_file, "drive",
                     format + " data import as a " + DriveTypeName(drive) +
                         " drive, but the robot file describes a " + DriveTypeName(robot.drive) +
                         " drive");
  }
}

std::string FieldName(std::size_t index, const std::string& what) {
  return "field " + std::to_string(index + 1) + " (" + what + ")";
}

std::vector<uint8_t> DifferentialTicks::Message(int64_t utime, int64_t left, int64_t right,
                                                const RobotDescription& robot) {
  if (first_) {
    left0_ = left;
    right0_ = right;
    first_ = false;
  }
  WheelSample sample;
  sample.utime = utime;
  sample.position = {double(left - left0_) * rad_per_tick_, double(right - right0_) * rad_per_tick_};
  sample.steer = {0.0, 0.0};
  return Encode(WheelStateMessage(sample, robot));
}

void AddWheelsFromOdometry(const std::vector<OdometryPose>& poses, const RobotDescription& robot,
                           EventBuffer* events, ImportSummary* summary) {
  const auto model = MakeDriveModel(robot);
  WheelSample sample;
  sample.position.assign(2, 0.0);
  sample.steer.assign(2, 0.0);
  double max_sideways = 0.0, sum_sideways2 = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (i > 0) {
      // The arc through both poses; its sideways part vy cannot be driven and is lost.
      const Twist2 arc = LogTwist(Between(poses[i - 1].pose, poses[i].pose), 1.0);
      const WheelSetpoint rotation = model->Inverse(arc);
      for (int w = 0; w < 2; ++w) sample.position[w] += rotation.speed[w];
      max_sideways = std::max(max_sideways, std::abs(arc.vy));
      sum_sideways2 += arc.vy * arc.vy;
    }
    sample.utime = poses[i].utime;
    std::vector<double> velocity;
    if (poses[i].has_velocity) velocity = model->Inverse({poses[i].tv, 0.0, poses[i].rv}).speed;
    events->Add(kWheelsStream, kWheelsChannel, sample.utime, Encode(WheelStateMessage(sample, robot, velocity)));
  }
  if (poses.size() > 1) {
    std::ostringstream note;
    note << "odometry steps hold a sideways part no differential drive can make (lost): largest "
         << max_sideways << " m, rms " << std::sqrt(sum_sideways2 / (poses.size() - 1)) << " m";
    summary->notes.push_back(note.str());
  }
}

}  // namespace calib::import_internal
