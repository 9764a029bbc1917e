#include "calib/devices/canopen.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "calib/core/errors.h"
#include "devices/bridge_config.h"

namespace calib {

namespace {

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool ParseHex(const std::string& text, uint64_t* value) {
  if (text.empty() || text.size() > 16) return false;
  uint64_t v = 0;
  for (char c : text) {
    const int d = HexDigit(c);
    if (d < 0) return false;
    v = v * 16 + uint64_t(d);
  }
  *value = v;
  return true;
}

}  // namespace

bool CandumpReader::Next(CanFrame* frame) {
  std::string line;
  do {
    if (!reader_.Next(&line)) return false;
  } while (line.find_first_not_of(" \t") == std::string::npos);
  const std::vector<std::string> fields = SplitFields(line);
  if (fields.size() < 3 || fields.size() > 4 || (fields.size() == 4 && fields[3] != "T" && fields[3] != "R"))
    reader_.Fail("expected '(SECONDS) IFACE ID#DATA' (candump -l format), got '" + line + "'");
  const std::string& stamp = fields[0];
  if (stamp.size() < 3 || stamp.front() != '(' || stamp.back() != ')')
    reader_.Fail("field 1 (time) must be '(seconds)', got '" + stamp + "'");
  frame->utime = ParseSecondsAsMicros(reader_, stamp.substr(1, stamp.size() - 2), "field 1 (time)");
  const std::string& body = fields[2];
  const std::size_t hash = body.find('#');
  if (hash == std::string::npos) reader_.Fail("field 3 (frame) has no '#': '" + body + "'");
  if (body.compare(hash, 2, "##") == 0)
    reader_.Fail("CAN FD frame '" + body + "': the encoder bridge reads classic CAN only");
  const std::string id_text = body.substr(0, hash);
  uint64_t id = 0;
  if ((id_text.size() != 3 && id_text.size() != 8) || !ParseHex(id_text, &id))
    reader_.Fail("field 3 (frame): identifier '" + id_text +
                 "' must be 3 (standard) or 8 (extended) hex digits");
  frame->extended = id_text.size() == 8;
  if (!frame->extended && id > 0x7FF) reader_.Fail("standard identifier " + id_text + " exceeds 7FF");
  frame->id = static_cast<uint32_t>(id & 0x1FFFFFFF);
  std::string data = body.substr(hash + 1);
  frame->data.clear();
  frame->remote = !data.empty() && (data[0] == 'R' || data[0] == 'r');
  if (frame->remote) return true;
  const std::size_t underscore = data.find('_');  // len8_dlc suffix of newer candump
  if (underscore != std::string::npos) data.resize(underscore);
  if (data.size() % 2 != 0 || data.size() > 16)
    reader_.Fail("field 3 (frame): data '" + data + "' must be 0 to 8 bytes as pairs of hex digits");
  for (std::size_t i = 0; i < data.size(); i += 2) {
    uint64_t byte = 0;
    if (!ParseHex(data.substr(i, 2), &byte))
      reader_.Fail("field 3 (frame): data '" + data + "' is not hex");
    frame->data.push_back(static_cast<uint8_t>(byte));
  }
  return true;
}

std::string FormatCandumpLine(const CanFrame& frame, const std::string& interface) {
  char head[64];
  const int64_t s = frame.utime / 1000000, us = frame.utime % 1000000;
  std::snprintf(head, sizeof head, "(%lld.%06lld) ", static_cast<long long>(s),
                static_cast<long long>(us));
  char id[16];
  std::snprintf(id, sizeof id, frame.extended ? "%08X#" : "%03X#", frame.id);
  std::string line = std::string(head) + interface + " " + id;
  if (frame.remote) return line + "R";
  for (uint8_t b : frame.data) {
    char byte[3];
    std::snprintf(byte, sizeof byte, "%02X", b);
    line += byte;
  }
  return line;
}

uint32_t TpdoCobId(int tpdo, int node) { return 0x180 + 0x100 * uint32_t(tpdo - 1) + uint32_t(node); }

void PutPdoValue(const PdoField& field, int64_t value, std::vector<uint8_t>* data) {
  if (data->size() < std::size_t(field.offset + field.length)) data->resize(field.offset + field.length);
  const uint64_t bits = static_cast<uint64_t>(value);
  for (int i = 0; i < field.length; ++i) (*data)[field.offset + i] = uint8_t(bits >> (8 * i));
}

namespace {

int64_t GetPdoValue(const PdoField& field, const std::vector<uint8_t>& data) {
  uint64_t v = 0;
  for (int i = field.length - 1; i >= 0; --i) v = (v << 8) | data[field.offset + i];
  if (field.is_signed && field.length < 8 && (v >> (8 * field.length - 1)) & 1)
    v |= ~uint64_t(0) << (8 * field.length);
  return static_cast<int64_t>(v);
}

// --- config file

using yaml::CheckedMap;
using yaml::Field;
using yaml::Reporter;
using bridge_internal::ReadBool;
using bridge_internal::ReadInteger;

PdoField ReadPdoField(const Reporter& reporter, const CheckedMap& map, int wheel_node) {
  PdoField f;
  const auto cob = map.Find("cob_id");
  const auto tpdo = map.Find("tpdo");
  if (cob && (tpdo || map.Has("node")))
    reporter.Fail(*cob, "give either cob_id or tpdo (with the node), not both");
  if (cob) {
    f.cob_id = uint32_t(ReadInteger(reporter, *cob, 1, 0x7FF));
  } else {
    if (!tpdo) reporter.Fail(map.line(), map.path() + ".tpdo", "missing required key (or give cob_id)");
    const int node = map.Has("node") ? int(ReadInteger(reporter, map.Get("node"), 1, 127)) : wheel_node;
    if (node == 0)
      reporter.Fail(map.line(), map.path() + ".node",
                    "no node ID: give node here or for the wheel (or give cob_id)");
    f.cob_id = TpdoCobId(int(ReadInteger(reporter, *tpdo, 1, 4)), node);
  }
  f.offset = map.Has("offset") ? int(ReadInteger(reporter, map.Get("offset"), 0, 7)) : 0;
  const Field length = map.Get("length", "bytes of the object: 1 to 8");
  f.length = int(ReadInteger(reporter, length, 1, 8));
  if (f.offset + f.length > 8)
    reporter.Fail(length, "offset + length = " + std::to_string(f.offset + f.length) +
                              " bytes exceeds the 8 bytes of a CAN frame");
  f.is_signed = map.Has("signed") ? ReadBool(reporter, map.Get("signed")) : true;
  return f;
}

CanWheelConfig ReadWheel(const Reporter& reporter, const Field& field) {
  CanWheelConfig w;
  w.name = field.path.substr(field.path.rfind('.') + 1);
  const CheckedMap map(reporter, field, {"node", "position", "velocity", "steer"});
  if (map.Has("node")) w.node = int(ReadInteger(reporter, map.Get("node"), 1, 127));
  const std::vector<std::string> common{"cob_id", "tpdo", "node", "offset", "length", "signed"};
  auto with = [&](const std::string& extra1, const std::string& extra2) {
    std::vector<std::string> keys = common;
    keys.push_back(extra1);
    if (!extra2.empty()) keys.push_back(extra2);
    return keys;
  };
  const CheckedMap position(reporter, map.Get("position", "the drive's encoder position object"),
                            with("ticks_per_rev", ""));
  w.position = ReadPdoField(reporter, position, w.node);
  w.ticks_per_rev = yaml::ReadPositive(reporter, position.Get("ticks_per_rev"));
  if (const auto v = map.Find("velocity")) {
    const CheckedMap velocity(reporter, *v, with("rad_s_per_unit", ""));
    w.velocity = ReadPdoField(reporter, velocity, w.node);
    w.velocity_rad_s_per_unit = yaml::ReadNumber(reporter, velocity.Get("rad_s_per_unit"));
  }
  if (const auto s = map.Find("steer")) {
    const CheckedMap steer(reporter, *s, with("counts_per_rev", "zero"));
    w.steer = ReadPdoField(reporter, steer, w.node);
    w.steer_counts_per_rev = yaml::ReadPositive(reporter, steer.Get("counts_per_rev"));
    if (steer.Has("zero"))
      w.steer_zero = ReadInteger(reporter, steer.Get("zero"), INT64_MIN / 2, INT64_MAX / 2);
  }
  return w;
}

}  // namespace

CanBridgeConfig ParseCanBridgeConfig(const std::string& yaml_text, const std::string& origin) {
  const Reporter reporter(origin);
  const Field root = yaml::ParseSingleDocument(reporter, yaml_text, "CAN bridge config");
  const CheckedMap top(reporter, root, {"channel", "sync", "clock", "wheels"});
  CanBridgeConfig config;
  config.source_file = origin;
  if (const auto c = top.Find("channel")) config.channel = yaml::ReadString(reporter, *c);
  const CheckedMap sync(reporter, top.Get("sync", "the SYNC producer: cob_id and period_s"),
                        {"cob_id", "period_s", "counter_overflow"});
  config.sync_cob_id = sync.Has("cob_id") ? uint32_t(ReadInteger(reporter, sync.Get("cob_id"), 1, 0x7FF)) : 0x80;
  config.sync_period_s = yaml::ReadPositive(reporter, sync.Get("period_s"));
  if (const auto o = sync.Find("counter_overflow")) {
    config.sync_counter_overflow = int(ReadInteger(reporter, *o, 0, 240));
    if (config.sync_counter_overflow == 1)
      reporter.Fail(*o, "must be 0 (no counter byte) or 2..240 (CiA 301)");
  }
  bridge_internal::ReadClockOptions(reporter, top, &config.clock);
  const Field wheels = top.Get("wheels", "wheel name -> node and PDO objects");
  if (!wheels.value.IsMap() || wheels.value.size() == 0)
    reporter.Fail(wheels, "expected a map of wheel names, got " + yaml::Describe(wheels.value));
  for (const auto& entry : wheels.value) {
    const std::string name = entry.first.Scalar();
    const int line = yaml::LineOf(entry.first.Mark());
    config.wheels.push_back(ReadWheel(reporter, Field{"wheels." + name, line, entry.second}));
  }
  // No two objects may share bytes of one PDO, and no PDO may use the SYNC's COB-ID.
  std::map<uint32_t, std::vector<std::pair<int, std::string>>> used;  // cob -> byte owners
  for (const CanWheelConfig& w : config.wheels) {
    for (const auto& [field, what] : std::vector<std::pair<const PdoField*, std::string>>{
             {&w.position, "position"},
             {w.velocity ? &*w.velocity : nullptr, "velocity"},
             {w.steer ? &*w.steer : nullptr, "steer"}}) {
      if (!field) continue;
      const std::string key = "wheels." + w.name + "." + what;
      if (field->cob_id == config.sync_cob_id)
        reporter.Fail(0, key, "uses the SYNC COB-ID " + std::to_string(config.sync_cob_id));
      auto& owners = used[field->cob_id];
      for (int b = field->offset; b < field->offset + field->length; ++b) {
        for (const auto& [byte, owner] : owners) {
          if (byte == b)
            reporter.Fail(0, key, "byte " + std::to_string(b) + " of COB-ID " +
                                      std::to_string(field->cob_id) + " is also " + owner);
        }
        owners.push_back({b, key});
      }
    }
  }
  return config;
}

CanBridgeConfig LoadCanBridgeConfig(const std::string& path) {
  return ParseCanBridgeConfig(yaml::ReadTextFile(path, "CAN bridge config"), path);
}

// --- decoder

CanopenDecoder::CanopenDecoder(CanBridgeConfig config)
    : config_(std::move(config)), clock_(config_.clock) {
  auto add = [this](const PdoField& f) {
    for (const Pdo& p : pdos_)
      if (p.cob_id == f.cob_id) return;
    pdos_.push_back({f.cob_id, {}, false});
  };
  for (const CanWheelConfig& w : config_.wheels) {
    add(w.position);
    if (w.velocity) add(*w.velocity);
    if (w.steer) add(*w.steer);
    unwrappers_.emplace_back(8 * w.position.length);
  }
}

const std::vector<uint8_t>& CanopenDecoder::PdoData(uint32_t cob_id) const {
  for (const Pdo& p : pdos_)
    if (p.cob_id == cob_id) return p.data;
  return pdos_.front().data;  // unreachable: every field's PDO is in pdos_
}

void CanopenDecoder::Feed(const CanFrame& frame, const std::string& file, const std::string& place,
                          std::vector<agvcal::wheel_state_t>* out) {
  ++stats_.frames;
  if (frame.extended || frame.remote) {
    ++stats_.ignored;
    return;
  }
  if (frame.id == config_.sync_cob_id) {
    if (in_cycle_ && !cycle_done_) ++stats_.incomplete_cycles;
    int64_t step = 1;
    const int counter = frame.data.empty() ? -1 : frame.data[0];
    if (stats_.syncs > 0) {
      if (config_.sync_counter_overflow > 0 && counter >= 1 && last_counter_ >= 1) {
        const int n = config_.sync_counter_overflow;
        step = ((counter - last_counter_) % n + n) % n;
        if (step == 0) step = n;
      } else {
        step = std::max<int64_t>(1, std::llround(double(frame.utime - last_sync_utime_) * 1e-6 /
                                                 config_.sync_period_s));
      }
      stats_.syncs_lost += step - 1;
      sync_index_ += step;
    }
    ++stats_.syncs;
    last_counter_ = counter;
    last_sync_utime_ = frame.utime;
    const int64_t device_us = std::llround(double(sync_index_) * config_.sync_period_s * 1e6);
    cycle_utime_ = clock_.Add(device_us, frame.utime);
    in_cycle_ = true;
    cycle_done_ = false;
    for (Pdo& p : pdos_) p.received = false;
    return;
  }
  auto pdo = std::find_if(pdos_.begin(), pdos_.end(), [&](const Pdo& p) { return p.cob_id == frame.id; });
  if (pdo == pdos_.end()) {
    ++stats_.ignored;
    return;
  }
  if (!in_cycle_) {
    ++stats_.pdos_before_sync;
    return;
  }
  // Every object this PDO carries must fit in the bytes received.
  for (const CanWheelConfig& w : config_.wheels) {
    for (const PdoField* f : {&w.position, w.velocity ? &*w.velocity : nullptr, w.steer ? &*w.steer : nullptr}) {
      if (f && f->cob_id == frame.id && int(frame.data.size()) < f->offset + f->length) {
        char id[8];
        std::snprintf(id, sizeof id, "%03X", frame.id);
        throw InputError(file, place,
                         "PDO " + std::string(id) + " has " + std::to_string(frame.data.size()) +
                             " data bytes, but the bridge config (" + config_.source_file +
                             ") maps wheel '" + w.name + "' to bytes " + std::to_string(f->offset) +
                             ".." + std::to_string(f->offset + f->length - 1));
      }
    }
  }
  pdo->data = frame.data;
  pdo->received = true;
  if (!cycle_done_ && std::all_of(pdos_.begin(), pdos_.end(), [](const Pdo& p) { return p.received; })) {
    cycle_done_ = true;
    Publish(out);
  }
}

void CanopenDecoder::Publish(std::vector<agvcal::wheel_state_t>* out) {
  agvcal::wheel_state_t msg{};
  // Stamps must increase even while the clock fit settles (a new least-delayed SYNC).
  msg.utime = stats_.published > 0 ? std::max(cycle_utime_, last_published_ + 1) : cycle_utime_;
  msg.num_wheels = int32_t(config_.wheels.size());
  for (std::size_t i = 0; i < config_.wheels.size(); ++i) {
    const CanWheelConfig& w = config_.wheels[i];
    msg.name.push_back(w.name);
    const int64_t raw = GetPdoValue(w.position, PdoData(w.position.cob_id));
    const int64_t ticks = unwrappers_[i].Unwrap(static_cast<uint64_t>(raw));
    msg.position.push_back(double(ticks) * 2.0 * M_PI / w.ticks_per_rev);
    msg.velocity.push_back(w.velocity ? double(GetPdoValue(*w.velocity, PdoData(w.velocity->cob_id))) *
                                            w.velocity_rad_s_per_unit
                                      : std::nan(""));
    msg.steer.push_back(w.steer ? double(GetPdoValue(*w.steer, PdoData(w.steer->cob_id)) - w.steer_zero) *
                                      2.0 * M_PI / w.steer_counts_per_rev
                                : 0.0);
  }
  last_published_ = msg.utime;
  ++stats_.published;
  out->push_back(std::move(msg));
}

}  // namespace calib

