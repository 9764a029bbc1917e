#include "calib/io/recording_tail.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "calib/core/errors.h"
#include "calib/io/recording.h"

namespace calib {

namespace {
constexpr uint64_t kEventHeaderBytes = 28;  // sync, event number, timestamp, two lengths
}  // namespace

RecordingTail FindLastWholeEvent(const std::string& path) {
  RecordingTail tail;
  LogReader reader(path);
  LogEvent event;
  // NextComplete stops before an event the file holds only part of, as it does for a log
  // still being written; damage before that is skipped by the reader, never cut.
  while (reader.NextComplete(&event)) {
    ++tail.whole_events;
    tail.whole_end = event.offset + kEventHeaderBytes + event.channel.size() + event.data.size();
  }
  std::error_code error;
  tail.file_size = std::filesystem::file_size(path, error);
  if (error) throw InputError(path, "", "cannot read its size: " + error.message());
  return tail;
}

RecordingTail CutToLastWholeEvent(const std::string& path) {
  const RecordingTail tail = FindLastWholeEvent(path);
  if (tail.file_size > tail.whole_end && ::truncate(path.c_str(), static_cast<off_t>(tail.whole_end)) != 0)
    throw InputError(path, "byte " + std::to_string(tail.whole_end),
                     std::string("cannot cut the torn last event: ") + std::strerror(errno));
  return tail;
}

}  // namespace calib
