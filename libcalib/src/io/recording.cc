#include "calib/io/recording.h"

#include <cerrno>
#include <cstring>

#include <sys/stat.h>

#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"

namespace calib {

namespace {
constexpr uint32_t kSyncWord = 0xEDA1DA01;
constexpr int32_t kMaxChannelLength = 256;     // LCM's own limit on channel names
constexpr int32_t kMaxDataLength = 1 << 28;    // 256 MiB: anything larger is corruption

uint64_t ReadBigEndian(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

void PutBigEndian(uint64_t v, int bytes, std::vector<uint8_t>* out) {
  for (int i = bytes - 1; i >= 0; --i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}
}  // namespace

LogReader::LogReader(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
}

LogReader::~LogReader() {
  if (file_) std::fclose(file_);
}

bool LogReader::Next(LogEvent* event) { return Read(event, false); }

bool LogReader::NextComplete(LogEvent* event) { return Read(event, true); }

bool LogReader::Read(LogEvent* event, bool incomplete_tail_is_end) {
  // An event still being written: back to its start, for a later call.
  auto tail = [&]() {
    std::clearerr(file_);
    std::fseek(file_, static_cast<long>(offset_), SEEK_SET);
    return false;
  };
  const std::string place =
      "event " + std::to_string(count_) + " at byte " + std::to_string(offset_);
  uint8_t header[28];
  const size_t got = std::fread(header, 1, sizeof(header), file_);
  if (got == 0 && std::feof(file_)) return incomplete_tail_is_end ? tail() : false;
  if (got < sizeof(header) && incomplete_tail_is_end) return tail();
  if (got < sizeof(header)) throw InputError(path_, place, "truncated event header (log cut short)");
  if (ReadBigEndian(header, 4) != kSyncWord)
    throw InputError(path_, place, "bad sync word: not an LCM log, or corrupt");
  event->event_number = static_cast<int64_t>(ReadBigEndian(header + 4, 8));
  event->timestamp = static_cast<int64_t>(ReadBigEndian(header + 12, 8));
  const int32_t channel_length = static_cast<int32_t>(ReadBigEndian(header + 20, 4));
  const int32_t data_length = static_cast<int32_t>(ReadBigEndian(header + 24, 4));
  if (channel_length <= 0 || channel_length > kMaxChannelLength)
    throw InputError(path_, place, "implausible channel name length " + std::to_string(channel_length));
  if (data_length < 0 || data_length > kMaxDataLength)
    throw InputError(path_, place, "implausible message length " + std::to_string(data_length));
  // Nothing is allocated for bytes the file does not hold (a corrupt length of up to 256 MiB
  // would otherwise be zero-filled first): such an event is truncated, or the growing tail.
  struct stat info {};
  const uint64_t body_at = offset_ + sizeof(header);
  if (fstat(fileno(file_), &info) != 0 ||
      static_cast<uint64_t>(info.st_size) < body_at + uint64_t(channel_length) + uint64_t(data_length)) {
    if (incomplete_tail_is_end) return tail();
    throw InputError(path_, place, "truncated event (log cut short): its header says " +
                                       std::to_string(int64_t(channel_length) + data_length) +
                                       " bytes follow, the file holds " +
                                       std::to_string(info.st_size > int64_t(body_at) ? info.st_size - body_at : 0));
  }
  event->channel.resize(channel_length);
  event->data.resize(data_length);
  if (std::fread(event->channel.data(), 1, channel_length, file_) != size_t(channel_length) ||
      std::fread(event->data.data(), 1, data_length, file_) != size_t(data_length)) {
    if (incomplete_tail_is_end) return tail();
    throw InputError(path_, place, "truncated event (log cut short)");
  }
  event->offset = offset_;
  offset_ += sizeof(header) + channel_length + data_length;
  ++count_;
  return true;
}

LogWriter::LogWriter(const std::string& path) : path_(path), file_(OpenOutput(path, &partial_path_)) {}

LogWriter::~LogWriter() {
  if (file_) {
    std::fclose(file_);
    if (!partial_path_.empty()) std::remove(partial_path_.c_str());
  }
}

void LogWriter::Publish(const std::string& channel, int64_t utime,
                        const std::vector<uint8_t>& data) {
  std::vector<uint8_t> header;
  header.reserve(28 + channel.size());
  PutBigEndian(kSyncWord, 4, &header);
  PutBigEndian(static_cast<uint64_t>(count_), 8, &header);
  PutBigEndian(static_cast<uint64_t>(utime), 8, &header);
  PutBigEndian(channel.size(), 4, &header);
  PutBigEndian(data.size(), 4, &header);
  header.insert(header.end(), channel.begin(), channel.end());
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size() ||
      std::fwrite(data.data(), 1, data.size(), file_) != data.size())
    throw InputError(path_, "event " + std::to_string(count_), "write failed (disk full?)");
  ++count_;
}

void LogWriter::Close() {
  if (!file_) return;
  std::FILE* file = file_;
  file_ = nullptr;
  try {
    CommitOutput(path_, file, &partial_path_);
  } catch (const InputError& e) {
    throw InputError(path_, "", "could not finish writing the log: " + e.problem());
  }
}

}  // namespace calib
