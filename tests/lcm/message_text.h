#pragma once
// The canonical text of a decoded message that the three decodings of tests/lcm/lcm_types.sh
// print alike (C++ here, Java in LcmLogText.java, Python in lcm_log_text.py): the type, then
// every field sorted by name, `name=value`; an integer in decimal, a float or double as the
// 16 hex digits of its IEEE double (a float widened exactly) or `nan`, a string as the hex of
// its UTF-8 bytes in quotes, an array as [a,b,...].

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

inline void Put(std::string& out, int64_t value) { out += std::to_string(value); }
inline void Put(std::string& out, int32_t value) { Put(out, static_cast<int64_t>(value)); }
inline void Put(std::string& out, int16_t value) { Put(out, static_cast<int64_t>(value)); }
inline void Put(std::string& out, int8_t value) { Put(out, static_cast<int64_t>(value)); }
inline void Put(std::string& out, double value) {
  if (std::isnan(value)) {
    out += "nan";
    return;
  }
  uint64_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  char text[20];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(bits));
  out += text;
}
inline void Put(std::string& out, float value) { Put(out, static_cast<double>(value)); }
inline void Put(std::string& out, const std::string& value) {
  out += '"';
  for (unsigned char c : value) {
    char text[3];
    std::snprintf(text, sizeof text, "%02x", c);
    out += text;
  }
  out += '"';
}
template <typename T>
void Put(std::string& out, const std::vector<T>& values);
template <typename T, size_t N>
void Put(std::string& out, const T (&values)[N]);
template <typename T>
void PutArray(std::string& out, const T* values, size_t size) {
  out += '[';
  for (size_t i = 0; i < size; ++i) {
    if (i) out += ',';
    Put(out, values[i]);
  }
  out += ']';
}
template <typename T>
void Put(std::string& out, const std::vector<T>& values) { PutArray(out, values.data(), values.size()); }
template <typename T, size_t N>
void Put(std::string& out, const T (&values)[N]) { PutArray(out, values, N); }

// Deterministic values from a running seed: booleans (int8_t) 0/1, as Java decodes them.
template <typename T>
void Fill(T& value, int& seed) { value = static_cast<T>((seed++ * 37) % 1000 - 500); }
inline void Fill(int8_t& value, int& seed) { value = static_cast<int8_t>(seed++ % 2); }
template <typename T>
void FillReal(T& value, int& seed) {
  const int n = seed++;
  value = n % 11 == 5 ? static_cast<T>(NAN) : n % 13 == 7 ? -static_cast<T>(INFINITY)
                                                           : static_cast<T>(n * 0.371 - 5.0);
}
inline void Fill(double& value, int& seed) { FillReal(value, seed); }
inline void Fill(float& value, int& seed) { FillReal(value, seed); }
inline void Fill(std::string& value, int& seed) { value = "f\xc3\xa9ld " + std::to_string(seed++); }
template <typename T>
void Fill(std::vector<T>& values, int& seed);
template <typename T>
void Fill(std::vector<T>& values, int& seed) { for (T& v : values) Fill(v, seed); }
template <typename T, size_t N>
void Fill(T (&values)[N], int& seed) { for (T& v : values) Fill(v, seed); }

template <typename Message>
std::vector<uint8_t> Encoded(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// Defined in the generated message_text.cc.
std::string MessageText(const void* data, int size);  // "unknown" when no type has its hash
std::vector<std::pair<std::string, std::vector<uint8_t>>> EveryTypeSample();  // (channel, bytes)
