// PCD and KITTI .bin readers (calib/io/cloud_file.h). Own readers rather than
// PCL's io module: small, strict about malformed input, and no PCL headers here.
#include "calib/io/cloud_file.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>

#include "calib/core/errors.h"

namespace calib {

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string Extension(const std::string& path) {
  return Lower(std::filesystem::path(path).extension().string());
}

std::vector<char> ReadBytes(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "", "cannot read " + what + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot read " + what + ": " + std::strerror(errno));
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, "", "cannot read " + what + ": " + std::strerror(errno));
  return bytes;
}

void AddPoint(CloudFileData* out, double x, double y, double z) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
    ++out->dropped;
    return;
  }
  out->xyz.insert(out->xyz.end(), {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
}

// LZF (liblzf's format, as PCL writes it); false if the data are corrupt.
bool LzfDecompress(const uint8_t* in, size_t in_len, uint8_t* out, size_t out_len) {
  const uint8_t* ip = in;
  const uint8_t* const in_end = in + in_len;
  uint8_t* op = out;
  uint8_t* const out_end = out + out_len;
  while (ip < in_end) {
    unsigned ctrl = *ip++;
    if (ctrl < (1u << 5)) {  // literal run of ctrl + 1 bytes
      ++ctrl;
      if (static_cast<size_t>(out_end - op) < ctrl || static_cast<size_t>(in_end - ip) < ctrl) return false;
      std::memcpy(op, ip, ctrl);
      op += ctrl, ip += ctrl;
    } else {  // back reference
      size_t len = ctrl >> 5;
      size_t back = ((ctrl & 0x1f) << 8) + 1;
      if (ip >= in_end) return false;
      if (len == 7) {
        len += *ip++;
        if (ip >= in_end) return false;
      }
      back += *ip++;
      len += 2;
      if (back > static_cast<size_t>(op - out) || static_cast<size_t>(out_end - op) < len) return false;
      const uint8_t* ref = op - back;
      for (size_t k = 0; k < len; ++k) *op++ = *ref++;  // may overlap: byte by byte
    }
  }
  return op == out_end;
}

struct PcdField {
  std::string name;
  int size = 4;
  char type = 'F';
  int count = 1;
  size_t offset = 0;  // within a binary point record
};

[[noreturn]] void FailLine(const std::string& path, int line, const std::string& problem) {
  throw InputError(path, "line " + std::to_string(line), problem);
}

// What a PCD header says (ReadPcd).
struct PcdHeader {
  std::vector<PcdField> fields;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  long long width = -1, height = -1, points = -1;
  Eigen::Vector3d vp_t = Eigen::Vector3d::Zero();
  Eigen::Quaterniond vp_q = Eigen::Quaterniond::Identity();
  std::string data_kind;  // ascii, binary or binary_compressed; empty before the DATA line
  size_t data_start = 0;  // first byte after the DATA line
  int data_line = 0;      // line number of the DATA line
  int ix = -1, iy = -1, iz = -1;  // the fields x, y and z
  size_t record = 0;              // bytes of one point (binary)
};

// One header line, `key` and its `values` (line `line_number` of `path`), into `h`.
void ParsePcdHeaderLine(const std::string& path, int line_number, const std::string& key,
                        const std::vector<std::string>& values, PcdHeader* h) {
  std::vector<PcdField>& fields = h->fields;
  auto number = [&](const std::string& text, const std::string& what) {
    char* stop = nullptr;
    const double v = std::strtod(text.c_str(), &stop);
    if (stop == text.c_str() || *stop != '\0' || !std::isfinite(v))
      FailLine(path, line_number, what + ": '" + text + "' is not a number");
    return v;
  };
  auto whole = [&](const std::string& text, const std::string& what, long long min) {
    const double v = number(text, what);
    if (v != std::floor(v) || v < static_cast<double>(min) || v > 4e9)
      FailLine(path, line_number, what + ": '" + text + "' must be a whole number >= " + std::to_string(min));
    return static_cast<long long>(v);
  };
  auto check_columns = [&](const std::string& what) {
    if (!h->have_fields) FailLine(path, line_number, what + " before FIELDS");
    if (values.size() != fields.size())
      FailLine(path, line_number, what + " has " + std::to_string(values.size()) + " entries for " +
                                      std::to_string(fields.size()) + " FIELDS");
  };
  if (key == "VERSION") {
    return;
  } else if (key == "FIELDS" || key == "COLUMNS") {
    if (values.empty()) FailLine(path, line_number, "FIELDS names no field");
    fields.clear();
    for (const auto& v : values) fields.push_back(PcdField{v});
    h->have_fields = true;
  } else if (key == "SIZE") {
    check_columns("SIZE");
    for (size_t i = 0; i < values.size(); ++i) {
      const long long s = whole(values[i], "SIZE of " + fields[i].name, 1);
      if (s != 1 && s != 2 && s != 4 && s != 8) FailLine(path, line_number, "SIZE of " + fields[i].name + " must be 1, 2, 4 or 8");
      fields[i].size = static_cast<int>(s);
    }
    h->have_size = true;
  } else if (key == "TYPE") {
    check_columns("TYPE");
    for (size_t i = 0; i < values.size(); ++i) {
      if (values[i] != "F" && values[i] != "I" && values[i] != "U")
        FailLine(path, line_number, "TYPE of " + fields[i].name + " must be F, I or U, got '" + values[i] + "'");
      fields[i].type = values[i][0];
    }
    h->have_type = true;
  } else if (key == "COUNT") {
    check_columns("COUNT");
    for (size_t i = 0; i < values.size(); ++i)
      fields[i].count = static_cast<int>(whole(values[i], "COUNT of " + fields[i].name, 1));
    h->have_count = true;
  } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
    if (values.size() != 1) FailLine(path, line_number, key + " needs one number");
    const long long v = whole(values[0], key, key == "POINTS" ? 0 : 1);
    (key == "WIDTH" ? h->width : key == "HEIGHT" ? h->height : h->points) = v;
  } else if (key == "VIEWPOINT") {
    if (values.size() != 7) FailLine(path, line_number, "VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz)");
    double v[7];
    for (int i = 0; i < 7; ++i) v[i] = number(values[i], "VIEWPOINT");
    h->vp_t = {v[0], v[1], v[2]};
    h->vp_q = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
    if (std::abs(h->vp_q.norm() - 1.0) > 1e-3) FailLine(path, line_number, "VIEWPOINT quaternion is not of unit length");
    h->vp_q.normalize();
  } else if (key == "DATA") {
    if (values.size() != 1 || (values[0] != "ascii" && values[0] != "binary" && values[0] != "binary_compressed"))
      FailLine(path, line_number, "DATA must be ascii, binary or binary_compressed");
    h->data_kind = values[0];
  } else {
    FailLine(path, line_number, "unknown header line '" + key + "' (not a PCD file?)");
  }
}

