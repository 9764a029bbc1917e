#include "calib/devices/sick_cola.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "calib/core/errors.h"
#include "calib/io/text_reader.h"
#include "devices/bridge_config.h"

namespace calib {

namespace {

// Reads the space-separated hex fields of a telegram, naming the field on error.
class FieldCursor {
 public:
  FieldCursor(const std::string& text, const std::string& origin, int64_t number)
      : fields_(SplitFields(text)), origin_(origin), number_(number) {}

  const std::string& Text(const std::string& name) {
    if (index_ >= fields_.size())
      Fail(name, "missing: the telegram ends after " + std::to_string(fields_.size()) + " fields");
    return fields_[index_++];
  }
  uint64_t Hex(const std::string& name, int max_digits) {
    const std::string& text = Text(name);
    uint64_t v = 0;
    bool ok = !text.empty() && int(text.size()) <= max_digits;
    for (char c : text) {
      int d = -1;
      if (c >= '0' && c <= '9') d = c - '0';
      else if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
      else if (c >= 'a' && c <= 'f') d = c - 'a' + 10;
      if (d < 0) ok = false;
      v = v * 16 + uint64_t(d < 0 ? 0 : d);
    }
    if (!ok)
      Fail(name, "expected at most " + std::to_string(max_digits) + " hex digits, got '" +
                     text.substr(0, 40) + "'");
    return v;
  }
  float Real(const std::string& name) {
    const uint32_t bits = uint32_t(Hex(name, 8));
    float v;
    std::memcpy(&v, &bits, sizeof v);
    if (!std::isfinite(v)) Fail(name, "not a finite number");
    return v;
  }
  bool AtEnd() const { return index_ >= fields_.size(); }
  [[noreturn]] void Fail(const std::string& name, const std::string& problem) const {
    throw InputError(origin_,
                     "telegram " + std::to_string(number_) + ", field " + std::to_string(index_) +
                         " (" + name + ")",
                     problem);
  }

 private:
  std::vector<std::string> fields_;
  std::string origin_;
  int64_t number_;
  std::size_t index_ = 0;
};

std::string HexText(uint64_t v) {
  char buffer[24];
  std::snprintf(buffer, sizeof buffer, "%llX", static_cast<unsigned long long>(v));
  return buffer;
}

std::string RealText(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "%08X", bits);
  return buffer;
}

}  // namespace

bool IsLmdScandata(const std::string& telegram) {
  return telegram.rfind("sSN LMDscandata ", 0) == 0 || telegram.rfind("sRA LMDscandata ", 0) == 0;
}

SickScan ParseLmdScandata(const std::string& telegram, const std::string& origin, int64_t number) {
  FieldCursor f(telegram, origin, number);
  SickScan s;
  s.command = f.Text("command type");
  if (s.command != "sSN" && s.command != "sRA")
    f.Fail("command type", "expected sSN or sRA, got '" + s.command.substr(0, 20) + "'");
  const std::string& name = f.Text("command");
  if (name != "LMDscandata") f.Fail("command", "expected LMDscandata, got '" + name.substr(0, 40) + "'");
  s.version = int(f.Hex("version number", 4));
  s.device_number = int(f.Hex("device number", 4));
  s.serial_number = uint32_t(f.Hex("serial number", 8));
  f.Hex("device status", 2);
  f.Hex("device status", 2);
  s.telegram_counter = int(f.Hex("telegram counter", 4));
  s.scan_counter = int(f.Hex("scan counter", 4));
  s.time_since_startup_us = uint32_t(f.Hex("time since start up", 8));
  s.time_of_transmission_us = uint32_t(f.Hex("time of transmission", 8));
  for (const char* n : {"input status", "input status", "output status", "output status"}) f.Hex(n, 2);
  f.Hex("reserved", 4);
  s.scan_frequency = uint32_t(f.Hex("scan frequency", 8));
  s.measurement_frequency = uint32_t(f.Hex("measurement frequency", 8));
  const int encoders = int(f.Hex("number of encoders", 4));
  for (int i = 0; i < encoders; ++i) {
    f.Hex("encoder position", 8);
    f.Hex("encoder speed", 4);
  }
  bool have_dist = false;
  for (int bits : {16, 8}) {
    const std::string kind = std::to_string(bits) + "-bit";
    const int channels = int(f.Hex("number of " + kind + " channels", 4));
    for (int c = 0; c < channels; ++c) {
      const std::string content = f.Text(kind + " channel content");
      const float scale = f.Real(content + " scale factor");
      const float offset = f.Real(content + " scale offset");
      const int32_t start = int32_t(uint32_t(f.Hex(content + " start angle", 8)));
      const uint32_t step = uint32_t(f.Hex(content + " angular step", 4));
      const int count = int(f.Hex(content + " number of data", 4));
      std::vector<uint32_t> data(count);
      for (int i = 0; i < count; ++i) data[i] = uint32_t(f.Hex(content + " data", bits / 4));
      if (content == "DIST1") {
        if (have_dist) f.Fail(content, "a second DIST1 channel");
        have_dist = true;
        s.dist_scale = scale;
        s.dist_offset = offset;
        s.start_angle = start;
        s.angular_step = step;
        s.distances = std::move(data);
      } else if (content == "RSSI1") {
        s.rssi = std::move(data);
      }
    }
  }
  if (!have_dist) f.Fail("channels", "no DIST1 channel: the scan has no distances");
  // Trailing blocks (position, name, comment, time, event) are not needed.
  return s;
}

