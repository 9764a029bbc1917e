#pragma once
// Reading and writing lcm-logger recordings (the LCM event log format), with
// errors that name the file, the event and the byte offset. Written by us
// rather than through lcm::LogFile so that a corrupt or truncated log is told
// apart from its end, and so that writes are atomic.
//
// Event layout (big-endian): int32 sync 0xEDA1DA01, int64 event number,
// int64 timestamp (us), int32 channel length, int32 data length, channel, data.

#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace calib {

// A channel name as it can be shown on a terminal or in JSON: every byte outside printable
// ASCII, space included (a trailing space is otherwise invisible), as \xNN ("SCAN\x20").
std::string PrintableChannel(const std::string& channel);

struct LogEvent {
  int64_t event_number = 0;
  int64_t timestamp = 0;   // us, when the logger received (or the simulator published) it
  std::string channel;
  std::vector<uint8_t> data;
  uint64_t offset = 0;     // byte offset of the event in the file
};

// A stretch of a recording the reader skipped: a torn event (an lcm-logger killed mid-write
// leaves one; restarted with -a, it appends after it) or damaged bytes, up to the next event that
// validates. `before_utime`/`after_utime`: the logger times of the events either side (0 where
// there is none): the span of data the recording lacks.
struct LogSkip {
  uint64_t begin = 0, end = 0;  // byte range [begin, end)
  int64_t before_utime = 0, after_utime = 0;
  std::string problem;          // what was found at `begin`
  std::string Describe() const; // "bytes B-E skipped (PROBLEM): the recording lacks ..."
};

class LogReader {
 public:
  // Throws InputError if the file cannot be opened (core/input_file.h: a directory, a device,
  // a FIFO nothing is written to are refused; a pipe is read once, to its end).
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // Reads the next event; false at the end of the file. Damage after a good event (a torn
  // event, a bad sync word, an implausible length, an event cut short by the end of the file)
  // is skipped to the next event that validates (its header plausible, its lengths within the
  // file, its channel name printable, the next sync word or the end right after it) and
  // reported to the skip handler; a file that does not start as an LCM log (bad sync word
  // at byte 0 and no valid event after it), and damage in a pipe (which cannot be searched),
  // throw InputError (file, "event N at byte B", problem).
  bool Next(LogEvent* event);

  // Like Next, for a log still being written (lcm-logger's): an incomplete
  // event at the end is not an error but the end for now; a later call reads
  // it once it is complete.
  bool NextComplete(LogEvent* event);

  // Called for each stretch skipped (default: none; the skips are also kept in skips()).
  void set_on_skip(std::function<void(const LogSkip&)> handler) { on_skip_ = std::move(handler); }
  const std::vector<LogSkip>& skips() const { return skips_; }

  const std::string& path() const { return path_; }

 private:
  bool Read(LogEvent* event, bool incomplete_tail_is_end);
  bool ReadStream(LogEvent* event);
  // The header at `offset` of a regular file, "" when it is a plausible event wholly within
  // `size` bytes (its length in *length), else the problem.
  std::string CheckEventAt(uint64_t offset, uint64_t size, bool strict, uint64_t* length) const;
  // The offset of the next event from `from` on that validates strictly, or `size` if none.
  uint64_t Resync(uint64_t from, uint64_t size) const;
  void Skip(uint64_t end, const std::string& problem, uint64_t size);
  size_t ReadAt(uint64_t offset, void* buffer, size_t bytes) const;
  std::string path_;
  int fd_ = -1;
  bool stream_ = false;
  uint64_t offset_ = 0;
  int64_t count_ = 0;
  int64_t last_timestamp_ = 0;
  std::optional<LogSkip> pending_skip_;  // reported once the event after it is known
  std::vector<LogSkip> skips_;
  std::function<void(const LogSkip&)> on_skip_;
};

// Receives encoded messages: a log file, an LCM bus or a test's memory.
class MessageSink {
 public:
  virtual ~MessageSink() = default;
  virtual void Publish(const std::string& channel, int64_t utime,
                       const std::vector<uint8_t>& data) = 0;
};

// Writes a log to a temporary renamed to PATH on Close() (calib/io/atomic_file.h,
// OpenOutput), so a reader never sees half a recording. Events count from 0.
class LogWriter : public MessageSink {
 public:
  explicit LogWriter(const std::string& path);  // throws InputError if not writable
  ~LogWriter() override;                         // without Close(): removes the temporary
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  void Publish(const std::string& channel, int64_t utime,
               const std::vector<uint8_t>& data) override;
  void Close();
  int64_t events() const { return count_; }

 private:
  std::string path_, partial_path_;  // partial_path_: the temporary (empty: in place)
  std::FILE* file_ = nullptr;
  int64_t count_ = 0;
};

// Keeps every message in memory, for tests and in-process pipelines.
class MemorySink : public MessageSink {
 public:
  void Publish(const std::string& channel, int64_t utime,
               const std::vector<uint8_t>& data) override {
    events.push_back({static_cast<int64_t>(events.size()), utime, channel, data, 0});
  }
  std::vector<LogEvent> events;
};

}  // namespace calib
