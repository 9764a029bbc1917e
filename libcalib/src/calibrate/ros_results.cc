#include "calib/calibrate/ros_results.h"

#include <openssl/evp.h>

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"
#include "calib/io/log_summary.h"

namespace calib {

namespace {

std::string Formatted(const char* format, double a, double b = 0.0, double c = 0.0) {
  char text[128];
  std::snprintf(text, sizeof text, format, a, b, c);
  return text;
}

std::string UtcDate(int64_t utime) {
  const std::time_t seconds = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// The lines naming the writer and the recording, each between `lead` and `tail`.
std::string Provenance(const std::string& lead, const std::string& tail, const RobotDescription& robot,
                       const ResultProvenance& source) {
  return lead + "agvcal solve: " + robot.name + " calibrated from " + source.log_path + tail + "\n" +
         lead + "recording sha256 " + source.sha256 + ", recorded " + UtcDate(source.start_utime) +
         tail + "\n";
}

// An XML comment may not hold "--" (a file name might).
std::string XmlComment(const std::string& indent, std::string text) {
  for (size_t at; (at = text.find("--")) != std::string::npos;) text.replace(at, 2, "- -");
  return indent + "<!-- " + text + " -->\n";
}

std::string XmlProvenance(const std::string& indent, const RobotDescription& robot,
                          const ResultProvenance& source) {
  std::string lines = Provenance("", "", robot, source), out;
  for (size_t at = 0, end; (end = lines.find('\n', at)) != std::string::npos; at = end + 1)
    out += XmlComment(indent, lines.substr(at, end - at));
  return out;
}

std::string BaseFrame(const RobotDescription& robot) { return robot.ros ? robot.ros->base_frame : "base_link"; }

void RequireLidarMount(const CalibrationResult& result, const std::string& option) {
  if (result.source != MotionSource::kLidar2d)
    throw InputError("command line", option,
                     "needs the 2D lidar's mount: solve from the scans (--source lidar2d)");
}

std::string Sigmas(const CalibrationResult& result) {
  return Formatted("sigma: x %.3g m, y %.3g m", result.mount_x.std, result.mount_y.std) +
         Formatted(", yaw %.3g rad; z, roll, pitch are not calibrated (the scan plane is level)",
                   result.mount_yaw.std);
}

}  // namespace

ResultProvenance RecordingProvenance(const std::string& log_path) {
  ResultProvenance source;
  source.log_path = log_path;
  source.start_utime = RecordingStartUtime(SummarizeLog(log_path));
  const InputFile file = OpenInputFile(log_path, "recording");
  const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr);
  char buffer[1 << 16];
  for (ssize_t n; (n = ::read(file.fd, buffer, sizeof buffer)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      ::close(file.fd);
      throw InputError(log_path, "", "cannot read the recording to hash it");
    }
    EVP_DigestUpdate(context.get(), buffer, static_cast<size_t>(n));
  }
  ::close(file.fd);
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  EVP_DigestFinal_ex(context.get(), digest, &size);
  for (unsigned int i = 0; i < size; ++i) {
    char hex[3];
    std::snprintf(hex, sizeof hex, "%02x", digest[i]);
    source.sha256 += hex;
  }
  return source;
}

std::string LidarUrdf(const RobotDescription& robot, const CalibrationResult& result,
                      const ResultProvenance& source, const std::string& lidar, const std::string& option) {
  RequireLidarMount(result, option);
  const std::string base = BaseFrame(robot);
  return "<?xml version=\"1.0\"?>\n" + XmlProvenance("", robot, source) + XmlComment("", Sigmas(result)) +
         "<robot name=\"" + robot.name + "\">\n"
         "  <link name=\"" + base + "\"/>\n"
         "  <link name=\"" + lidar + "\"/>\n"
         "  <joint name=\"" + lidar + "_joint\" type=\"fixed\">\n"
         "    <parent link=\"" + base + "\"/>\n"
         "    <child link=\"" + lidar + "\"/>\n" +
         Formatted("    <origin xyz=\"%.9g %.9g 0\"", result.mount_x.value, result.mount_y.value) +
         Formatted(" rpy=\"0 0 %.9g\"/>\n", result.mount_yaw.value) +
         "  </joint>\n"
         "</robot>\n";
}

std::string LidarStaticTfLaunch(const RobotDescription& robot, const CalibrationResult& result,
                                const ResultProvenance& source, const std::string& lidar,
                                const std::string& option) {
  RequireLidarMount(result, option);
  return "<launch>\n" + XmlProvenance("  ", robot, source) + XmlComment("  ", Sigmas(result)) +
         "  <node pkg=\"tf2_ros\" exec=\"static_transform_publisher\" name=\"" + lidar +
         "_static_tf\"\n        args=\"" +
         Formatted("--x %.9g --y %.9g --z 0 --roll 0 --pitch 0", result.mount_x.value, result.mount_y.value) +
         Formatted(" --yaw %.9g", result.mount_yaw.value) + " --frame-id " + BaseFrame(robot) +
         " --child-frame-id " + lidar + "\"/>\n</launch>\n";
}

std::string DriveControllerYaml(const RobotDescription& robot, const CalibrationResult& result,
                                const ResultProvenance& source, const std::string& option) {
  auto param = [&](const std::string& name) { return result.params.at(name); };
  std::string yaml = Provenance("# ", "", robot, source);
  if (result.drive == DriveType::kDifferential) {
    const Estimate left = param("left_radius"), right = param("right_radius"), track = param("track");
    const double radius = 0.5 * (left.value + right.value);
    const double radius_std = 0.5 * std::hypot(left.std, right.std);  // the two are fitted apart
    yaml += "diff_drive_controller:\n  ros__parameters:\n" +
            Formatted("    wheel_separation: %.9g  # sigma %.3g m\n", track.value, track.std) +
            Formatted("    wheel_radius: %.9g  # mean of left %.9g and right %.9g m;", radius, left.value, right.value) +
            Formatted(" sigma %.3g m\n", radius_std) +
            "    wheel_separation_multiplier: 1.0\n" +
            Formatted("    left_wheel_radius_multiplier: %.9g  # left_radius sigma %.3g m\n",
                      left.value / radius, left.std) +
            Formatted("    right_wheel_radius_multiplier: %.9g  # right_radius sigma %.3g m\n",
                      right.value / radius, right.std);
  } else if (result.drive == DriveType::kTricycle) {
    const Estimate radius = param("drive_radius"), wheelbase = param("wheelbase"), offset = param("steer_offset");
    yaml += "tricycle_controller:\n  ros__parameters:\n" +
            Formatted("    wheelbase: %.9g  # sigma %.3g m\n", wheelbase.value, wheelbase.std) +
            Formatted("    wheel_radius: %.9g  # sigma %.3g m\n", radius.value, radius.std) +
            Formatted("# steering offset %.9g rad (sigma %.3g rad): the raw steering reading with the wheel\n",
                      offset.value, offset.std) +
            "# along x; tricycle_controller has no parameter for it: subtract it in the steering joint's\n"
            "# hardware interface (or its transmission's offset)\n";
  } else {
    throw InputError("command line", option,
                     "no ros2_control controller takes a dual steer drive's parameters (docs/ros.md)");
  }
  return yaml;
}

}  // namespace calib
