#include "calib/io/message_layout.h"

#include <cstring>
#include <vector>

#include "agvcal/message_layouts.hpp"

namespace calib {
namespace {

size_t PrimitiveSize(LayoutKind kind) {
  switch (kind) {
    case LayoutKind::kInt8: return 1;
    case LayoutKind::kInt16: return 2;
    case LayoutKind::kInt32:
    case LayoutKind::kFloat:
    case LayoutKind::kString: return 4;  // a string's length field at least
    case LayoutKind::kInt64:
    case LayoutKind::kDouble: return 8;
  }
  return 1;
}

int64_t ReadBigEndian(const uint8_t* p, size_t bytes) {
  uint64_t v = 0;
  for (size_t i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  const int bits = static_cast<int>(8 * bytes);
  if (bits < 64 && (v >> (bits - 1)) & 1) v |= ~uint64_t{0} << bits;  // sign-extend
  return static_cast<int64_t>(v);
}

const MessageLayout* FindLayout(const char* type_name) {
  for (const MessageLayout& layout : kMessageLayouts) {
    const char* dot = std::strrchr(layout.type, '.');
    if (std::strcmp(dot ? dot + 1 : layout.type, type_name) == 0) return &layout;
  }
  return nullptr;
}

}  // namespace

std::string CheckEncodedLengths(const char* type_name, const uint8_t* data, size_t size) {
  const MessageLayout* layout = FindLayout(type_name);
  if (!layout || size < 8) return "";  // the decoder refuses a message without its hash
  std::vector<int64_t> scalars(layout->num_fields, 0);
  size_t pos = 8;
  auto left = [&]() { return size - pos; };
  for (int f = 0; f < layout->num_fields; ++f) {
    const LayoutField& field = layout->fields[f];
    // The number of elements, each dimension checked before it multiplies.
    int64_t count = 1;
    for (int d = 0; d < field.num_dims; ++d) {
      const LayoutDimension& dim = field.dims[d];
      const int64_t n = dim.field_index < 0 ? dim.size : scalars[dim.field_index];
      const std::string what =
          dim.field_index < 0 ? std::to_string(n) : std::string(layout->fields[dim.field_index].name) +
                                                        " = " + std::to_string(n);
      if (n < 0) return what + ": a negative length for " + field.name;
      const size_t element = PrimitiveSize(field.kind);
      if (n > 0 && static_cast<uint64_t>(count) > left() / element / static_cast<uint64_t>(n))
        return what + ": " + field.name + " needs at least " +
               std::to_string(static_cast<unsigned long long>(count) * static_cast<unsigned long long>(n) *
                              element) +
               " bytes, " + std::to_string(left()) + " are left";
      count *= n;
    }
    if (field.kind != LayoutKind::kString) {
      const size_t bytes = PrimitiveSize(field.kind) * static_cast<size_t>(count);  // fits: checked above
      if (left() < bytes) return std::string(field.name) + ": the message ends inside it";
      if (field.num_dims == 0 && field.kind != LayoutKind::kFloat && field.kind != LayoutKind::kDouble)
        scalars[f] = ReadBigEndian(data + pos, bytes);
      pos += bytes;
      continue;
    }
    for (int64_t i = 0; i < count; ++i) {
      if (left() < 4) return std::string(field.name) + ": the message ends inside it";
      const int64_t length = ReadBigEndian(data + pos, 4);
      pos += 4;
      if (length < 0 || static_cast<uint64_t>(length) > left())
        return std::string(field.name) + ": a string of " + std::to_string(length) + " bytes, " +
               std::to_string(left()) + " are left";
      pos += static_cast<size_t>(length);
    }
  }
  return "";
}

}  // namespace calib
