// rosbag2's SQLite3 storage (ros_bag.h): table topics(id, name, type, serialization_format, ...)
// and messages(id, topic_id, timestamp, data), read through libsqlite3, never written.
#include <sqlite3.h>
#include <unistd.h>

#include <map>
#include <memory>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"
#include "import/ros_bag.h"

namespace calib::import_internal {

namespace {

using Database = std::unique_ptr<sqlite3, decltype(&sqlite3_close)>;
using Statement = std::unique_ptr<sqlite3_stmt, decltype(&sqlite3_finalize)>;

std::string Text(sqlite3_stmt* statement, int column) {
  const unsigned char* text = sqlite3_column_text(statement, column);
  return text ? reinterpret_cast<const char*>(text) : "";
}

class SqliteBag {
 public:
  explicit SqliteBag(const std::string& path) : path_(path), db_(nullptr, sqlite3_close) {
    const InputFile file = OpenInputFile(path, "rosbag2 SQLite3 file");  // the usual refusals
    ::close(file.fd);
    if (file.stream) throw InputError(path, "", "SQLite needs a regular file, not a pipe");
    sqlite3* raw = nullptr;
    const int status = sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
    db_.reset(raw);
    if (status != SQLITE_OK) Fail("opening", status);
  }

  Statement Prepare(const char* sql, const std::string& what) {
    sqlite3_stmt* raw = nullptr;
    const int status = sqlite3_prepare_v2(db_.get(), sql, -1, &raw, nullptr);
    if (status != SQLITE_OK) Fail(what, status);
    return Statement(raw, sqlite3_finalize);
  }

  // Steps `statement`: true for a row, false at the end.
  bool Step(sqlite3_stmt* statement, const std::string& place) {
    const int status = sqlite3_step(statement);
    if (status == SQLITE_ROW) return true;
    if (status != SQLITE_DONE) Fail(place, status);
    return false;
  }

  [[noreturn]] void Fail(const std::string& place, int status) const {
    const char* message = db_ ? sqlite3_errmsg(db_.get()) : sqlite3_errstr(status);
    throw InputError(path_, place, std::string("SQLite: ") + message +
                                       " (not a rosbag2 SQLite3 file, or a corrupt one)");
  }

 private:
  const std::string& path_;
  Database db_;
};

}  // namespace

void ReadRosbag2Sqlite(const std::string& path, const std::set<std::string>& wanted, Bag* bag) {
  SqliteBag db(path);
  std::map<int64_t, const BagTopic*> topics;
  Statement list = db.Prepare("SELECT id, name, type, serialization_format FROM topics",
                              "table topics");
  while (db.Step(list.get(), "table topics")) {
    BagTopic topic{Text(list.get(), 1), Text(list.get(), 2), Text(list.get(), 3)};
    topics[sqlite3_column_int64(list.get(), 0)] = &(bag->topics[topic.name] = topic);
  }
  Statement rows = db.Prepare(
      "SELECT id, topic_id, timestamp, data FROM messages ORDER BY timestamp, id", "table messages");
  while (db.Step(rows.get(), "table messages")) {
    const std::string place = "messages row id " + std::to_string(sqlite3_column_int64(rows.get(), 0));
    const auto topic = topics.find(sqlite3_column_int64(rows.get(), 1));
    if (topic == topics.end())
      throw InputError(path, place, "topic_id " + std::to_string(sqlite3_column_int64(rows.get(), 1)) +
                                        " is not in table topics");
    if (!wanted.count(topic->second->name)) continue;
    BagMessage message;
    message.topic = topic->second;
    message.record_ns = sqlite3_column_int64(rows.get(), 2);
    message.file = path;
    message.place = place;
    const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(rows.get(), 3));
    message.data.assign(data, data + sqlite3_column_bytes(rows.get(), 3));
    bag->messages.push_back(std::move(message));
  }
  SortByRecordTime(bag);
}

}  // namespace calib::import_internal
