#include "sim/world_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calib/core/errors.h"

namespace calib {

namespace {

constexpr int kPillarSides = 16;

double ParseNumber(const std::string& token, const std::string& element, size_t field,
                   const std::string& origin, const std::string& place) {
  const char* begin = token.c_str();
  char* end = nullptr;
  const double value = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || !std::isfinite(value)) {
    throw InputError(
        origin, place,
        "'" + token + "' is not a number (field " + std::to_string(field) + " of " + element + ")");
  }
  return value;
}

}  // namespace

std::vector<WallSegment> ParseWorldSegments(const std::string& text, const std::string& origin) {
  std::vector<WallSegment> segments;
  double height = 3.0;
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string place = "line " + std::to_string(line_number);
    line = line.substr(0, line.find('#'));
    std::istringstream words(line);
    std::string element;
    if (!(words >> element)) continue;
    std::vector<double> v;
    for (std::string token; words >> token;) {
      v.push_back(ParseNumber(token, element, v.size() + 1, origin, place));
    }
    auto expect_fields = [&](size_t n, const char* usage) {
      if (v.size() != n && v.size() != n + 1) {
        throw InputError(
            origin, place,
            element + " takes " + usage + ", got " + std::to_string(v.size()) + " numbers");
      }
    };
    // The optional last field is the element's height; it must be positive
    // or the element would be invisible to every lidar.
    auto element_height = [&](size_t n) {
      const double h = v.size() > n ? v[n] : height;
      if (h <= 0.0) {
        throw InputError(origin, place,
                         element + " height must be positive, got " + std::to_string(h));
      }
      return h;
    };
    if (element == "height") {
      if (v.size() != 1) {
        throw InputError(origin, place,
                         "height takes 1 number (H), got " + std::to_string(v.size()));
      }
      if (v[0] <= 0.0) {
        throw InputError(origin, place, "height must be positive, got " + std::to_string(v[0]));
      }
      height = v[0];
    } else if (element == "wall") {
      expect_fields(4, "4 numbers and an optional height (X1 Y1 X2 Y2 [H])");
      const Eigen::Vector2d a(v[0], v[1]), b(v[2], v[3]);
      if (a == b) throw InputError(origin, place, "wall has zero length");
      segments.push_back({a, b, element_height(4)});
    } else if (element == "box") {
      expect_fields(4, "4 numbers and an optional height (XMIN YMIN XMAX YMAX [H])");
      if (v[2] <= v[0] || v[3] <= v[1]) {
        throw InputError(origin, place,
                         "box has a negative or zero size (needs XMIN < XMAX and YMIN < YMAX)");
      }
      const double h = element_height(4);
      const Eigen::Vector2d c[4] = {{v[0], v[1]}, {v[2], v[1]}, {v[2], v[3]}, {v[0], v[3]}};
      for (int i = 0; i < 4; ++i) segments.push_back({c[i], c[(i + 1) % 4], h});
    } else if (element == "pillar") {
      expect_fields(3, "3 numbers and an optional height (CX CY R [H])");
      if (v[2] <= 0.0) {
        throw InputError(origin, place,
                         "pillar radius must be positive, got " + std::to_string(v[2]));
      }
      const double h = element_height(3);
      // Vertices on the circle; the facets lie at most R(1 - cos(pi/16)) =
      // 0.019 R inside it.
      std::vector<Eigen::Vector2d> c(kPillarSides);
      for (int i = 0; i < kPillarSides; ++i) {
        const double angle = 2.0 * M_PI * i / kPillarSides;
        c[i] = {v[0] + v[2] * std::cos(angle), v[1] + v[2] * std::sin(angle)};
      }
      for (int i = 0; i < kPillarSides; ++i) {
        segments.push_back({c[i], c[(i + 1) % kPillarSides], h});
      }
    } else {
      throw InputError(origin, place,
                       "unknown element '" + element + "' (expected height, wall, box or pillar)");
    }
  }
  if (segments.empty()) {
    throw InputError(origin, "", "no wall, box or pillar in the world file");
  }
  return segments;
}

std::vector<WallSegment> LoadWorldSegments(const std::string& path_or_name) {
  std::string path = path_or_name;
  const bool bundled = path_or_name.find('/') == std::string::npos &&
                       std::filesystem::path(path_or_name).extension().empty();
  if (bundled) path = std::string(AGVCAL_SOURCE_DIR) + "/config/worlds/" + path_or_name + ".world";
  std::ifstream in(path);
  if (!in) {
    if (!bundled) throw InputError(path, "", "cannot open world file");
    // List the bundled worlds so a typo in a name is easy to fix.
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(
             std::string(AGVCAL_SOURCE_DIR) + "/config/worlds", ec)) {
      if (entry.path().extension() == ".world") names.push_back(entry.path().stem().string());
    }
    std::sort(names.begin(), names.end());
    std::string known;
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    throw InputError(path_or_name, "",
                     "no bundled world of that name (looked for " + path +
                         "; bundled: " + (known.empty() ? "none" : known) + ")");
  }
  std::stringstream text;
  text << in.rdbuf();
  return ParseWorldSegments(text.str(), path);
}

}  // namespace calib
