#pragma once
// Opening a file the tools read (a recording, a robot file, a config) so that nothing blocks
// and nothing endless is read: a regular file as it is; a pipe or FIFO (`<(cat LOG)`, mkfifo)
// read to its end, but refused when no writer sends anything within kStreamWaitS (a FIFO
// without a writer would block open() forever); a directory, a device or a socket refused.

#include <string>

namespace calib {

inline constexpr int kStreamWaitS = 10;

struct InputFile {
  int fd = -1;          // open for reading, blocking (close it with ::close)
  bool stream = false;  // a pipe or FIFO: no size, no seeking, read once
};

// Throws InputError (path, "", "cannot read WHAT: ...") for what cannot be read.
InputFile OpenInputFile(const std::string& path, const std::string& what);

// The whole content of `path` (OpenInputFile's rules), refused when longer than `max_bytes`
// (a character device such as /dev/zero never ends): "larger than N bytes".
std::string ReadWholeFile(const std::string& path, const std::string& what, std::size_t max_bytes);

}  // namespace calib