std::string FormatLmdScandata(const SickScan& s) {
  std::string t = s.command + " LMDscandata";
  auto add = [&t](const std::string& field) { t += " " + field; };
  add(HexText(s.version));
  add(HexText(s.device_number));
  add(HexText(s.serial_number));
  add("0 0");
  add(HexText(s.telegram_counter));
  add(HexText(s.scan_counter));
  add(HexText(s.time_since_startup_us));
  add(HexText(s.time_of_transmission_us));
  add("0 0 0 0 0");
  add(HexText(s.scan_frequency));
  add(HexText(s.measurement_frequency));
  add("0");  // encoders
  auto channel = [&](const std::string& content, const std::vector<uint32_t>& data, float scale) {
    add(content);
    add(RealText(scale));
    add(RealText(content == "DIST1" ? s.dist_offset : 0.0f));
    add(HexText(uint32_t(s.start_angle)));
    add(HexText(s.angular_step));
    add(HexText(data.size()));
    for (uint32_t v : data) add(HexText(v));
  };
  add(s.rssi.empty() ? "1" : "2");
  channel("DIST1", s.distances, s.dist_scale);
  if (!s.rssi.empty()) channel("RSSI1", s.rssi, 1.0f);
  add("0");  // 8-bit channels
  add("0 0 0 0 0");  // position, name, comment, time, event
  return t;
}

SickScan SickScanFromMessage(const agvcal::laser_scan_t& scan, double angle_offset_deg) {
  SickScan s;
  s.start_angle = int32_t(std::lround((scan.angle_min * 180.0 / M_PI - angle_offset_deg) * 1e4));
  s.angular_step = uint32_t(std::lround(std::abs(scan.angle_increment) * 180.0 / M_PI * 1e4));
  s.scan_frequency = scan.scan_time > 0 ? uint32_t(std::lround(100.0 / scan.scan_time)) : 0;
  s.measurement_frequency = scan.time_increment > 0 ? uint32_t(std::lround(0.01 / scan.time_increment)) : 0;
  for (int i = 0; i < scan.nranges; ++i) {
    const float r = scan.ranges[i];
    const bool hit = std::isfinite(r) && r >= scan.range_min && r <= scan.range_max;
    s.distances.push_back(hit ? uint32_t(std::clamp<long>(std::lround(r * 1000.0), 1, 65535)) : 0);
  }
  return s;
}

void StxEtxFramer::Append(const char* data, std::size_t size) { buffer_.append(data, size); }

bool StxEtxFramer::Next(std::string* telegram) {
  for (;;) {
    const std::size_t stx = buffer_.find(kStx);
    if (stx == std::string::npos) {
      dropped_ += int64_t(buffer_.size());
      buffer_.clear();
      return false;
    }
    if (stx > 0) {
      dropped_ += int64_t(stx);
      buffer_.erase(0, stx);
    }
    const std::size_t etx = buffer_.find(kEtx, 1);
    const std::size_t next_stx = buffer_.find(kStx, 1);
    if (next_stx != std::string::npos && (etx == std::string::npos || next_stx < etx)) {
      dropped_ += int64_t(next_stx);  // a frame cut short by the next one
      buffer_.erase(0, next_stx);
      continue;
    }
    if (etx == std::string::npos) {
      if (buffer_.size() > max_bytes_) {
        dropped_ += int64_t(buffer_.size());
        buffer_.clear();
      }
      return false;
    }
    telegram->assign(buffer_, 1, etx - 1);
    buffer_.erase(0, etx + 1);
    return true;
  }
}

