#include "calib/io/ros_files.h"

#include <openssl/evp.h>

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <ctime>
#include <memory>
#include <utility>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"
#include "calib/io/cloud_file.h"
#include "calib/io/log_summary.h"

namespace calib {

namespace {

std::string Sha256Hex(const std::string& path) {
  const InputFile file = OpenInputFile(path, "recording");
  const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr);
  char buffer[1 << 16];
  for (ssize_t n; (n = ::read(file.fd, buffer, sizeof buffer)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      ::close(file.fd);
      throw InputError(path, "", "cannot read the recording to hash it");
    }
    EVP_DigestUpdate(context.get(), buffer, static_cast<size_t>(n));
  }
  ::close(file.fd);
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  EVP_DigestFinal_ex(context.get(), digest, &size);
  std::string hex;
  for (unsigned int i = 0; i < size; ++i) {
    char text[3];
    std::snprintf(text, sizeof text, "%02x", digest[i]);
    hex += text;
  }
  return hex;
}

std::string UtcDate(int64_t utime) {
  const std::time_t seconds = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// An XML comment may not hold "--" (a file name might).
std::string XmlComment(const std::string& indent, std::string text) {
  for (size_t at; (at = text.find("--")) != std::string::npos;) text.replace(at, 2, "- -");
  return indent + "<!-- " + text + " -->\n";
}

// Every line of `lines` as an XML comment.
std::string XmlComments(const std::string& indent, const std::string& lines) {
  std::string out;
  for (size_t at = 0, end; (end = lines.find('\n', at)) != std::string::npos; at = end + 1)
    out += XmlComment(indent, lines.substr(at, end - at));
  return out;
}

using Coordinates = std::vector<std::pair<const char*, const RosCoordinate*>>;
Coordinates AllCoordinates(const RosMount& m) {
  return {{"x", &m.x}, {"y", &m.y}, {"z", &m.z}, {"roll", &m.roll}, {"pitch", &m.pitch}, {"yaw", &m.yaw}};
}
bool IsLength(const std::string& name) { return name == "x" || name == "y" || name == "z"; }

// "sigma: x 0.0186 m, y 0.0333 m, yaw 0.00826 rad; z, roll, pitch: <uncalibrated>"
std::string SigmaLine(const RosMount& mount) {
  std::string calibrated, others;
  for (const auto& [name, c] : AllCoordinates(mount)) {
    if (c->sigma) {
      calibrated += (calibrated.empty() ? "" : ", ") + std::string(name) +
                    Formatted(IsLength(name) ? " %.3g m" : " %.3g rad", *c->sigma);
    } else {
      others += (others.empty() ? "" : ", ") + std::string(name);
    }
  }
  return "sigma: " + calibrated + (others.empty() ? "" : "; " + others + ": " + mount.uncalibrated) + "\n";
}

}  // namespace

std::string Formatted(const char* format, double a, double b, double c) {
  char text[160];
  std::snprintf(text, sizeof text, format, a, b, c);
  return text;
}

ResultProvenance RecordingProvenance(const std::string& log_path, const std::string& command) {
  ResultProvenance source;
  source.command = command;
  source.log_path = log_path;
  if (!IsCloudFileName(log_path)) source.start_utime = RecordingStartUtime(SummarizeLog(log_path));
  source.sha256 = Sha256Hex(log_path);
  return source;
}

std::string ProvenanceLines(const std::string& lead, const std::string& robot_name, const ResultProvenance& source) {
  return lead + source.command + ": " + robot_name + " calibrated from " + source.log_path + "\n" + lead +
         "recording sha256 " + source.sha256 +
         (source.start_utime ? ", recorded " + UtcDate(*source.start_utime) : std::string(", no recording date")) +
         "\n" + (source.note.empty() ? "" : lead + source.note + "\n");
}

std::string RosBaseFrame(const RobotDescription& robot) { return robot.ros ? robot.ros->base_frame : "base_link"; }

std::string MountUrdf(const RosMount& m, const ResultProvenance& source) {
  return "<?xml version=\"1.0\"?>\n" + XmlComments("", ProvenanceLines("", m.robot_name, source) + SigmaLine(m)) +
         "<robot name=\"" + m.robot_name + "\">\n"
         "  <link name=\"" + m.parent + "\"/>\n"
         "  <link name=\"" + m.child + "\"/>\n"
         "  <joint name=\"" + m.child + "_joint\" type=\"fixed\">\n"
         "    <parent link=\"" + m.parent + "\"/>\n"
         "    <child link=\"" + m.child + "\"/>\n" +
         Formatted("    <origin xyz=\"%.9g %.9g %.9g\"", m.x.value, m.y.value, m.z.value) +
         Formatted(" rpy=\"%.9g %.9g %.9g\"/>\n", m.roll.value, m.pitch.value, m.yaw.value) +
         "  </joint>\n"
         "</robot>\n";
}

std::string MountStaticTfLaunch(const RosMount& m, const ResultProvenance& source) {
  return "<launch>\n" + XmlComments("  ", ProvenanceLines("", m.robot_name, source) + SigmaLine(m)) +
         "  <node pkg=\"tf2_ros\" exec=\"static_transform_publisher\" name=\"" + m.child +
         "_static_tf\"\n        args=\"" + Formatted("--x %.9g --y %.9g --z %.9g", m.x.value, m.y.value, m.z.value) +
         Formatted(" --roll %.9g --pitch %.9g --yaw %.9g", m.roll.value, m.pitch.value, m.yaw.value) +
         " --frame-id " + m.parent + " --child-frame-id " + m.child + "\"/>\n</launch>\n";
}

std::string MountAutowareYaml(const RosMount& m, const ResultProvenance& source) {
  std::string yaml = ProvenanceLines("# ", m.robot_name, source) + m.parent + ":\n  " + m.child + ":\n";
  for (const auto& [name, c] : AllCoordinates(m)) {
    yaml += "    " + std::string(name) + Formatted(": %.9g", c->value);
    yaml += c->sigma ? Formatted(IsLength(name) ? "  # sigma %.3g m\n" : "  # sigma %.3g rad\n", *c->sigma)
                     : "  # " + m.uncalibrated + "\n";
  }
  return yaml;
}

}  // namespace calib
