// agvcal-canbridge: CANopen motor drives and steering encoders -> WHEELS.
// Live from a SocketCAN interface (kernel receive stamps), or a candump -l
// log replayed with its own stamps; the decoding is libcalib's CanopenDecoder.
#include <lcm/lcm-cpp.hpp>

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <thread>

#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/devices/canopen.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Encoder bridge for CANopen drives and steering encoders: decodes the
synchronous TPDOs of the nodes in CONFIG.yaml (config/bridges/*_can.yaml,
format in libcalib/include/calib/devices/canopen.h) and publishes wheel_state_t on
WHEELS (or the config's channel), stamped with the SYNC producer's clock.
Give exactly one of --can and --candump.)")
      .Positional("CONFIG.yaml", "the bridge config")
      .Option("--can", "IFACE", "read a SocketCAN interface live (e.g. can0), until Ctrl-C")
      .Option("--candump", "FILE", "replay a 'candump -l' log with its recorded stamps, then exit")
      .Option("--robot", "FILE", "check that CONFIG.yaml reports every wheel of this robot file")
      .Option("--speed", "X",
              "replay speed: log seconds per wall-clock second (default 1;\n"
              "0 = as fast as possible)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 stopped cleanly or end of the log, 2 bad config, log, frame\n"
              "layout or interface, 1 internal error.\n");
}

using agvcal_process::g_stop_requested;

class Bridge {
 public:
  Bridge(lcm::LCM* lcm, calib::CanBridgeConfig config)
      : lcm_(lcm), decoder_(std::move(config)), heartbeat_(lcm, "canbridge") {}

  void Feed(const calib::CanFrame& frame, const std::string& file, const std::string& place) {
    out_.clear();
    decoder_.Feed(frame, file, place, &out_);
    for (const agvcal::wheel_state_t& m : out_) lcm_->publish(decoder_.config().channel, &m);
    Beat();
  }
  void Beat(bool force = false) {
    const auto& s = decoder_.stats();
    heartbeat_.Beat("running " + std::to_string(s.published) + " wheel states, " +
                        std::to_string(s.syncs_lost) + " SYNCs lost",
                    force);
  }
  void Report() const {
    const auto& s = decoder_.stats();
    std::cerr << "agvcal-canbridge: stopped; " << s.frames << " frames, " << s.published
              << " wheel states, " << s.syncs << " SYNCs (" << s.syncs_lost << " lost), "
              << s.incomplete_cycles << " incomplete cycles, " << s.ignored << " other frames\n";
  }

 private:
  lcm::LCM* lcm_;
  calib::CanopenDecoder decoder_;
  agvcal_process::Heartbeat heartbeat_;
  std::vector<agvcal::wheel_state_t> out_;
};

void Replay(Bridge* bridge, const std::string& path, double speed) {
  calib::CandumpReader reader(path);
  calib::CanFrame frame;
  int64_t first = 0, wall_start = 0;
  bool any = false;
  while (!g_stop_requested && reader.Next(&frame)) {
    if (!any) {
      any = true;
      first = frame.utime;
      wall_start = agvcal_process::WallMicros();
    }
    if (speed > 0) {
      const int64_t due = wall_start + int64_t(double(frame.utime - first) / speed);
      while (!g_stop_requested && agvcal_process::WallMicros() < due) {
        bridge->Beat();
        std::this_thread::sleep_for(std::chrono::microseconds(
            std::min<int64_t>(100000, due - agvcal_process::WallMicros())));
      }
    }
    bridge->Feed(frame, path, reader.place());
  }
}

void Live(Bridge* bridge, const std::string& iface) {
  const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) throw calib::InputError("--can " + iface, "", std::string("cannot open a CAN socket: ") + std::strerror(errno));
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, iface.c_str(), IFNAMSIZ - 1);
  if (iface.size() >= IFNAMSIZ || ioctl(fd, SIOCGIFINDEX, &ifr) < 0) {
    close(fd);
    throw calib::InputError("--can " + iface, "", "no such CAN interface (ip link show type can)");
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  const int on = 1;
  // Kernel receive stamps: no user-space scheduling delay in the SYNC arrivals.
  setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on);
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    const std::string reason = std::strerror(errno);
    close(fd);
    throw calib::InputError("--can " + iface, "", "cannot bind: " + reason);
  }
  int64_t count = 0;
  while (!g_stop_requested) {
    bridge->Beat();
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    can_frame raw{};
    char control[CMSG_SPACE(sizeof(timeval))];
    iovec io{&raw, sizeof raw};
    msghdr msg{};
    msg.msg_iov = &io;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = recvmsg(fd, &msg, 0);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      const std::string reason = std::strerror(errno);
      close(fd);
      throw calib::InputError("--can " + iface, "", "read failed: " + reason);
    }
    if (n < static_cast<ssize_t>(sizeof raw)) continue;
    calib::CanFrame frame;
    frame.utime = agvcal_process::WallMicros();
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP) {
        timeval tv;
        std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
        frame.utime = int64_t(tv.tv_sec) * 1000000 + tv.tv_usec;
      }
    }
    if (raw.can_id & CAN_ERR_FLAG) continue;
    frame.extended = raw.can_id & CAN_EFF_FLAG;
    frame.remote = raw.can_id & CAN_RTR_FLAG;
    frame.id = raw.can_id & (frame.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    frame.data.assign(raw.data, raw.data + std::min<int>(raw.can_dlc, 8));
    bridge->Feed(frame, iface, "frame " + std::to_string(++count));
  }
  close(fd);
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-canbridge");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  if (args.Has("--can") == args.Has("--candump"))
    throw calib::InputError("command line", "", "give exactly one of --can IFACE and --candump FILE");
  if (args.Has("--speed") && !args.Has("--candump"))
    throw calib::InputError("command line", "--speed", "only for --candump replay");
  const double speed = args.GetDouble("--speed", 1.0);
  if (!(speed >= 0)) throw calib::InputError("command line", "--speed", "must be >= 0");
  calib::CanBridgeConfig config = calib::LoadCanBridgeConfig(args.positional[0]);
  if (args.Has("--robot")) {
    const calib::RobotDescription robot = calib::LoadRobotFile(args.Get("--robot", ""));
    for (const std::string& role : calib::WheelRoles(robot.drive)) {
      const std::string& name = robot.wheel_name(role);
      bool found = false;
      for (const calib::CanWheelConfig& w : config.wheels) found = found || w.name == name;
      if (!found)
        throw calib::InputError(config.source_file, "wheels",
                                "no wheel '" + name + "' (role " + role + " in " + robot.source_file + ")");
    }
  }
  if (args.Has("--candump")) calib::CandumpReader probe(args.Get("--candump", ""));  // readable?

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  InstallStopHandlers();
  Bridge bridge(&lcm, std::move(config));
  bridge.Beat(true);
  if (args.Has("--candump"))
    Replay(&bridge, args.Get("--candump", ""), speed);
  else
    Live(&bridge, args.Get("--can", ""));
  bridge.Report();
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-canbridge", Run, argc, argv); }