// The header of the PCD file `path` (its `bytes`) up to the DATA line, checked: the
// fields x, y and z, and the point count.
PcdHeader ReadPcdHeader(const std::string& path, const std::vector<char>& bytes) {
  PcdHeader h;
  size_t pos = 0;
  int line_number = 0;
  while (h.data_kind.empty()) {
    if (pos >= bytes.size())
      throw InputError(path, "line " + std::to_string(line_number), "header ends without a DATA line (not a PCD file?)");
    const size_t end = std::find(bytes.begin() + pos, bytes.end(), '\n') - bytes.begin();
    std::string line(bytes.begin() + pos, bytes.begin() + end);
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string key;
    in >> key;
    std::vector<std::string> values;
    for (std::string v; in >> v;) values.push_back(v);
    ParsePcdHeaderLine(path, line_number, key, values, &h);
  }
  h.data_start = pos;
  h.data_line = line_number;
  const int data_line = line_number;
  std::vector<PcdField>& fields = h.fields;
  if (!h.have_fields || !h.have_size || !h.have_type)
    FailLine(path, data_line, "header lacks " + std::string(!h.have_fields ? "FIELDS" : !h.have_size ? "SIZE" : "TYPE"));
  if (!h.have_count)
    for (auto& f : fields) f.count = 1;
  if (h.width < 0 || h.height < 0) FailLine(path, data_line, "header lacks WIDTH or HEIGHT");
  if (static_cast<double>(h.width) * static_cast<double>(h.height) > 4e9)
    FailLine(path, data_line, "WIDTH x HEIGHT is more than 4e9 points");
  if (h.points < 0) h.points = h.width * h.height;
  if (h.points != h.width * h.height)
    FailLine(path, data_line, "POINTS " + std::to_string(h.points) + " differs from WIDTH x HEIGHT " +
                                  std::to_string(h.width * h.height));
  for (size_t i = 0; i < fields.size(); ++i) {
    fields[i].offset = h.record;
    h.record += static_cast<size_t>(fields[i].size) * fields[i].count;
    if (fields[i].name == "x") h.ix = static_cast<int>(i);
    if (fields[i].name == "y") h.iy = static_cast<int>(i);
    if (fields[i].name == "z") h.iz = static_cast<int>(i);
  }
  // A point's values take at least a byte each, in binary or ASCII: a COUNT that makes one point
  // larger than the whole file is corrupt (and must not size an allocation).
  if (h.record > bytes.size())
    FailLine(path, data_line, "SIZE x COUNT gives a point of " + std::to_string(h.record) +
                                  " bytes, more than the whole file (" + std::to_string(bytes.size()) + " bytes)");
  if (h.ix < 0 || h.iy < 0 || h.iz < 0) FailLine(path, data_line, "FIELDS lacks x, y or z");
  for (int i : {h.ix, h.iy, h.iz})
    if (fields[i].type != 'F' || (fields[i].size != 4 && fields[i].size != 8))
      FailLine(path, data_line, "field " + fields[i].name + " must be TYPE F of SIZE 4 or 8");
  return h;
}

