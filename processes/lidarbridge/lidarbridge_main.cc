// agvcal-lidarbridge: a SICK 2D lidar over Ethernet (CoLa-A) -> SCAN. A TCP
// client that asks the device to stream scans and reconnects when it drops;
// decoding and the device-clock mapping are libcalib's SickScanDecoder.
#include <lcm/lcm-cpp.hpp>

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <thread>

#include "calib/core/errors.h"
#include "calib/devices/sick_cola.h"
#include "common/process_util.h"
#include "common/tcp_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Lidar bridge for SICK LMS1xx/LMS5xx/TiM scanners (CoLa-A over TCP): connects,
sends 'sEN LMDscandata 1' and publishes every scan as laser_scan_t on SCAN (or
the config's channel). Stamps come from the device's clock, mapped to the
host's by a minimum-delay fit (no network jitter baked in). Reconnects when
the connection drops; stops on Ctrl-C.)")
      .Positional("CONFIG.yaml", "the bridge config (config/bridges/sick_lms1xx.yaml)")
      .Option("--host", "HOST", "the scanner's address (required)")
      .Option("--port", "P", "TCP port (default 2111)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 stopped, 2 bad config or options, 1 internal error.\n");
}

using agvcal_process::g_stop_requested;
using agvcal_process::WallMicros;

// A scanner streams tens of scans a second: this long without a byte on an open connection is
// a stalled device (or link), said once, while the bridge keeps waiting on it.
constexpr int64_t kStalledUs = 2000000;

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-lidarbridge");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  if (!args.Has("--host")) throw calib::InputError("command line", "--host", "missing (the scanner's address)");
  const std::string host = args.Get("--host", "");
  const std::string port = args.Get("--port", "2111");
  const calib::SickBridgeConfig config = calib::LoadSickBridgeConfig(args.positional[0]);
  const std::string origin = host + ":" + port;

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  InstallStopHandlers();
  Heartbeat heartbeat(&lcm, "lidarbridge");
  calib::SickScanDecoder decoder(config);
  int64_t telegrams = 0, scans = 0, bad = 0, connections = 0;
  std::string last_error;
  while (!g_stop_requested) {
    heartbeat.Beat("connecting to " + origin, true);
    std::string error;
    const int fd = ConnectTcp(host, port, &error);
    if (fd < 0) {
      if (error != last_error) std::cerr << "agvcal-lidarbridge: " << origin << ": " << error << "; retrying\n";
      last_error = error;
      for (int i = 0; i < 10 && !g_stop_requested; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      continue;
    }
    last_error.clear();
    ++connections;
    std::cerr << "agvcal-lidarbridge: connected to " << origin << "\n";
    decoder.Reset();  // the device may have restarted: its clock with it
    calib::StxEtxFramer framer;
    bool open = SendAll(fd, calib::FrameTelegram("sEN LMDscandata 1"));
    char buffer[65536];
    int64_t last_data = WallMicros();
    bool stalled = false;
    while (open && !g_stop_requested) {
      const int64_t silent = WallMicros() - last_data;
      heartbeat.Beat(stalled ? "stalled: no data from " + origin + " for " + std::to_string(silent / 1000000) + " s, " +
                                   std::to_string(scans) + " scans"
                             : "streaming " + std::to_string(scans) + " scans");
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) {
        if (!stalled && WallMicros() - last_data > kStalledUs) {
          stalled = true;
          std::cerr << "agvcal-lidarbridge: " << origin << ": no data for " << kStalledUs / 1000000
                    << " s on an open connection (the device stalled?); waiting for it\n";
        }
        continue;
      }
      const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
      const int64_t arrival = WallMicros();
      if (stalled && n > 0)
        std::cerr << "agvcal-lidarbridge: " << origin << ": data again after " << (arrival - last_data) / 1000 << " ms\n";
      if (n > 0) last_data = arrival, stalled = false;
      if (n <= 0) {
        if (n < 0 && errno == EINTR) continue;
        open = false;
        break;
      }
      framer.Append(buffer, std::size_t(n));
      std::string telegram;
      while (framer.Next(&telegram)) {
        ++telegrams;
        if (!calib::IsLmdScandata(telegram)) {
          if (telegram.rfind("sFA", 0) == 0)
            std::cerr << "agvcal-lidarbridge: " << origin << " reports error " << telegram << "\n";
          continue;
        }
        // A corrupt telegram is reported and skipped; the stream goes on.
        try {
          const calib::SickScan scan = calib::ParseLmdScandata(telegram, origin, telegrams);
          const agvcal::laser_scan_t msg = decoder.Decode(scan, arrival, origin, telegrams);
          lcm.publish(config.channel, &msg);
          ++scans;
        } catch (const calib::InputError& e) {
          if (++bad <= 10) std::cerr << "agvcal-lidarbridge: skipping: " << e.what() << "\n";
        }
      }
    }
    close(fd);
    if (!g_stop_requested) std::cerr << "agvcal-lidarbridge: " << origin << " closed the connection; reconnecting\n";
  }
  heartbeat.Beat("stopped", true);
  std::cerr << "agvcal-lidarbridge: stopped; " << scans << " scans, " << bad << " bad telegrams, "
            << decoder.scans_lost() << " scans lost, " << connections << " connections, clock rate "
            << decoder.clock().rate() << "\n";
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-lidarbridge", Run, argc, argv); }
