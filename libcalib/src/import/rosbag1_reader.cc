// ROS 1 bags (ros_bag.h) through Debian's python3-rosbag: scripts/agvcal-rosbag1-messages lists
// the bag's topics and writes the wanted messages, serialized as ROS 1 does, in record-time
// order (its header says the framing); ros_messages.h decodes them. (The C++ rosbag_storage
// of librosbag-storage-dev needs pluginlib's headers, which its Debian package does not pull in.)
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"
#include "import/ros_bag.h"

extern char** environ;

namespace calib::import_internal {

namespace {

std::string HelperPath() {
  const char* path = std::getenv("AGVCAL_ROSBAG1_HELPER");
  return path ? path : std::string(AGVCAL_SOURCE_DIR) + "/scripts/agvcal-rosbag1-messages";
}

// Runs the helper; its stdout and stderr, and whether it exited 0.
bool RunHelper(const std::vector<std::string>& args, std::string* out, std::string* err) {
  int out_pipe[2], err_pipe[2];
  if (pipe(out_pipe) != 0) return false;
  if (pipe(err_pipe) != 0) {
    close(out_pipe[0]);
    close(out_pipe[1]);
    return false;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err_pipe[1], 2);
  for (int fd : {out_pipe[0], out_pipe[1], err_pipe[0], err_pipe[1]})
    posix_spawn_file_actions_addclose(&actions, fd);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out_pipe[1]);
  close(err_pipe[1]);
  if (spawned != 0) {
    *err = std::string("cannot run ") + argv[0] + ": " + std::strerror(spawned);
    close(out_pipe[0]);
    close(err_pipe[0]);
    return false;
  }
  pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
  std::string* sinks[2] = {out, err};
  char buffer[1 << 16];
  for (int open_fds = 2; open_fds > 0;) {
    if (poll(fds, 2, -1) < 0) continue;  // EINTR
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || !(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t n = read(fds[i].fd, buffer, sizeof buffer);
      if (n > 0) {
        sinks[i]->append(buffer, static_cast<size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        close(fds[i].fd);
        fds[i].fd = -1;
        --open_fds;
      }
    }
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// Parses the helper's output (its header comment) into `bag`.
void ParseHelperOutput(const std::string& path, const std::string& out, Bag* bag) {
  auto fail = [&](const std::string& problem) {
    throw InputError(path, "", "unexpected output of " + HelperPath() + ": " + problem);
  };
  std::vector<const BagTopic*> topics;
  size_t at = 0;
  for (;;) {
    const size_t end = out.find('\n', at);
    if (end == std::string::npos) fail("no DATA line");
    const std::string line = out.substr(at, end - at);
    at = end + 1;
    if (line == "DATA") break;
    const size_t tab1 = line.find('\t'), tab2 = line.find('\t', tab1 + 1);
    if (line.compare(0, 6, "TOPIC\t") != 0 || tab2 == std::string::npos) fail("bad topic line");
    BagTopic topic{line.substr(tab1 + 1, tab2 - tab1 - 1), line.substr(tab2 + 1), "ros1"};
    topics.push_back(&(bag->topics[topic.name] = topic));
  }
  for (int64_t index = 0; at < out.size(); ++index) {
    if (out.size() - at < 16) fail("truncated message record");
    uint32_t topic = 0, length = 0;
    int64_t record_ns = 0;
    std::memcpy(&topic, out.data() + at, 4);
    std::memcpy(&record_ns, out.data() + at + 4, 8);
    std::memcpy(&length, out.data() + at + 12, 4);
    at += 16;
    if (topic >= topics.size() || length > out.size() - at) fail("bad message record");
    BagMessage message;
    message.topic = topics[topic];
    message.record_ns = record_ns;
    message.file = path;
    message.place = "message " + std::to_string(index) + " (record time " + std::to_string(record_ns) + " ns)";
    message.data.assign(out.begin() + static_cast<std::ptrdiff_t>(at),
                        out.begin() + static_cast<std::ptrdiff_t>(at + length));
    at += length;
    bag->messages.push_back(std::move(message));
  }
}

}  // namespace

void ReadRosbag1(const std::string& path, const std::set<std::string>& wanted, Bag* bag) {
  const InputFile file = OpenInputFile(path, "ROS 1 bag");  // the usual refusals first
  ::close(file.fd);
  if (file.stream) throw InputError(path, "", "a bag must be a regular file, not a pipe");
  std::vector<std::string> args{"/usr/bin/python3", HelperPath(), path};
  args.insert(args.end(), wanted.begin(), wanted.end());
  std::string out, err;
  if (!RunHelper(args, &out, &err)) {
    while (!err.empty() && err.back() == '\n') err.pop_back();
    const size_t last = err.rfind('\n');
    std::string problem = last == std::string::npos ? err : err.substr(last + 1);
    if (problem.compare(0, path.size() + 2, path + ": ") == 0) problem.erase(0, path.size() + 2);
    throw InputError(path, "", "not a readable ROS 1 bag (python3-rosbag: " +
                                   (problem.empty() ? "failed" : problem) + ")");
  }
  ParseHelperOutput(path, out, bag);
  SortByRecordTime(bag);
}

}  // namespace calib::import_internal
