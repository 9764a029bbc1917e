#include "calib/core/input_file.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "calib/core/errors.h"

namespace calib {

InputFile OpenInputFile(const std::string& path, const std::string& what) {
  auto fail = [&](const std::string& problem) { throw InputError(path, "", "cannot read " + what + ": " + problem); };
  // Non-blocking, or a FIFO without a writer would block right here.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) fail(std::strerror(errno));
  auto refuse = [&](const std::string& problem) {
    ::close(fd);
    fail(problem);
  };
  struct stat info {};
  if (::fstat(fd, &info) != 0) refuse(std::strerror(errno));
  InputFile file{fd, S_ISFIFO(info.st_mode)};
  if (S_ISDIR(info.st_mode)) refuse("is a directory");
  if (!S_ISREG(info.st_mode) && !file.stream) refuse("not a regular file, pipe or FIFO (a device or a socket)");
  if (file.stream) {
    pollfd wait{fd, POLLIN, 0};
    const int ready = ::poll(&wait, 1, kStreamWaitS * 1000);
    if (ready == 0)
      refuse("a pipe or FIFO that nothing was written to within " + std::to_string(kStreamWaitS) +
             " s (no writer?)");
    if (ready < 0) refuse(std::strerror(errno));
  }
  if (::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK) != 0) refuse(std::strerror(errno));
  return file;
}

std::string ReadWholeFile(const std::string& path, const std::string& what, std::size_t max_bytes) {
  const InputFile file = OpenInputFile(path, what);
  std::string text;
  char buffer[1 << 16];
  for (;;) {
    const ssize_t got = ::read(file.fd, buffer, sizeof(buffer));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const std::string problem = std::strerror(errno);
      ::close(file.fd);
      throw InputError(path, "", "cannot read " + what + ": " + problem);
    }
    if (got == 0) break;
    text.append(buffer, std::size_t(got));
    if (text.size() > max_bytes) {
      ::close(file.fd);
      throw InputError(path, "", "larger than " + std::to_string(max_bytes) + " bytes: not a " + what);
    }
  }
  ::close(file.fd);
  return text;
}

}  // namespace calib
