#include <iomanip>
#include <iostream>

#include <nlohmann/json.hpp>

#include "calib/core/errors.h"
#include "calib/io/log_summary.h"
#include "commands.h"
#include "common/command_line.h"

namespace agvcal_cli {

namespace {
// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Lists the channels of an lcm-logger recording: message type, count, time span
and rate (from the messages' utime), and messages out of time order or with
duplicated stamps. A torn event (an lcm-logger killed mid-write) is skipped to the
next valid event and named ("skipped: bytes B-E ..."), with the span of data lost;
channel names are shown with unprintable bytes as \xNN.)")
      .Positional("LOG", "the recording (lcm-logger)")
      .Flag("--json", "print the summary as JSON (channels with type, count, first and last\n"
            "utime, rate, out-of-order and duplicated counts)")
      .Footer("Exit status: 0 listed; 2 not an LCM log, or a message that does not decode as\n"
              "the type of docs/spec/messages.md; 1 internal error.\n");
}
}  // namespace

int Info(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal info");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const calib::LogSummary summary = calib::SummarizeLog(args.positional[0]);
  if (args.Has("--json")) {
    nlohmann::json out;
    out["events"] = summary.events;
    for (const auto& [name, ch] : summary.channels)
      out["channels"][calib::PrintableChannel(name)] = {{"type", ch.type},
                               {"count", ch.count},
                               {"first_utime", ch.first_utime},
                               {"last_utime", ch.last_utime},
                               {"rate_hz", ch.rate_hz},
                               {"out_of_order", ch.out_of_order},
                               {"duplicated", ch.duplicated}};
    for (const calib::LogSkip& skip : summary.skipped)
      out["skipped"].push_back({{"begin", skip.begin}, {"end", skip.end}, {"before_utime", skip.before_utime},
                                {"after_utime", skip.after_utime}, {"problem", skip.problem}});
    std::cout << out.dump(2) << "\n";
    return calib::kExitOk;
  }
  std::cout << std::left << std::setw(18) << "channel" << std::setw(20) << "type" << std::right
            << std::setw(9) << "count" << std::setw(10) << "span s" << std::setw(10) << "rate Hz"
            << "  problems\n";
  for (const auto& [name, ch] : summary.channels) {
    std::cout << std::left << std::setw(18) << calib::PrintableChannel(name) << std::setw(20)
              << (ch.type.empty() ? "?" : ch.type) << std::right << std::setw(9) << ch.count
              << std::setw(10) << std::fixed << std::setprecision(2)
              << (ch.last_utime - ch.first_utime) * 1e-6 << std::setw(10) << std::setprecision(1)
              << ch.rate_hz << "  ";
    if (ch.out_of_order) std::cout << ch.out_of_order << " out of order ";
    if (ch.duplicated) std::cout << ch.duplicated << " duplicated stamps";
    std::cout << "\n";
  }
  for (const calib::LogSkip& skip : summary.skipped) std::cout << "skipped: " << skip.Describe() << "\n";
  return calib::kExitOk;
}

}  // namespace agvcal_cli