SickBridgeConfig ParseSickBridgeConfig(const std::string& yaml_text, const std::string& origin) {
  const yaml::Reporter reporter(origin);
  const yaml::Field root = yaml::ParseSingleDocument(reporter, yaml_text, "lidar bridge config");
  const yaml::CheckedMap top(reporter, root,
                             {"protocol", "channel", "angle_offset_deg", "range_min", "range_max",
                              "first_beam_offset_s", "clock"});
  SickBridgeConfig config;
  config.source_file = origin;
  const yaml::Field protocol = top.Get("protocol", "sick_cola_a");
  if (yaml::ReadString(reporter, protocol) != "sick_cola_a")
    reporter.Fail(protocol, "unsupported protocol " + yaml::Describe(protocol.value) + " (supported: sick_cola_a)");
  if (const auto c = top.Find("channel")) config.channel = yaml::ReadString(reporter, *c);
  config.angle_offset_deg = yaml::NumberOr(reporter, top, "angle_offset_deg", config.angle_offset_deg);
  if (const auto r = top.Find("range_min")) config.range_min = yaml::ReadNumber(reporter, *r);
  if (const auto r = top.Find("range_max")) config.range_max = yaml::ReadPositive(reporter, *r);
  if (config.range_min < 0 || config.range_min >= config.range_max)
    reporter.Fail(top.line(), "range_min", "must be >= 0 and below range_max");
  config.first_beam_offset_s = yaml::NumberOr(reporter, top, "first_beam_offset_s", 0.0);
  bridge_internal::ReadClockOptions(reporter, top, &config.clock);
  return config;
}

SickBridgeConfig LoadSickBridgeConfig(const std::string& path) {
  return ParseSickBridgeConfig(yaml::ReadTextFile(path, "lidar bridge config"), path);
}

void SickScanDecoder::Reset() {
  clock_ = DeviceClock(config_.clock);
  transmission_.Reset();
  last_scan_counter_ = -1;
}

agvcal::laser_scan_t SickScanDecoder::Decode(const SickScan& s, int64_t arrival_utime,
                                             const std::string& origin, int64_t number) {
  const std::string place = "telegram " + std::to_string(number);
  if (s.scan_frequency == 0) throw InputError(origin, place, "scan frequency is 0");
  if (s.angular_step == 0 && s.distances.size() > 1) throw InputError(origin, place, "angular step is 0");
  if (!s.rssi.empty() && s.rssi.size() != s.distances.size())
    throw InputError(origin, place,
                     "RSSI1 has " + std::to_string(s.rssi.size()) + " values for " +
                         std::to_string(s.distances.size()) + " distances");
  if (last_scan_counter_ >= 0) scans_lost_ += ((s.scan_counter - last_scan_counter_ - 1) & 0xFFFF);
  last_scan_counter_ = s.scan_counter;

  // Device times, unwrapped: the start of the scan precedes its transmission by
  // less than half the 32-bit range.
  const int64_t transmission = transmission_.Unwrap(s.time_of_transmission_us);
  const int64_t start = transmission - int64_t(uint32_t(s.time_of_transmission_us - s.time_since_startup_us));
  clock_.Add(transmission, arrival_utime);
  int64_t utime = clock_.ToHost(start + std::llround(config_.first_beam_offset_s * 1e6));
  if (any_ && utime <= last_utime_) utime = last_utime_ + 1;  // while the fit settles
  any_ = true;
  last_utime_ = utime;

  const double frequency_hz = s.scan_frequency / 100.0;
  const double step_rad = s.angular_step / 1e4 * M_PI / 180.0;
  agvcal::laser_scan_t m{};
  m.utime = utime;
  m.angle_min = float((s.start_angle / 1e4 + config_.angle_offset_deg) * M_PI / 180.0);
  m.angle_increment = float(step_rad);
  m.time_increment = float(step_rad / (2.0 * M_PI) / frequency_hz);  // rotating mirror
  m.scan_time = float(1.0 / frequency_hz);
  m.range_min = float(config_.range_min);
  m.range_max = float(config_.range_max);
  m.nranges = int32_t(s.distances.size());
  m.ranges.reserve(s.distances.size());
  for (uint32_t raw : s.distances) {
    m.ranges.push_back(raw == 0 ? NAN : float((raw * double(s.dist_scale) + s.dist_offset) * 1e-3));
  }
  m.nintensities = int32_t(s.rssi.size());
  for (uint32_t v : s.rssi) m.intensities.push_back(float(v));
  return m;
}

}  // namespace calib
