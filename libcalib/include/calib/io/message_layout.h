#pragma once
// The encoded layout of the messages of lcmtypes/ (generated at build time into
// agvcal/message_layouts.hpp by lcmtypes/layouts.py), and a check of an encoded
// message's lengths against it. lcm-gen's decoders size every array from the
// length field they read before they know whether the bytes are there: a corrupt
// `nranges` of 2^31 allocates 8 GB and kills the process. CheckEncodedLengths
// walks the bytes first, allocating nothing, so that a decoder only ever sees
// lengths the message can hold.

#include <cstddef>
#include <cstdint>
#include <string>

namespace calib {

// The primitive of a field, as encoded: big-endian integers and IEEE floats; a
// string is an int32 length (with its terminating NUL) and that many bytes.
enum class LayoutKind { kInt8, kInt16, kInt32, kInt64, kFloat, kDouble, kString };

struct LayoutDimension {
  int size;         // a fixed length (field_index < 0)
  int field_index;  // else the index of the earlier integer field holding the length
};

struct LayoutField {
  const char* name;
  LayoutKind kind;
  int num_dims;  // 0 for a scalar
  LayoutDimension dims[2];
};

struct MessageLayout {
  const char* type;  // "agvcal.laser_scan_t"
  const LayoutField* fields;
  int num_fields;
};

// Checks an encoded message (with its 8-byte type hash) of the type lcm-gen calls
// `type_name` ("laser_scan_t", getTypeName()): every length, of an array or a string,
// is non-negative and fits in the bytes left. Returns "" when they do; else the
// problem with the field, its length and the limit ("nranges = 2147483647: ranges
// needs 8589934588 bytes, 1212 are left"). A type without a layout passes.
std::string CheckEncodedLengths(const char* type_name, const uint8_t* data, size_t size);

}  // namespace calib
