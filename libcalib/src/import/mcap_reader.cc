// MCAP files (ros_bag.h), from the specification at mcap.dev/spec: magic, records of
// opcode (1 byte) + length (8 bytes) + content, little endian; chunks hold records of their own.
#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <cstring>
#include <map>
#include <memory>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"
#include "import/ros_bag.h"

namespace calib::import_internal {

namespace {

constexpr char kMagic[] = "\x89MCAP0\r\n";
constexpr size_t kMagicSize = 8;
constexpr size_t kRecordHeader = 9;
enum Opcode : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05,
  kChunk = 0x06, kDataEnd = 0x0F
};
// A bag is read whole, like every importer's input.
constexpr size_t kMaxFileBytes = size_t{4} << 30;
// LZ4 cannot expand data more than 255-fold (one byte per 255 of a run).
constexpr uint64_t kMaxLz4Ratio = 255;

// Reads the fields of one record's content; a field past its end is the record's problem.
class Fields {
 public:
  Fields(const uint8_t* data, size_t size, const std::string& file, std::string place)
      : data_(data), size_(size), file_(file), place_(std::move(place)) {}
  template <typename T>
  T Number() {
    T value;
    std::memcpy(&value, Take(sizeof(T)), sizeof(T));  // MCAP and every supported host: little endian
    return value;
  }
  std::string String() {
    const uint32_t length = Number<uint32_t>();
    const uint8_t* bytes = Take(length);
    return std::string(reinterpret_cast<const char*>(bytes), length);
  }
  const uint8_t* Take(uint64_t n) {
    if (n > size_ - at_) Fail("record shorter than its fields (corrupt or truncated)");
    const uint8_t* p = data_ + at_;
    at_ += n;
    return p;
  }
  size_t remaining() const { return size_ - at_; }
  const std::string& place() const { return place_; }
  [[noreturn]] void Fail(const std::string& problem) const { throw InputError(file_, place_, problem); }

 private:
  const uint8_t* data_;
  size_t size_, at_ = 0;
  const std::string& file_;
  std::string place_;
};

class McapReader {
 public:
  McapReader(const std::string& path, const std::set<std::string>& wanted, Bag* bag)
      : path_(path), wanted_(wanted), bag_(bag) {}

  void Read() {
    const std::string file = ReadWholeFile(path_, "MCAP file", kMaxFileBytes);
    const auto* data = reinterpret_cast<const uint8_t*>(file.data());
    if (file.size() < kMagicSize || std::memcmp(data, kMagic, kMagicSize) != 0)
      throw InputError(path_, "byte 0", "not an MCAP file (no MCAP magic)");
    size_t at = kMagicSize;
    for (;;) {
      const std::string place = Place(at);
      if (file.size() - at < kRecordHeader)
        throw InputError(path_, place, "truncated: the file ends before the data section does "
                                       "(no DataEnd record)");
      const uint8_t opcode = data[at];
      uint64_t length;
      std::memcpy(&length, data + at + 1, 8);
      if (length > file.size() - at - kRecordHeader)
        throw InputError(path_, place, "truncated: record of " + std::to_string(length) +
                                           " bytes, " + std::to_string(file.size() - at - kRecordHeader) +
                                           " left in the file");
      Fields fields(data + at + kRecordHeader, length, path_, place);
      if (opcode == kDataEnd) {
        CheckDataCrc(fields.Number<uint32_t>(), data, at, place);
        break;
      }
      if (opcode == kFooter) throw InputError(path_, place, "footer before the DataEnd record");
      if (opcode == kChunk) {
        ReadChunk(&fields);
      } else {
        Dispatch(opcode, &fields);
      }
      at += kRecordHeader + length;
      ++record_;
    }
    if (std::memcmp(data + file.size() - kMagicSize, kMagic, kMagicSize) != 0)
      throw InputError(path_, "end of file", "truncated: no closing MCAP magic");
  }

 private:
  std::string Place(size_t byte) const {
    return "record " + std::to_string(record_) + " (byte " + std::to_string(byte) + ")";
  }

  void CheckDataCrc(uint32_t expected, const uint8_t* data, size_t end, const std::string& place) {
    if (expected == 0) return;  // 0: the writer did not compute it
    const uint32_t actual = static_cast<uint32_t>(crc32_z(0L, data, end));
    if (actual != expected)
      throw InputError(path_, place, "data section CRC mismatch (corrupt file)");
  }

  void Dispatch(uint8_t opcode, Fields* f) {
    if (opcode == kSchema) {
      const uint16_t id = f->Number<uint16_t>();
      const std::string name = f->String();
      f->String();  // encoding: the type name is all the decoders need
      schemas_[id] = name;
    } else if (opcode == kChannel) {
      const uint16_t id = f->Number<uint16_t>();
      const uint16_t schema = f->Number<uint16_t>();
      BagTopic topic;
      topic.name = f->String();
      topic.encoding = f->String();
      const auto found = schemas_.find(schema);
      if (schema != 0 && found == schemas_.end())
        f->Fail("channel " + topic.name + " names schema " + std::to_string(schema) +
                ", which no earlier record defines");
      topic.type = schema == 0 ? "" : found->second;
      channels_[id] = &(bag_->topics[topic.name] = topic);
    } else if (opcode == kMessage) {
      const uint16_t id = f->Number<uint16_t>();
      f->Number<uint32_t>();  // sequence
      const uint64_t log_time = f->Number<uint64_t>();
      f->Number<uint64_t>();  // publish time
      const auto channel = channels_.find(id);
      if (channel == channels_.end())
        f->Fail("message on channel " + std::to_string(id) + ", which no earlier record defines");
      if (!wanted_.count(channel->second->name)) return;
      BagMessage message;
      message.topic = channel->second;
      message.record_ns = static_cast<int64_t>(log_time);
      message.file = path_;
      message.place = f->place();
      const size_t n = f->remaining();
      const uint8_t* bytes = f->Take(n);
      message.data.assign(bytes, bytes + n);
      bag_->messages.push_back(std::move(message));
    }
    // Other records (attachments, metadata, indexes, statistics) carry nothing imported.
  }

