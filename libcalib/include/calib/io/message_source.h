#pragma once
// One seam for messages, from the bus or from a recording (in the spirit of
// Drake's DrakeLcmInterface, with DrakeLcm on the bus and DrakeLcmLog over a
// log): a consumer subscribes handlers to channels, then lets the source handle
// messages, so that a live process and an offline command run the same code on
// the same messages. Implementations: RecordingSource (below: an lcm-logger
// recording, in its order) and agvcal_process::BusSource
// (processes/common/bus_source.h: the LCM bus).
//
// A bad message, one that does not decode or whose handler throws InputError
// (a conversion of messages.h refusing it), meets the source's policy:
//   - over a recording, the InputError leaves HandleNext, naming the file and
//     the event ("run.log: event 12 (WHEELS): does not decode as wheel_state_t");
//   - on the bus, the message is skipped, counted and reported on stderr, and
//     the process goes on.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"

namespace calib {

class MessageSource {
 public:
  // Gets a message's encoded bytes.
  using RawHandler = std::function<void(const std::string& channel, const uint8_t* data, size_t size)>;

  virtual ~MessageSource() = default;

  // Calls `handler` for every message on `channel` (a name, not a pattern), in the
  // order they come; the handlers of one channel in the order of subscription.
  virtual void SubscribeRaw(const std::string& channel, RawHandler handler) = 0;

  // The same, decoded as `Message` (an lcm-gen type); `origin` names the message for the
  // conversions of messages.h. A message that does not decode is a bad message (above).
  template <typename Message>
  void Subscribe(const std::string& channel,
                 std::function<void(const Message& message, const std::string& origin)> handler);

  // Handles the next message, waiting at most `timeout_ms` for it (the bus; a recording
  // does not wait). False when none was handled: none came in time, or done().
  virtual bool HandleNext(int timeout_ms) = 0;
  // No message will be handled any more: the end of the recording (or of the log of LCM's
  // file:// provider), or a stop (RequestStop(); on the bus also SIGINT/SIGTERM).
  virtual bool done() const = 0;
  // Handles messages until done().
  void HandleAll();
  void RequestStop() { stop_requested_ = true; }

  // Inside a handler: where the message being handled comes from, as InputError's file
  // and place (a recording: its path and "event N (CHANNEL)"; the bus: the channel and
  // ""), and both joined ("run.log: event 12 (WHEELS)"): the `origin` of messages.h.
  virtual std::string file() const = 0;
  virtual std::string place() const = 0;
  std::string origin() const;

  // A message that decoded and converted but is left out (a wheel sample that cannot be
  // physically true, a stamp out of order: core/wheel_track.h's WheelSampleGate): counted,
  // the first kMaxDropNotes kept ("run.log: event 12 (WHEELS): wheel 'drive' position jumps
  // ..."), each passed to the handler of set_on_drop. The owner says them (stderr, notes of
  // RESULT.json); the source goes on.
  static constexpr std::size_t kMaxDropNotes = 20;
  void Drop(const std::string& origin, const std::string& problem);
  int64_t dropped() const { return dropped_; }
  const std::vector<std::string>& drop_notes() const { return drop_notes_; }
  void set_on_drop(std::function<void(const std::string& note)> handler) { on_drop_ = std::move(handler); }

  // What a subscription holds back to the end of the input (a wheel sample after a long
  // gap, until its successor shows the gap real): `flush` passes it on. Called by Finish,
  // which a RecordingSource calls at the recording's end and a live process before its
  // final result.
  void AtFinish(std::function<void()> flush) { finishers_.push_back(std::move(flush)); }
  void Finish();

 protected:
  bool stop_requested() const { return stop_requested_; }

 private:
  bool stop_requested_ = false;
  int64_t dropped_ = 0;
  std::vector<std::string> drop_notes_;
  std::function<void(const std::string&)> on_drop_;
  std::vector<std::function<void()>> finishers_;
  bool finished_ = false;
};

// An lcm-logger recording as a MessageSource: its events in file order, each handled
// once. A corrupt or truncated log, like a bad message, throws InputError.
class RecordingSource : public MessageSource {
 public:
  enum class Mode {
    kComplete,  // the whole recording; done() at its end
    kGrowing,   // a log still being written (LogReader::NextComplete): HandleNext is false at
                // its last complete event and goes on from there later; never done() by itself
  };
  // Throws InputError if the file cannot be opened.
  explicit RecordingSource(const std::string& path, Mode mode = Mode::kComplete);

  void SubscribeRaw(const std::string& channel, RawHandler handler) override;
  bool HandleNext(int timeout_ms) override;  // never waits
  bool done() const override { return ended_ || stop_requested(); }
  std::string file() const override { return reader_.path(); }
  std::string place() const override;

  // The event handled last.
  const LogEvent& event() const { return event_; }

 private:
  LogReader reader_;
  Mode mode_;
  LogEvent event_;
  bool ended_ = false;
  std::map<std::string, std::vector<RawHandler>> handlers_;
};

// Subscriptions that hand over plain data: each decodes its channel's messages and
// converts them with messages.h (the conversion's InputError makes a bad message);
// `robot` is copied. SubscribeWheels passes the samples through a WheelSampleGate
// (core/wheel_track.h): what it drops goes to the source's Drop.
void SubscribeWheels(MessageSource* source, const RobotDescription& robot,
                     std::function<void(const WheelSample&)> handler);  // WHEELS
void SubscribeScans(MessageSource* source, const std::string& channel,
                    std::function<void(LaserScan)> handler);
void SubscribeScanMatches(MessageSource* source,
                          std::function<void(const SensorMotion&)> handler);  // SCAN_MATCH
void SubscribePoses(MessageSource* source, const std::string& channel,
                    std::function<void(const StampedPose&)> handler);
void SubscribeImu(MessageSource* source, const std::string& channel,
                  std::function<void(const ImuSample&)> handler);
void SubscribeDriveCommands(MessageSource* source, const RobotDescription& robot,
                            std::function<void(const DriveCommand&)> handler);  // DRIVE_CMD
void SubscribeClouds(MessageSource* source, const std::string& channel,
                     std::function<void(const PointCloud&)> handler);
void SubscribeMountAngles(MessageSource* source, const std::string& channel,
                          std::function<void(const MountAngle&)> handler);

template <typename Message>
void MessageSource::Subscribe(const std::string& channel,
                              std::function<void(const Message& message, const std::string& origin)> handler) {
  SubscribeRaw(channel, [this, handler = std::move(handler)](const std::string&, const uint8_t* data,
                                                             size_t size) {
    Message message;
    std::string why;
    if (!Decode(data, static_cast<int>(size), &message, &why))
      throw InputError(file(), place(), std::string("does not decode as ") + Message::getTypeName() + ": " + why);
    handler(message, origin());
  });
}

}  // namespace calib
