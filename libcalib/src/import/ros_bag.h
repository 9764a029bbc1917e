#pragma once
// The records of a ROS bag the importers need, whatever its storage (MCAP, rosbag2 SQLite3,
// ROS 1): the messages of chosen topics with their type, serialization and record time, in
// record-time order. Internal to libcalib (importers.h: ImportRosbag2, ImportRosbag).
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace calib::import_internal {

struct BagTopic {
  std::string name;
  std::string type;      // e.g. sensor_msgs/msg/LaserScan (ROS 2) or sensor_msgs/LaserScan (ROS 1)
  std::string encoding;  // message serialization: cdr (ROS 2) or ros1
};

struct BagMessage {
  const BagTopic* topic = nullptr;
  int64_t record_ns = 0;      // the bag's record (log) time
  std::string file, place;    // where it was read, for error messages
  std::vector<uint8_t> data;  // serialized message
};

struct Bag {
  std::map<std::string, BagTopic> topics;  // every topic of the bag, by name
  std::vector<BagMessage> messages;        // those of the wanted topics, by record time
};

// Upper bound on one message or a chunk's uncompressed size (writers' chunks are a few MB at
// most): a corrupt length must be refused before it is allocated.
inline constexpr uint64_t kMaxBagRecordBytes = uint64_t{1} << 28;

// MCAP file (mcap.dev/spec): the data section read record by record, chunks decompressed
// (none, zstd, lz4) and their CRC checked; throws InputError naming the file, "record N (byte
// B)" and the problem for bad magic, a truncated or oversized record, a CRC mismatch, an unknown
// compression or a message of an unknown channel.
void ReadMcap(const std::string& path, const std::set<std::string>& wanted, Bag* bag);

// rosbag2 SQLite3 storage (.db3: tables topics and messages); throws InputError naming the
// file and the row for what SQLite refuses or a message of an unknown topic.
void ReadRosbag2Sqlite(const std::string& path, const std::set<std::string>& wanted, Bag* bag);

// A ROS 1 bag (.bag) through rosbag_storage; throws InputError naming the file for what it
// refuses.
void ReadRosbag1(const std::string& path, const std::set<std::string>& wanted, Bag* bag);

// Sorts the messages by record time, keeping the bag's order otherwise.
void SortByRecordTime(Bag* bag);

}  // namespace calib::import_internal
