#pragma once
// The LCM bus as a calib::MessageSource (calib/io/message_source.h): what every
// process that listens does with the bus, in one place.
//   - Every subscription keeps every message (no queue limit: LCM's default of
//     30 per subscription drops messages while the process is busy, and one lost
//     WHEELS message changes every later live result).
//   - A bad message (it does not decode, or its handler throws InputError) is
//     skipped, counted and reported once on stderr. Any other exception of a
//     handler stops the source, and HandleNext throws it: no exception crosses
//     LCM's C callbacks (Drake's rule).
//   - HandleNext throws when receiving fails (handleTimeout < 0) unless a stop
//     was requested; with LCM's file:// provider that is the end of its log:
//     done(), not an error.
//   - Optionally each message is delivered once, in stamp order per channel, and
//     a (re)started process first catches up from the group's recording.
// Handlers run in the thread that calls HandleNext, HandleQueued or CatchUp.

#include <lcm/lcm-cpp.hpp>

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calib/io/message_source.h"
#include "calib/live/catch_up.h"
#include "common/process_util.h"

namespace agvcal_process {

class BusSource : public calib::MessageSource {
 public:
  // Opens the bus at `url` ("" = LCM_DEFAULT_URL or LCM's default); throws
  // calib::InputError naming the URL if it does not open. `program` prefixes what
  // is said on stderr ("agvcal-solver").
  BusSource(const std::string& url, std::string program);
  BusSource(const BusSource&) = delete;
  BusSource& operator=(const BusSource&) = delete;

  void SubscribeRaw(const std::string& channel, RawHandler handler) override;
  bool HandleNext(int timeout_ms) override;
  // The file:// provider's log has ended, a stop was requested (RequestStop, or
  // SIGINT/SIGTERM: g_stop_requested), or a handler failed.
  bool done() const override;
  std::string file() const override { return channel_; }  // the channel of the message
  std::string place() const override { return ""; }

  // On stop: handles the messages already received or still arriving (until 50 ms
  // pass without one), so that what was sent before the stop is not lost with the
  // queue. After `limit_s` wall seconds only those that arrived before the call.
  void HandleQueued(double limit_s = 2.0);

  // From now on each message is delivered once, in stamp order per channel
  // (calib/live/catch_up.h): one older than or as old as the last delivered on its
  // channel is dropped (counted in duplicates()).
  void DeliverOncePerStamp() { once_per_stamp_ = true; }
  // Catching up after a (re)start (docs/live.md): reads `recording` (lcm-logger's file,
  // still being written; waited for if it does not exist yet) until it reaches the first
  // live message of every subscribed channel, at most `limit_s` wall seconds, holding the
  // live messages meanwhile, then delivers those. Turns DeliverOncePerStamp on. Progress
  // and any gap left are reported on stderr. Returns the number of messages taken from
  // the recording.
  int64_t CatchUp(const std::string& recording, Heartbeat* heartbeat, double limit_s = 10.0);

  // Messages delivered on `channel` so far (bad ones included): what the process
  // received, to compare with a recording's counts.
  int64_t received(const std::string& channel) const;
  int64_t skipped() const { return skipped_; }     // bad messages
  // "; 2 bad messages skipped; 1 left out" (skipped(), dropped()), or "" when none.
  std::string InputNote() const;
  // The heartbeat's state carries InputNote() from now on (and so the dashboard).
  void ReportOn(Heartbeat* heartbeat) {
    heartbeat->set_note([this] { return InputNote(); });
  }
  int64_t duplicates() const { return filter_.rejected(); }

  // The bus, for publishing.
  lcm::LCM& lcm() { return lcm_; }

 private:
  void OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void Offer(const std::string& channel, const uint8_t* data, size_t size);
  void Deliver(const std::string& channel, const uint8_t* data, size_t size);
  // One lcm.handleTimeout with its checks; true if a message came.
  bool Wait(int timeout_ms);

  lcm::LCM lcm_;
  std::string program_;
  bool from_file_ = false;
  bool ended_ = false;
  std::vector<std::string> channels_;  // in the order of first subscription
  std::map<std::string, std::vector<RawHandler>> handlers_;
  std::map<std::string, int64_t> received_;
  std::string channel_;                // of the message being delivered
  int64_t skipped_ = 0;
  int64_t last_arrival_ = 0;           // receive time of the last message (LCM's recv_utime)
  std::optional<std::string> error_;   // the first failure of a handler
  bool once_per_stamp_ = false;
  calib::StampFilter filter_;
  bool holding_ = false;               // catching up: live messages are held
  std::optional<calib::CatchUpTracker> tracker_;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> held_;
};

}  // namespace agvcal_process