namespace calib {

std::vector<CanFrame> EmulateCanBus(const CanBridgeConfig& config,
                                    const std::vector<agvcal::wheel_state_t>& states,
                                    const CanEmulation& options) {
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> late(0.0, options.jitter_s * 1e6);
  std::vector<CanFrame> frames;
  int counter = 0;
  for (const agvcal::wheel_state_t& state : states) {
    const int64_t sent = state.utime;
    CanFrame sync;
    sync.id = config.sync_cob_id;
    sync.utime = sent + std::llround(late(rng));
    if (config.sync_counter_overflow > 0) {
      counter = counter % config.sync_counter_overflow + 1;
      sync.data = {uint8_t(counter)};
    }
    if (!frames.empty()) sync.utime = std::max(sync.utime, frames.back().utime + 1);
    frames.push_back(sync);
    std::map<uint32_t, CanFrame> pdos;
    for (const CanWheelConfig& w : config.wheels) {
      int index = -1;
      for (int i = 0; i < state.num_wheels; ++i)
        if (state.name[i] == w.name) index = i;
      if (index < 0) throw InputError("wheel states", "utime " + std::to_string(state.utime), "no wheel '" + w.name + "'");
      auto put = [&](const PdoField& f, int64_t value) {
        CanFrame& frame = pdos[f.cob_id];
        frame.id = f.cob_id;
        PutPdoValue(f, value, &frame.data);
      };
      put(w.position, std::llround(state.position[index] * w.ticks_per_rev / (2.0 * M_PI)));
      if (w.velocity) {
        const double v = state.velocity[index];
        put(*w.velocity, std::isfinite(v) ? std::llround(v / w.velocity_rad_s_per_unit) : 0);
      }
      if (w.steer)
        put(*w.steer, std::llround(state.steer[index] * w.steer_counts_per_rev / (2.0 * M_PI)) + w.steer_zero);
    }
    // The bus keeps the frames' order; the host's delays may bunch them up.
    int j = 0;
    int64_t previous = sync.utime;
    for (auto& [cob, frame] : pdos) {
      frame.utime = std::max<int64_t>(previous + 1, sent + std::llround(++j * options.pdo_spacing_s * 1e6 + late(rng)));
      previous = frame.utime;
      frames.push_back(frame);
    }
  }
  return frames;
}

}  // namespace calib
