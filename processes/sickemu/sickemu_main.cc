// agvcal-sickemu: a SICK CoLa-A scanner emulator on TCP, serving the scans of
// a recording as LMDscandata telegrams with the device's own timestamps, for
// testing agvcal-lidarbridge (and trying it) without a scanner.
#include <netinet/in.h>
#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <random>
#include <thread>

#include "agvcal/laser_scan_t.hpp"
#include "calib/core/errors.h"
#include "calib/devices/sick_cola.h"
#include "calib/io/message_source.h"
#include "common/process_util.h"
#include "common/tcp_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Emulates a SICK scanner speaking CoLa-A on TCP: accepts one client, answers
'sEN LMDscandata 1' with 'sEA LMDscandata 1', then streams the scans of LOG's
channel as 'sSN LMDscandata' telegrams in real time (ranges in whole mm), and
closes the connection and exits at the end of the recording. For testing
agvcal-lidarbridge without a scanner: the bridge stamps each scan by mapping the
device's own clock (a 32-bit microsecond counter in each telegram) onto the host's;
the options below give that clock the faults of a real device (network delay,
a clock running fast, a counter about to wrap) to check the mapping against.)")
      .Positional("LOG", "the recording whose scans it serves")
      .Option("--port", "P", "TCP port (default 2111)")
      .Option("--bind", "ADDR", "IPv4 address to listen on (default 127.0.0.1)")
      .Option("--channel", "SCAN", "the recording's scan channel (default SCAN)")
      .Option("--jitter-ms", "J", "each telegram leaves up to J ms late (uniform, seeded; default 0):\n"
              "network and scheduling delay, which the bridge must not take for\n"
              "the scan's time")
      .Option("--drift-ppm", "D", "the emulated device's clock runs D ppm fast (default 0): a real\n"
              "scanner's oscillator drifts against the host's clock")
      .Option("--boot-us", "B", "the device's clock at the first scan, us (default 4294000000:\n"
              "the 32-bit counter wraps about 1 s later, which the bridge must\n"
              "unwrap)")
      .Option("--seed", "N", "seed of the jitter (default 1): the same seed, the same delays")
      .Footer("Exit status: 0 served the recording, 2 bad log or options, 1 internal error.\n");
}

using agvcal_process::g_stop_requested;
using agvcal_process::WallMicros;

std::vector<agvcal::laser_scan_t> ReadScans(const std::string& path, const std::string& channel) {
  std::vector<agvcal::laser_scan_t> scans;
  calib::RecordingSource recording(path);
  recording.Subscribe<agvcal::laser_scan_t>(
      channel, [&](const agvcal::laser_scan_t& m, const std::string&) { scans.push_back(m); });
  recording.HandleAll();
  if (scans.empty()) throw calib::InputError(path, "", "no " + channel + " messages");
  return scans;
}

void SleepUntil(int64_t wall_us) {
  while (!g_stop_requested) {
    const int64_t left = wall_us - WallMicros();
    if (left <= 0) return;
    std::this_thread::sleep_for(std::chrono::microseconds(std::min<int64_t>(left, 100000)));
  }
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-sickemu");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const double jitter_us = args.GetDouble("--jitter-ms", 0.0) * 1000.0;
  const double drift = args.GetDouble("--drift-ppm", 0.0) * 1e-6;
  const int64_t boot = int64_t(args.GetDouble("--boot-us", 4294000000.0));
  const int port = int(args.GetDouble("--port", 2111));
  if (jitter_us < 0 || port <= 0 || port > 65535)
    throw calib::InputError("command line", "--jitter-ms/--port", "out of range");
  const std::vector<agvcal::laser_scan_t> scans = ReadScans(args.positional[0], args.Get("--channel", "SCAN"));

  const int server = socket(AF_INET, SOCK_STREAM, 0);
  const int on = 1;
  setsockopt(server, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(uint16_t(port));
  if (inet_pton(AF_INET, args.Get("--bind", "127.0.0.1").c_str(), &addr.sin_addr) != 1)
    throw calib::InputError("command line", "--bind", "not an IPv4 address");
  if (bind(server, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || listen(server, 1) != 0)
    throw calib::InputError("command line", "--port " + std::to_string(port), std::strerror(errno));
  InstallStopHandlers();
  std::cerr << "agvcal-sickemu: listening on port " << port << "\n";

  int client = -1;
  while (client < 0 && !g_stop_requested) {
    pollfd p{server, POLLIN, 0};
    if (poll(&p, 1, 100) > 0) client = accept(server, nullptr, nullptr);
  }
  close(server);
  if (client < 0) return calib::kExitOk;
  // Wait for the request to stream.
  calib::StxEtxFramer framer;
  std::string telegram;
  bool streaming = false;
  char buffer[4096];
  while (!streaming && !g_stop_requested) {
    pollfd p{client, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = recv(client, buffer, sizeof buffer, 0);
    if (n <= 0) {
      close(client);
      return calib::kExitOk;
    }
    framer.Append(buffer, std::size_t(n));
    while (framer.Next(&telegram)) {
      const bool start = telegram == "sEN LMDscandata 1";
      SendAll(client, calib::FrameTelegram(start ? "sEA LMDscandata 1" : "sFA 1"));
      streaming = streaming || start;
    }
  }

  std::mt19937_64 rng(uint64_t(args.GetDouble("--seed", 1)));
  std::uniform_real_distribution<double> late(0.0, jitter_us);
  const int64_t first = scans.front().utime;
  const int64_t wall_start = WallMicros() + 100000;
  int64_t sent = 0;
  for (std::size_t i = 0; i < scans.size() && !g_stop_requested; ++i) {
    const agvcal::laser_scan_t& m = scans[i];
    calib::SickScan s = calib::SickScanFromMessage(m, -90.0);
    s.telegram_counter = int(i & 0xFFFF);
    s.scan_counter = int(i & 0xFFFF);
    // The scan ends (n - 1) beams after its start; the device sends it 1 ms later.
    const double transmit_after_us = std::max(0, m.nranges - 1) * double(m.time_increment) * 1e6 + 1000.0;
    auto device = [&](double since_first_us) {
      return uint32_t(uint64_t(boot + std::llround(since_first_us * (1.0 + drift))) & 0xFFFFFFFFu);
    };
    s.time_since_startup_us = device(double(m.utime - first));
    s.time_of_transmission_us = device(double(m.utime - first) + transmit_after_us);
    SleepUntil(wall_start + (m.utime - first) + std::llround(transmit_after_us + late(rng)));
    if (!SendAll(client, calib::FrameTelegram(calib::FormatLmdScandata(s)))) break;
    ++sent;
  }
  close(client);
  std::cerr << "agvcal-sickemu: sent " << sent << " scans\n";
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-sickemu", Run, argc, argv); }