// A float field's value (SIZE 4 or 8) at `where`.
double PcdValue(const char* where, const PcdField& f) {
  if (f.size == 4) {
    float v;
    std::memcpy(&v, where, 4);
    return static_cast<double>(v);
  }
  double v;
  std::memcpy(&v, where, 8);
  return v;
}

// Adds the points, given in the header's VIEWPOINT frame, to a cloud in the sensor's frame.
class PcdPoints {
 public:
  PcdPoints(const PcdHeader& h, CloudFileData* out)
      : identity_(h.vp_t.isZero() && h.vp_q.isApprox(Eigen::Quaterniond::Identity())),
        vp_inverse_(h.vp_q.conjugate().toRotationMatrix()),
        vp_t_(h.vp_t),
        out_(out) {}
  void Add(double x, double y, double z) const {
    if (identity_) return AddPoint(out_, x, y, z);
    const Eigen::Vector3d p = vp_inverse_ * (Eigen::Vector3d(x, y, z) - vp_t_);
    AddPoint(out_, p.x(), p.y(), p.z());
  }

 private:
  const bool identity_;
  const Eigen::Matrix3d vp_inverse_;
  const Eigen::Vector3d vp_t_;
  CloudFileData* out_;
};

// DATA ascii: a line of numbers per point (blank lines skipped).
void ReadPcdAscii(const std::string& path, const std::vector<char>& bytes, const PcdHeader& h,
                  const PcdPoints& points, CloudFileData* out) {
  const std::vector<PcdField>& fields = h.fields;
  const size_t n = static_cast<size_t>(h.points);
  size_t pos = h.data_start;
  int line_number = h.data_line;
  size_t columns = 0;
  for (const auto& f : fields) columns += f.count;
  // Column of each of x, y, z.
  auto column_of = [&](int field) {
    size_t c = 0;
    for (int i = 0; i < field; ++i) c += fields[i].count;
    return c;
  };
  const size_t cx = column_of(h.ix), cy = column_of(h.iy), cz = column_of(h.iz);
  out->xyz.reserve(3 * std::min<size_t>(n, 1 << 24));
  size_t read = 0;
  std::vector<double> row(columns);
  while (read < n) {
    if (pos >= bytes.size())
      throw InputError(path, "line " + std::to_string(line_number + 1),
                       "truncated: " + std::to_string(read) + " of " + std::to_string(n) + " points");
    const size_t end = std::find(bytes.begin() + pos, bytes.end(), '\n') - bytes.begin();
    std::string line(bytes.begin() + pos, bytes.begin() + end);
    pos = end + 1;
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const char* p = line.c_str();
    for (size_t c = 0; c < columns; ++c) {
      char* stop = nullptr;
      row[c] = std::strtod(p, &stop);
      if (stop == p)
        throw InputError(path, "line " + std::to_string(line_number),
                         "expected " + std::to_string(columns) + " numbers per point, found " + std::to_string(c));
      p = stop;
    }
    while (*p == ' ' || *p == '\t' || *p == '\r') ++p;
    if (*p != '\0')
      throw InputError(path, "line " + std::to_string(line_number),
                       "more than " + std::to_string(columns) + " values, or not a number: '" + std::string(p) + "'");
    points.Add(row[cx], row[cy], row[cz]);
    ++read;
  }
}

// DATA binary: one record of all fields per point.
void ReadPcdBinary(const std::string& path, const std::vector<char>& bytes, const PcdHeader& h,
                   const PcdPoints& points, CloudFileData* out) {
  const std::vector<PcdField>& fields = h.fields;
  const size_t n = static_cast<size_t>(h.points);
  const size_t pos = h.data_start, record = h.record;
  const size_t data_bytes = bytes.size() - std::min(pos, bytes.size());
  if (data_bytes / record < n)
    throw InputError(path, "byte " + std::to_string(bytes.size()),
                     "truncated: " + std::to_string(n) + " points of " + std::to_string(record) +
                         " bytes need " + std::to_string(n * record) + " bytes after the header, found " +
                         std::to_string(data_bytes));
  out->xyz.reserve(3 * n);
  const char* base = bytes.data() + pos;
  for (size_t i = 0; i < n; ++i) {
    const char* r = base + i * record;
    points.Add(PcdValue(r + fields[h.ix].offset, fields[h.ix]), PcdValue(r + fields[h.iy].offset, fields[h.iy]),
               PcdValue(r + fields[h.iz].offset, fields[h.iz]));
  }
}

