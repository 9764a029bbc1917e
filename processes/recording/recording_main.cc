// agvcal-recording: what scripts/agvcal-group does to its recording around Debian's lcm-logger
// (scripts/agvcal-group-logger runs it; docs/live.md, "The recording").
#include <lcm/lcm-cpp.hpp>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "agvcal/heartbeat_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/messages.h"
#include "calib/io/process_names.h"
#include "calib/io/recording.h"
#include "calib/io/recording_tail.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(What scripts/agvcal-group does to its recording around Debian's lcm-logger:
  repair RECORDING   cut a recording back to its last whole event (a logger killed while
                     writing leaves a torn one; lcm-logger -a would append after it)
  drain RECORDING    publish the group's mark (HEARTBEAT, process "group") every 150 ms
                     until one is in RECORDING: everything published before it has then
                     been received and written by the logger
  count RECORDING    the recording's messages per channel, on one line)")
      .Positional("COMMAND", "repair, drain or count")
      .Positional("RECORDING", "the group's recording (lcm-logger)")
      .Option("--timeout", "S", "drain: give up after S seconds (default 10)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 done, 1 the mark never reached the recording (drain), 2 unusable input.\n");
}

int Repair(const std::string& path) {
  if (!std::filesystem::exists(path)) return calib::kExitOk;  // a first start: nothing to repair
  const calib::RecordingTail tail = calib::CutToLastWholeEvent(path);
  if (tail.file_size > tail.whole_end)
    std::cerr << "agvcal-recording: " << path << ": cut a torn last event (" << tail.file_size - tail.whole_end
              << " bytes at byte " << tail.whole_end << ", after " << tail.whole_events << " whole events)\n";
  return calib::kExitOk;
}

// True once RECORDING holds a group mark whose state is `mark`; `reader` keeps its place.
bool MarkRecorded(calib::LogReader* reader, const std::string& mark, int64_t* events) {
  calib::LogEvent event;
  while (reader->NextComplete(&event)) {
    ++*events;
    if (event.channel != calib::kHeartbeatChannel) continue;
    agvcal::heartbeat_t beat;
    if (calib::Decode(event.data.data(), int(event.data.size()), &beat) && beat.process == calib::kGroupMarkProcess &&
        beat.state == mark)
      return true;
  }
  return false;
}

int Drain(const std::string& path, double timeout_s, const std::string& url) {
  lcm::LCM lcm(url);
  agvcal_process::RequireGoodBus(lcm, url);
  agvcal::heartbeat_t beat;
  beat.process = calib::kGroupMarkProcess;
  beat.pid = static_cast<int32_t>(getpid());
  beat.state = "draining the logger " + std::to_string(getpid());
  const auto start = std::chrono::steady_clock::now();
  const auto deadline = start + std::chrono::duration<double>(timeout_s);
  int64_t events = 0;
  std::unique_ptr<calib::LogReader> reader;
  // lcm-logger writes a message to the file when it comes more than 100 ms after its last
  // flush: a mark every 150 ms is written, with everything received before it.
  while (std::chrono::steady_clock::now() < deadline) {
    beat.utime = agvcal_process::WallMicros();
    lcm.publish(calib::kHeartbeatChannel, &beat);
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    if (!reader && std::filesystem::exists(path)) reader = std::make_unique<calib::LogReader>(path);
    if (reader && MarkRecorded(reader.get(), beat.state, &events)) {
      const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::cerr << "agvcal-recording: " << path << ": drained: the group's mark is event " << events << " ("
                << waited << " s)\n";
      return calib::kExitOk;
    }
  }
  std::cerr << "agvcal-recording: " << path << ": the group's mark did not reach the recording in " << timeout_s
            << " s (is lcm-logger running on this bus?)\n";
  return calib::kExitInternal;
}

int Count(const std::string& path) {
  std::map<std::string, int64_t> per_channel;
  int64_t total = 0;
  calib::LogReader reader(path);
  calib::LogEvent event;
  while (reader.NextComplete(&event)) {
    ++per_channel[event.channel];
    ++total;
  }
  std::ostringstream line;
  line << total << " messages";
  const char* separator = ": ";
  for (const auto& [channel, count] : per_channel) {
    line << separator << channel << " " << count;
    separator = ", ";
  }
  std::cout << line.str() << "\n";
  return calib::kExitOk;
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-recording");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const std::string& command = args.positional[0];
  const std::string& path = args.positional[1];
  if (command == "repair") return Repair(path);
  if (command == "drain") return Drain(path, args.GetDouble("--timeout", 10.0), args.Get("--lcm-url", ""));
  if (command == "count") return Count(path);
  throw calib::InputError("command line", command, "unknown command (repair, drain or count)");
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-recording", Run, argc, argv); }
