#pragma once
// The end of a recording that lcm-logger was writing when it was killed: its last event may be
// torn (written in part). lcm-logger -a appends after whatever the file ends with, so a torn
// event left there would make everything appended after it unreadable; cutting the file back to
// its last whole event first keeps the recording one readable log.

#include <cstdint>
#include <string>

namespace calib {

struct RecordingTail {
  int64_t whole_events = 0;  // events read whole from the start
  uint64_t whole_end = 0;    // byte just past the last whole event
  uint64_t file_size = 0;    // bytes in the file (more than whole_end: a torn last event)
};

// Reads PATH from its start to its last whole event. Throws InputError (file, event, problem)
// if an event before the end is corrupt: only a torn tail is something a cut repairs.
RecordingTail FindLastWholeEvent(const std::string& path);

// Cuts PATH back to its last whole event (nothing to do if it ends with one) and returns what
// it found before the cut. Throws InputError as above, or if the file cannot be cut.
RecordingTail CutToLastWholeEvent(const std::string& path);

}  // namespace calib