// DATA binary_compressed: sizes, then LZF; fields stored one after another.
void ReadPcdCompressed(const std::string& path, const std::vector<char>& bytes, const PcdHeader& h,
                       const PcdPoints& points, CloudFileData* out) {
  const std::vector<PcdField>& fields = h.fields;
  const size_t n = static_cast<size_t>(h.points);
  const size_t pos = h.data_start;
  const size_t data_bytes = bytes.size() - std::min(pos, bytes.size());
  if (data_bytes < 8)
    throw InputError(path, "byte " + std::to_string(pos), "truncated: no compressed-size header after DATA");
  uint32_t compressed = 0, uncompressed = 0;
  std::memcpy(&compressed, bytes.data() + pos, 4);
  std::memcpy(&uncompressed, bytes.data() + pos + 4, 4);
  if (compressed > data_bytes - 8)
    throw InputError(path, "byte " + std::to_string(pos),
                     "truncated: " + std::to_string(compressed) + " compressed bytes announced, " +
                         std::to_string(data_bytes - 8) + " present");
  size_t expected = 0;
  for (const auto& f : fields)
    if (f.name != "_") expected += static_cast<size_t>(f.size) * f.count * n;
  // LZF expands at most ~88 times (a 3-byte reference to 264 bytes): a larger
  // claim is corrupt, and must not make us allocate it.
  if (uncompressed != expected || expected > 90 * static_cast<size_t>(compressed) + 64)
    throw InputError(path, "byte " + std::to_string(pos + 4),
                     "uncompressed size " + std::to_string(uncompressed) + " does not match " +
                         std::to_string(n) + " points of the header's fields (" + std::to_string(expected) + ")");
  std::vector<uint8_t> raw(expected);
  if (expected > 0 &&
      !LzfDecompress(reinterpret_cast<const uint8_t*>(bytes.data() + pos + 8), compressed, raw.data(), raw.size()))
    throw InputError(path, "byte " + std::to_string(pos + 8), "corrupt compressed data (LZF)");
  // Start of each field's block.
  std::vector<size_t> block(fields.size(), 0);
  size_t at = 0;
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i].name == "_") continue;
    block[i] = at;
    at += static_cast<size_t>(fields[i].size) * fields[i].count * n;
  }
  out->xyz.reserve(3 * n);
  auto element = [&](int field, size_t i) {
    const PcdField& f = fields[field];
    return PcdValue(reinterpret_cast<const char*>(raw.data()) + block[field] +
                        i * static_cast<size_t>(f.size) * f.count, f);
  };
  for (size_t i = 0; i < n; ++i) points.Add(element(h.ix, i), element(h.iy, i), element(h.iz, i));
}

}  // namespace

bool IsCloudFileName(const std::string& path) {
  const std::string ext = Extension(path);
  return ext == ".pcd" || ext == ".bin";
}

CloudFileData ReadCloudFile(const std::string& path) {
  const std::string ext = Extension(path);
  if (ext == ".pcd") return ReadPcd(path);
  if (ext == ".bin") return ReadKittiBin(path);
  throw InputError(path, "", "unknown point cloud format '" + ext + "' (expected .pcd or KITTI .bin)");
}

CloudFileData ReadKittiBin(const std::string& path) {
  const std::vector<char> bytes = ReadBytes(path, "KITTI .bin frame");
  constexpr size_t kRecord = 16;  // x y z reflectance, float32 each
  if (bytes.empty()) throw InputError(path, "", "empty file: no points");
  if (bytes.size() % kRecord != 0)
    throw InputError(path, "byte " + std::to_string(bytes.size() - bytes.size() % kRecord),
                     "truncated record: the size " + std::to_string(bytes.size()) +
                         " is not a multiple of 16 bytes (x y z reflectance as float32)");
  CloudFileData out;
  out.format = "kitti";
  const size_t n = bytes.size() / kRecord;
  out.xyz.reserve(3 * n);
  for (size_t i = 0; i < n; ++i) {
    float v[4];
    std::memcpy(v, bytes.data() + i * kRecord, sizeof v);
    AddPoint(&out, v[0], v[1], v[2]);
  }
  return out;
}

CloudFileData ReadPcd(const std::string& path) {
  const std::vector<char> bytes = ReadBytes(path, "PCD file");
  const PcdHeader header = ReadPcdHeader(path, bytes);
  CloudFileData out;
  out.format = "pcd";
  const PcdPoints points(header, &out);
  if (header.data_kind == "ascii") {
    ReadPcdAscii(path, bytes, header, points, &out);
  } else if (header.data_kind == "binary") {
    ReadPcdBinary(path, bytes, header, points, &out);
  } else {
    ReadPcdCompressed(path, bytes, header, points, &out);
  }
  return out;
}

}  // namespace calib
