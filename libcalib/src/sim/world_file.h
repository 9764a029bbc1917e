#pragma once
// The world file (format in calib/sim/world.h) read into the wall faces of a World: boxes
// become their four sides, pillars 16-sided prisms. Kept apart from the ray casting.

#include <string>
#include <vector>

#include "calib/sim/world.h"

namespace calib {

// Parses world-file text; `origin` names it in errors. Throws InputError naming origin and line;
// a text without any wall, box or pillar is an error (most likely the wrong file).
std::vector<WallSegment> ParseWorldSegments(const std::string& text, const std::string& origin);

// Reads and parses a world file; a name without '/' and without extension is looked up in the
// bundled config/worlds (an unknown bundled name lists the bundled ones).
std::vector<WallSegment> LoadWorldSegments(const std::string& path_or_name);

}  // namespace calib