  void ReadChunk(Fields* f) {
    f->Number<uint64_t>();  // message start time
    f->Number<uint64_t>();  // message end time
    const uint64_t size = f->Number<uint64_t>();
    const uint32_t crc = f->Number<uint32_t>();
    const std::string compression = f->String();
    const uint64_t length = f->Number<uint64_t>();
    const uint8_t* records = f->Take(length);
    if (size > kMaxBagRecordBytes)
      f->Fail("chunk of " + std::to_string(size) + " bytes uncompressed, more than any bag needs");
    std::vector<uint8_t> plain = Decompress(f, compression, records, length, size);
    if (crc != 0 && static_cast<uint32_t>(crc32_z(0L, plain.data(), plain.size())) != crc)
      f->Fail("chunk CRC mismatch (corrupt chunk)");
    size_t at = 0;
    for (int64_t inner_record = 0; at < plain.size(); ++inner_record) {
      if (plain.size() - at < kRecordHeader) f->Fail("truncated record inside the chunk");
      uint64_t inner;
      std::memcpy(&inner, plain.data() + at + 1, 8);
      if (inner > plain.size() - at - kRecordHeader)
        f->Fail("record inside the chunk longer than the chunk (corrupt chunk)");
      Fields fields(plain.data() + at + kRecordHeader, inner, path_,
                    f->place() + ", its record " + std::to_string(inner_record));
      Dispatch(plain[at], &fields);
      at += kRecordHeader + inner;
    }
  }

  // A chunk's size checked against what its compressed bytes can hold before it is allocated.
  static void CheckSize(Fields* f, const std::string& compression, const uint8_t* in, uint64_t length,
                        uint64_t size) {
    bool plausible = true;
    if (compression.empty()) plausible = length == size;
    if (compression == "zstd") {
      const unsigned long long content = ZSTD_getFrameContentSize(in, length);
      // The first frame's size when it says it (a chunk may hold several frames).
      plausible = content == ZSTD_CONTENTSIZE_UNKNOWN || content <= size;
    }
    if (compression == "lz4") plausible = size <= kMaxLz4Ratio * length + 1024;
    if (!plausible)
      f->Fail(std::to_string(length) + " bytes of " + (compression.empty() ? "uncompressed" : compression) +
              " chunk cannot hold the " + std::to_string(size) + " it says (corrupt chunk)");
  }

  std::vector<uint8_t> Decompress(Fields* f, const std::string& compression, const uint8_t* in,
                                  uint64_t length, uint64_t size) {
    CheckSize(f, compression, in, length, size);
    std::vector<uint8_t> out(size);
    if (compression.empty()) {
      if (size) std::memcpy(out.data(), in, size);
    } else if (compression == "zstd") {
      const size_t n = ZSTD_decompress(out.data(), size, in, length);
      if (ZSTD_isError(n)) f->Fail(std::string("zstd chunk: ") + ZSTD_getErrorName(n));
      if (n != size) f->Fail("zstd chunk decompresses to " + std::to_string(n) + " bytes, says " +
                             std::to_string(size));
    } else if (compression == "lz4") {
      DecompressLz4(f, in, length, &out);
    } else {
      f->Fail("unknown chunk compression '" + compression + "' (known: none, zstd, lz4)");
    }
    return out;
  }

  static void DecompressLz4(Fields* f, const uint8_t* in, size_t length, std::vector<uint8_t>* out) {
    LZ4F_dctx* raw = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) f->Fail("lz4: no memory");
    const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> context(
        raw, LZ4F_freeDecompressionContext);
    size_t written = 0, read = 0;
    for (;;) {
      size_t out_size = out->size() - written, in_size = length - read;
      const size_t hint = LZ4F_decompress(context.get(), out->data() + written, &out_size,
                                          in + read, &in_size, nullptr);
      if (LZ4F_isError(hint)) f->Fail(std::string("lz4 chunk: ") + LZ4F_getErrorName(hint));
      written += out_size;
      read += in_size;
      if (hint == 0) break;
      if (in_size == 0 && out_size == 0)
        f->Fail(read == length ? "lz4 chunk: truncated" : "lz4 chunk: larger than it says");
    }
    if (written != out->size())
      f->Fail("lz4 chunk decompresses to " + std::to_string(written) + " bytes, says " +
              std::to_string(out->size()));
  }

  const std::string& path_;
  const std::set<std::string>& wanted_;
  Bag* bag_;
  int64_t record_ = 0;
  std::map<uint16_t, std::string> schemas_;
  std::map<uint16_t, const BagTopic*> channels_;
};

}  // namespace

void ReadMcap(const std::string& path, const std::set<std::string>& wanted, Bag* bag) {
  McapReader(path, wanted, bag).Read();
  SortByRecordTime(bag);
}

}  // namespace calib::import_internal
