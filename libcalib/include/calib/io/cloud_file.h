#pragma once
// Point clouds from files made elsewhere, for the ground calibration:
//  - PCD (PCL's format, versions 0.6/0.7): DATA ascii, binary or
//    binary_compressed (LZF); fields x, y, z of type F (4 or 8 bytes), other
//    fields skipped; a VIEWPOINT other than the identity is undone, so that
//    the points are in the sensor frame.
//  - KITTI Velodyne .bin: little-endian float32 records x y z reflectance,
//    sensor frame, m.
// Every problem is an InputError naming the file, the place (line or byte)
// and what is wrong. Points that are not finite (no return) are dropped.

#include <cstddef>
#include <string>
#include <vector>

namespace calib {

struct CloudFileData {
  std::vector<float> xyz;     // interleaved x, y, z, sensor frame, m
  size_t dropped = 0;         // non-finite points left out
  std::string format;         // "pcd" or "kitti"
};

// By extension: .pcd, or .bin (KITTI); InputError for anything else.
CloudFileData ReadCloudFile(const std::string& path);
CloudFileData ReadPcd(const std::string& path);
CloudFileData ReadKittiBin(const std::string& path);

// True for the extensions ReadCloudFile reads.
bool IsCloudFileName(const std::string& path);

}  // namespace calib
