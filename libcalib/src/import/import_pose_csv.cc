// Generic external-pose CSV -> POSE (grammar in importers.h).
#include <cmath>
#include <cstdlib>

#include "agvcal/pose2d_t.hpp"
#include "calib/core/se2.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"

namespace calib {

namespace {

using namespace import_internal;

bool LooksNumeric(const std::string& field) {
  char* end = nullptr;
  std::strtod(field.c_str(), &end);
  return !field.empty() && end == field.c_str() + field.size();
}

bool IsInteger(const std::string& field) {
  std::size_t i = (field[0] == '-' || field[0] == '+') ? 1 : 0;
  if (i == field.size()) return false;
  for (; i < field.size(); ++i)
    if (field[i] < '0' || field[i] > '9') return false;
  return true;
}

}  // namespace

ImportSummary ImportPoseCsv(const std::string& path, const std::string& channel,
                            MessageSink* sink) {
  ImportSummary summary;
  EventBuffer events;
  StampOrder order("pose");
  int time_kind = 0;  // 1 microseconds, 2 seconds
  bool first = true;
  TextReader reader(path);
  std::string line;
  while (reader.Next(&line)) {
    const std::size_t text = line.find_first_not_of(" \t");
    if (text == std::string::npos) continue;
    if (line[text] == '#') {
      ++summary.skipped;
      continue;
    }
    const std::vector<std::string> f = SplitFields(line, ',');
    if (first && !LooksNumeric(f[0])) {  // a header
      first = false;
      ++summary.skipped;
      continue;
    }
    first = false;
    if (f.size() != 4 && f.size() != 7 && f.size() != 13)
      reader.Fail("expected time, x, y, theta and 0, 3 or 9 covariance values (4, 7 or 13 "
                  "comma-separated fields), got " + std::to_string(f.size()));
    const int kind = IsInteger(f[0]) ? 1 : 2;
    if (time_kind != 0 && kind != time_kind)
      reader.Fail(FieldName(0, "time") + ": '" + f[0] + "' is in " +
                  (kind == 1 ? "microseconds (an integer)" : "seconds (a decimal)") +
                  " but earlier lines were in " + (kind == 1 ? "seconds" : "microseconds"));
    time_kind = kind;
    agvcal::pose2d_t pose{};
    pose.utime = kind == 1 ? ParseInteger(reader, f[0], FieldName(0, "time, us"))
                           : ParseSecondsAsMicros(reader, f[0], FieldName(0, "time, s"));
    pose.x = ParseNumber(reader, f[1], FieldName(1, "x, m"));
    pose.y = ParseNumber(reader, f[2], FieldName(2, "y, m"));
    pose.theta = WrapAngle(ParseNumber(reader, f[3], FieldName(3, "theta, rad")));
    std::vector<double> cov;
    for (std::size_t k = 4; k < f.size(); ++k)
      cov.push_back(ParseNumber(reader, f[k], FieldName(k, "covariance")));
    if (cov.size() == 3) {
      pose.cov[0] = cov[0];
      pose.cov[4] = cov[1];
      pose.cov[8] = cov[2];
    } else if (cov.size() == 9) {
      for (int i = 0; i < 9; ++i) pose.cov[i] = cov[i];
      for (int r = 0; r < 3; ++r)
        for (int c = r + 1; c < 3; ++c)
          if (std::abs(pose.cov[3 * r + c] - pose.cov[3 * c + r]) >
              1e-9 * (std::abs(pose.cov[3 * r + c]) + std::abs(pose.cov[3 * c + r]) + 1e-300))
            reader.Fail("covariance is not symmetric (entries " + std::to_string(3 * r + c + 1) +
                        " and " + std::to_string(3 * c + r + 1) + ")");
    }
    for (int i : {0, 4, 8})
      if (pose.cov[i] < 0) reader.Fail("covariance has a negative variance: " + std::to_string(pose.cov[i]));
    if (!order.Accept(reader, pose.utime)) continue;
    events.Add(kPoseStream, channel, pose.utime, Encode(pose));
  }
  summary.lines = reader.line_number();
  summary.duplicates_dropped = order.duplicates;
  events.Publish(sink, &summary);
  return summary;
}

}  // namespace calib
