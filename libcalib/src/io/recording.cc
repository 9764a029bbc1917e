#include "calib/io/recording.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/core/input_file.h"
#include "calib/core/units.h"

namespace calib {

namespace {
constexpr uint32_t kSyncWord = 0xEDA1DA01;
constexpr int32_t kMaxChannelLength = 256;     // LCM's own limit on channel names
constexpr int32_t kMaxDataLength = 1 << 28;    // 256 MiB: anything larger is corruption
constexpr size_t kHeaderBytes = 28;

uint64_t ReadBigEndian(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

void PutBigEndian(uint64_t v, int bytes, std::vector<uint8_t>* out) {
  for (int i = bytes - 1; i >= 0; --i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}
}  // namespace

std::string PrintableChannel(const std::string& channel) {
  std::string out;
  for (unsigned char c : channel) {
    if (c > 0x20 && c < 0x7f && c != '\\') {
      out += char(c);
    } else {
      out += Formatted("\\x%02X", c);
    }
  }
  return out;
}

LogReader::LogReader(const std::string& path) : path_(path) {
  const InputFile file = OpenInputFile(path, "recording");
  fd_ = file.fd;
  stream_ = file.stream;
}

LogReader::~LogReader() {
  if (fd_ >= 0) ::close(fd_);
}

bool LogReader::Next(LogEvent* event) { return Read(event, false); }

bool LogReader::NextComplete(LogEvent* event) { return Read(event, true); }

std::string LogSkip::Describe() const {
  std::string text = "bytes " + std::to_string(begin) + "-" + std::to_string(end) + " skipped (" + problem + ")";
  if (before_utime > 0 && after_utime > 0)
    return text + Formatted(": the recording lacks what was logged between %.6f s and %.6f s (%.3f s)",
                            before_utime * 1e-6, after_utime * 1e-6, (after_utime - before_utime) * 1e-6);
  if (before_utime > 0) return text + Formatted(": the recording lacks what was logged after %.6f s", before_utime * 1e-6);
  if (after_utime > 0) return text + Formatted(": the recording lacks what was logged before %.6f s", after_utime * 1e-6);
  return text;
}

size_t LogReader::ReadAt(uint64_t offset, void* buffer, size_t bytes) const {
  size_t done = 0;
  while (done < bytes) {
    const ssize_t got = ::pread(fd_, static_cast<uint8_t*>(buffer) + done, bytes - done, off_t(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    done += size_t(got);
  }
  return done;
}

namespace {

struct Header {
  uint32_t sync = 0;
  int64_t event_number = 0, timestamp = 0;
  int32_t channel_length = 0, data_length = 0;
};

Header ParseHeader(const uint8_t* p) {
  return {uint32_t(ReadBigEndian(p, 4)), int64_t(ReadBigEndian(p + 4, 8)), int64_t(ReadBigEndian(p + 12, 8)),
          int32_t(ReadBigEndian(p + 20, 4)), int32_t(ReadBigEndian(p + 24, 4))};
}

// What is wrong with a header (sync word, lengths), or "".
std::string HeaderProblem(const Header& h) {
  if (h.sync != kSyncWord) return "bad sync word: not an LCM log, or corrupt";
  if (h.channel_length <= 0 || h.channel_length > kMaxChannelLength)
    return "implausible channel name length " + std::to_string(h.channel_length);
  if (h.data_length < 0 || h.data_length > kMaxDataLength)
    return "implausible message length " + std::to_string(h.data_length);
  return "";
}

constexpr const char* kCutShort = "(log cut short)";

}  // namespace

std::string LogReader::CheckEventAt(uint64_t offset, uint64_t size, bool strict, uint64_t* length) const {
  uint8_t bytes[kHeaderBytes];
  if (offset + kHeaderBytes > size || ReadAt(offset, bytes, kHeaderBytes) != kHeaderBytes)
    return std::string("truncated event header ") + kCutShort;
  const Header h = ParseHeader(bytes);
  const std::string problem = HeaderProblem(h);
  if (!problem.empty()) return problem;
  const uint64_t body_at = offset + kHeaderBytes;
  *length = kHeaderBytes + uint64_t(h.channel_length) + uint64_t(h.data_length);
  if (offset + *length > size) {
    return "truncated event " + std::string(kCutShort) + ": its header says " +
           std::to_string(int64_t(h.channel_length) + h.data_length) + " bytes follow, the file holds " +
           std::to_string(size - body_at);
  }
  if (!strict) return "";
  // A candidate found by searching: its channel name printable, and the next event (or the end)
  // right after it.
  std::string channel(size_t(h.channel_length), '\0');
  if (ReadAt(body_at, channel.data(), channel.size()) != channel.size()) return "unreadable";
  for (unsigned char c : channel)
    if (c < 0x20 || c > 0x7e) return "channel name not printable";
  const uint64_t next = offset + *length;
  uint8_t sync[4];
  const size_t got = next < size ? ReadAt(next, sync, std::min<uint64_t>(4, size - next)) : 0;
  for (size_t i = 0; i < got; ++i)
    if (sync[i] != uint8_t(kSyncWord >> (8 * (3 - i)))) return "no event after it";
  return "";
}

uint64_t LogReader::Resync(uint64_t from, uint64_t size) const {
  constexpr size_t kChunk = 1 << 16;
  std::vector<uint8_t> chunk(kChunk + 3);
  for (uint64_t at = from; at < size; at += kChunk) {
    const size_t got = ReadAt(at, chunk.data(), size_t(std::min<uint64_t>(kChunk + 3, size - at)));
    for (size_t i = 0; i + 4 <= got && i < kChunk; ++i) {
      if (ReadBigEndian(&chunk[i], 4) != kSyncWord) continue;
      uint64_t length = 0;
      if (CheckEventAt(at + i, size, true, &length).empty()) return at + i;
    }
  }
  return size;
}

void LogReader::Skip(uint64_t end, const std::string& problem, uint64_t) {
  if (!pending_skip_) pending_skip_ = LogSkip{offset_, end, last_timestamp_, 0, problem};
  pending_skip_->end = end;  // damage right after damage: one stretch
  offset_ = end;
}

bool LogReader::Read(LogEvent* event, bool incomplete_tail_is_end) {
  if (stream_) return ReadStream(event);
  auto report_skip = [&](int64_t after_utime) {
    if (!pending_skip_) return;
    pending_skip_->after_utime = after_utime;
    skips_.push_back(*pending_skip_);
    pending_skip_.reset();
    if (on_skip_) on_skip_(skips_.back());
  };
  for (;;) {
    const std::string place = "event " + std::to_string(count_) + " at byte " + std::to_string(offset_);
    struct stat info {};
    if (::fstat(fd_, &info) != 0) throw InputError(path_, place, std::string("cannot read: ") + std::strerror(errno));
    const uint64_t size = uint64_t(info.st_size);
    if (offset_ >= size) {
      if (!incomplete_tail_is_end) report_skip(0);
      return false;
    }
    uint64_t length = 0;
    std::string problem = CheckEventAt(offset_, size, false, &length);
    const bool incomplete = problem.find(kCutShort) != std::string::npos;
    if (problem.empty()) {
      // An event whose claimed length runs past the start of another is torn (an lcm-logger
      // killed mid-write, then restarted with -a): the next sync word is not right after it.
      uint64_t unused = 0;
      const uint64_t end = offset_ + length;
      if (end < size && !CheckEventAt(end, size, false, &unused).empty() && !(incomplete_tail_is_end && end + kHeaderBytes > size)) {
        const uint64_t next = Resync(offset_ + 1, size);
        if (next < end) problem = "a torn event: another event starts inside it, at byte " + std::to_string(next);
      }
    }
    if (problem.empty()) {
      std::vector<uint8_t> bytes(length);
      if (ReadAt(offset_, bytes.data(), length) != length)
        throw InputError(path_, place, std::string("cannot read: ") + std::strerror(errno));
      const Header h = ParseHeader(bytes.data());
      event->event_number = h.event_number;
      event->timestamp = h.timestamp;
      event->channel.assign(reinterpret_cast<const char*>(&bytes[kHeaderBytes]), size_t(h.channel_length));
      event->data.assign(bytes.begin() + kHeaderBytes + h.channel_length, bytes.end());
      event->offset = offset_;
      offset_ += length;
      ++count_;
      report_skip(event->timestamp);
      last_timestamp_ = event->timestamp;
      return true;
    }
    if (incomplete && incomplete_tail_is_end) return false;  // being written: read it later
    const uint64_t next = Resync(offset_ + 1, size);
    // Nothing readable before and none after: not a recording (or nothing left of one).
    if (count_ == 0 && offset_ == 0 && next == size) throw InputError(path_, place, problem);
    if (next == size && incomplete_tail_is_end) return false;  // the next event may be on its way
    Skip(next, problem, size);
  }
}

bool LogReader::ReadStream(LogEvent* event) {
  const std::string place = "event " + std::to_string(count_) + " at byte " + std::to_string(offset_);
  auto read_fully = [&](uint8_t* buffer, size_t bytes) {
    size_t done = 0;
    while (done < bytes) {
      const ssize_t got = ::read(fd_, buffer + done, bytes - done);
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) throw InputError(path_, place, std::string("cannot read: ") + std::strerror(errno));
      if (got == 0) break;
      done += size_t(got);
    }
    return done;
  };
  uint8_t bytes[kHeaderBytes];
  const size_t got = read_fully(bytes, kHeaderBytes);
  if (got == 0) return false;
  if (got < kHeaderBytes) throw InputError(path_, place, std::string("truncated event header ") + kCutShort);
  const Header h = ParseHeader(bytes);
  const std::string problem = HeaderProblem(h);
  if (!problem.empty()) throw InputError(path_, place, problem + " (a pipe is not searched for the next event)");
  // Grown as the bytes come, so that a corrupt length allocates nothing the pipe does not hold.
  std::vector<uint8_t> body;
  const size_t length = size_t(h.channel_length) + size_t(h.data_length);
  while (body.size() < length) {
    const size_t old = body.size();
    body.resize(std::min(length, old + (size_t(1) << 20)));
    if (read_fully(body.data() + old, body.size() - old) != body.size() - old)
      throw InputError(path_, place, "truncated event " + std::string(kCutShort) + ": its header says " +
                                         std::to_string(length) + " bytes follow");
  }
  event->event_number = h.event_number;
  event->timestamp = h.timestamp;
  event->channel.assign(body.begin(), body.begin() + h.channel_length);
  event->data.assign(body.begin() + h.channel_length, body.end());
  event->offset = offset_;
  offset_ += kHeaderBytes + length;
  ++count_;
  return true;
}

LogWriter::LogWriter(const std::string& path) : path_(path), file_(OpenOutput(path, &partial_path_)) {}

LogWriter::~LogWriter() {
  if (file_) {
    std::fclose(file_);
    if (!partial_path_.empty()) std::remove(partial_path_.c_str());
  }
}

void LogWriter::Publish(const std::string& channel, int64_t utime,
                        const std::vector<uint8_t>& data) {
  std::vector<uint8_t> header;
  header.reserve(28 + channel.size());
  PutBigEndian(kSyncWord, 4, &header);
  PutBigEndian(static_cast<uint64_t>(count_), 8, &header);
  PutBigEndian(static_cast<uint64_t>(utime), 8, &header);
  PutBigEndian(channel.size(), 4, &header);
  PutBigEndian(data.size(), 4, &header);
  header.insert(header.end(), channel.begin(), channel.end());
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size() ||
      std::fwrite(data.data(), 1, data.size(), file_) != data.size())
    throw InputError(path_, "event " + std::to_string(count_), "write failed (disk full?)");
  ++count_;
}

void LogWriter::Close() {
  if (!file_) return;
  std::FILE* file = file_;
  file_ = nullptr;
  try {
    CommitOutput(path_, file, &partial_path_);
  } catch (const InputError& e) {
    throw InputError(path_, "", "could not finish writing the log: " + e.problem());
  }
}

}  // namespace calib
