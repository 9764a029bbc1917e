#include "common/bus_source.h"

#include <exception>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include "calib/core/errors.h"

namespace agvcal_process {

BusSource::BusSource(const std::string& url, std::string program)
    : lcm_(url), program_(std::move(program)), from_file_(url.rfind("file://", 0) == 0) {
  RequireGoodBus(lcm_, url);
  // Left-out samples are said as they come (the first few: a broken encoder would flood).
  set_on_drop([this](const std::string& note) {
    if (dropped() <= int64_t(kMaxDropNotes)) std::cerr << program_ << ": left out: " << note << "\n";
  });
}

std::string BusSource::InputNote() const {
  std::string note;
  if (skipped_ > 0)
    note += "; " + std::to_string(skipped_) + (skipped_ == 1 ? " bad message" : " bad messages") + " skipped";
  if (dropped() > 0) note += "; " + std::to_string(dropped()) + " left out";
  return note;
}

void BusSource::SubscribeRaw(const std::string& channel, RawHandler handler) {
  auto [it, added] = handlers_.try_emplace(channel);
  if (added) {
    channels_.push_back(channel);
    lcm::Subscription* subscription = lcm_.subscribe(channel, &BusSource::OnMessage, this);
    if (subscription) subscription->setQueueCapacity(0);  // 0: no limit
  }
  it->second.push_back(std::move(handler));
}

bool BusSource::done() const { return ended_ || stop_requested() || g_stop_requested; }

bool BusSource::HandleNext(int timeout_ms) {
  if (done()) return false;
  return Wait(timeout_ms);
}

bool BusSource::Wait(int timeout_ms) {
  const int status = lcm_.handleTimeout(timeout_ms);
  if (error_) throw std::runtime_error(*error_);
  if (status < 0) {
    if (from_file_) {
      ended_ = true;  // the file provider's log has ended
    } else if (!g_stop_requested) {
      throw std::runtime_error("receiving from the LCM bus failed");
    }
  }
  return status > 0;
}

void BusSource::HandleQueued(double limit_s) {
  const int64_t stop = WallMicros();
  const int64_t until = stop + static_cast<int64_t>(limit_s * 1e6);
  // A process starved by a loaded machine can be seconds behind the bus: past the limit it
  // still handles what arrived before the stop (the kernel's receive time), and ends at the
  // first message that came after it (a source that goes on publishing).
  while (Wait(50)) {
    if (WallMicros() >= until && last_arrival_ > stop) break;
  }
}

void BusSource::OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const auto* data = static_cast<const uint8_t*>(buffer->data);
  last_arrival_ = buffer->recv_utime;
  if (!holding_) return Offer(channel, data, buffer->data_size);
  if (const auto stamp = calib::LeadingStamp(data, buffer->data_size)) tracker_->Live(channel, *stamp);
  held_.emplace_back(channel, std::vector<uint8_t>(data, data + buffer->data_size));
}

void BusSource::Offer(const std::string& channel, const uint8_t* data, size_t size) {
  if (once_per_stamp_) {
    // A message too short for a stamp passes: its decoder rejects it.
    const auto stamp = calib::LeadingStamp(data, size);
    if (stamp && !filter_.Accept(channel, *stamp)) return;
  }
  Deliver(channel, data, size);
}

void BusSource::Deliver(const std::string& channel, const uint8_t* data, size_t size) {
  const auto it = handlers_.find(channel);
  if (it == handlers_.end()) return;
  ++received_[channel];
  channel_ = channel;
  for (const RawHandler& handler : it->second) {
    try {
      handler(channel, data, size);
    } catch (const calib::InputError& e) {
      if (skipped_++ == 0) std::cerr << program_ << ": ignoring a message (reported once): " << e.what() << "\n";
    } catch (const std::exception& e) {
      if (!error_) error_ = e.what();
      RequestStop();
    } catch (...) {
      if (!error_) error_ = "a handler of " + channel + " threw a non-standard exception";
      RequestStop();
    }
  }
}

int64_t BusSource::received(const std::string& channel) const {
  const auto it = received_.find(channel);
  return it == received_.end() ? 0 : it->second;
}

int64_t BusSource::CatchUp(const std::string& recording, Heartbeat* heartbeat, double limit_s) {
  constexpr int64_t kQuietUs = 2000000;  // a channel silent this long live has nothing missing
  DeliverOncePerStamp();
  holding_ = true;
  tracker_.emplace(channels_, kQuietUs);
  const int64_t start = WallMicros();
  std::optional<calib::RecordingSource> log;
  int64_t recovered = 0;
  while (!done()) {
    Wait(20);
    if (!log && std::filesystem::exists(recording)) {
      log.emplace(recording, calib::RecordingSource::Mode::kGrowing);
      for (const std::string& channel : channels_) {
        log->SubscribeRaw(channel, [&](const std::string& c, const uint8_t* data, size_t size) {
          if (const auto stamp = calib::LeadingStamp(data, size)) tracker_->Recorded(c, *stamp);
          Offer(c, data, size);
          ++recovered;
        });
      }
    }
    while (log && log->HandleNext(0)) {
    }
    const int64_t elapsed = WallMicros() - start;
    if (log && tracker_->Complete(elapsed)) break;
    if (elapsed > limit_s * 1e6) {
      std::cerr << program_ << ": catching up from " << recording << " took over " << limit_s
                << " s; messages may be missing on " << tracker_->Pending(elapsed) << "\n";
      break;
    }
    if (heartbeat) heartbeat->Beat("catching up");
  }
  holding_ = false;
  for (const auto& [channel, bytes] : held_) Offer(channel, bytes.data(), bytes.size());
  held_.clear();
  std::cerr << program_ << ": caught up: " << recovered << " messages from " << recording << ", "
            << duplicates() << " duplicates dropped\n";
  return recovered;
}

}  // namespace agvcal_process
