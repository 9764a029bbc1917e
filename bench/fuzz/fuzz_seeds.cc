// Writes the binary seeds of the fuzz corpus (bench/fuzz/make_corpus.sh): recordings cut from the
// sample logs, one encoded message of each type, SICK telegrams and candump lines made from the
// sample logs' scans and wheel states. Usage: fuzz_seeds CORPUS_DIR
#include <cstdio>
#include <fstream>
#include <map>
#include <string>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/calib_residual_t.hpp"
#include "agvcal/commander_status_t.hpp"
#include "agvcal/ground_estimate_t.hpp"
#include "agvcal/heartbeat_t.hpp"
#include "agvcal/operator_stop_t.hpp"
#include "calib/devices/canopen.h"
#include "calib/devices/sick_cola.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"

namespace {

const std::string kSource = AGVCAL_SOURCE_DIR;

void Write(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

template <typename Message>
void WriteMessage(const std::string& dir, const std::string& name, uint8_t type, const Message& message) {
  std::vector<uint8_t> bytes = {type};
  const std::vector<uint8_t> encoded = calib::Encode(message);
  bytes.insert(bytes.end(), encoded.begin(), encoded.end());
  Write(dir + "/messages/" + name, bytes);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds CORPUS_DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  const std::map<std::string, uint8_t> types = {{"WHEELS", 0}, {"SCAN", 1}, {"IMU", 2}, {"GROUND_TRUTH", 3},
                                                {"DRIVE_CMD", 6}};
  std::vector<agvcal::wheel_state_t> states;
  std::vector<agvcal::laser_scan_t> scans;
  for (const std::string name : {"forklift", "diff_robot", "dual_steer"}) {
    calib::LogReader reader(kSource + "/logs/" + name + "_demo.log");
    calib::LogWriter cut(dir + "/recording/" + name + ".log");
    calib::LogEvent event;
    std::map<std::string, int> seen;
    for (int i = 0; i < 40 && reader.Next(&event); ++i) {
      cut.Publish(event.channel, event.timestamp, event.data);
      if (seen[event.channel]++ == 0 && types.count(event.channel)) {
        std::vector<uint8_t> bytes = {types.at(event.channel)};
        bytes.insert(bytes.end(), event.data.begin(), event.data.end());
        Write(dir + "/messages/" + name + "_" + event.channel, bytes);
      }
    }
    cut.Close();
    if (name != std::string("forklift")) continue;
    calib::LogReader all(kSource + "/logs/" + name + "_demo.log");
    while (all.Next(&event) && (states.size() < 60 || scans.size() < 3)) {
      if (event.channel == "WHEELS" && states.size() < 60) {
        states.emplace_back();
        calib::Decode(event.data.data(), static_cast<int>(event.data.size()), &states.back());
      } else if (event.channel == "SCAN" && scans.size() < 3) {
        scans.emplace_back();
        calib::Decode(event.data.data(), static_cast<int>(event.data.size()), &scans.back());
      }
    }
  }
  WriteMessage(dir, "point_cloud", 4, agvcal::point_cloud_t{});
  WriteMessage(dir, "mount_angle", 5, agvcal::mount_angle_t{});
  WriteMessage(dir, "scan_match", 7, agvcal::scan_match_t{});
  WriteMessage(dir, "calib_estimate", 8, agvcal::calib_estimate_t{});
  WriteMessage(dir, "calib_residual", 9, agvcal::calib_residual_t{});
  WriteMessage(dir, "commander_status", 10, agvcal::commander_status_t{});
  WriteMessage(dir, "ground_estimate", 11, agvcal::ground_estimate_t{});
  WriteMessage(dir, "heartbeat", 12, agvcal::heartbeat_t{});
  WriteMessage(dir, "operator_stop", 13, agvcal::operator_stop_t{});

  // Three scans as a SICK LMS1xx streams them, the last with intensities.
  std::string stream;
  uint32_t device_us = 1000000;
  for (size_t i = 0; i < scans.size(); ++i) {
    calib::SickScan scan = calib::SickScanFromMessage(scans[i], -90.0);
    scan.telegram_counter = scan.scan_counter = static_cast<int>(i + 1);
    scan.time_since_startup_us = device_us;
    scan.time_of_transmission_us = device_us + 20000;
    device_us += 50000;
    if (i + 1 == scans.size()) scan.rssi.assign(scan.distances.size(), 200);
    stream += calib::FrameTelegram(calib::FormatLmdScandata(scan));
  }
  Write(dir + "/sick_cola/lms1xx.bin", std::vector<uint8_t>(stream.begin(), stream.end()));

  const calib::CanBridgeConfig config = calib::LoadCanBridgeConfig(kSource + "/config/bridges/forklift_can.yaml");
  std::ofstream candump(dir + "/candump/forklift.candump");
  for (const auto& frame : calib::EmulateCanBus(config, states, calib::CanEmulation{0.002, 0.0002, 1}))
    candump << calib::FormatCandumpLine(frame, "can0") << "\n";
  return 0;
}
