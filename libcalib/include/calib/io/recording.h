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
#include <string>
#include <vector>

namespace calib {

struct LogEvent {
  int64_t event_number = 0;
  int64_t timestamp = 0;   // us, when the logger received (or the simulator published) it
  std::string channel;
  std::vector<uint8_t> data;
  uint64_t offset = 0;     // byte offset of the event in the file
};

class LogReader {
 public:
  // Throws InputError if the file cannot be opened.
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // Reads the next event; false at the clean end of the file. Throws
  // InputError (file, "event N at byte B", problem) on a bad sync word, an
  // implausible length or a truncated event.
  bool Next(LogEvent* event);

  // Like Next, for a log still being written (lcm-logger's): an incomplete
  // event at the end is not an error but the end for now; a later call reads
  // it once it is complete.
  bool NextComplete(LogEvent* event);

  const std::string& path() const { return path_; }

 private:
  bool Read(LogEvent* event, bool incomplete_tail_is_end);
  std::string path_;
  std::FILE* file_ = nullptr;
  uint64_t offset_ = 0;
  int64_t count_ = 0;
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
