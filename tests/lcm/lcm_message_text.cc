// The C++ half of tests/lcm/lcm_types.sh:
//   lcm_message_text LOG                       every event as `CHANNEL TEXT` (message_text.h)
//   lcm_message_text --write-every-type LOG    a log with one message of every type, each on
//                                              the channel named after its type
#include <lcm/lcm.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "message_text.h"

int main(int argc, char** argv) {
  const bool write = argc == 3 && std::strcmp(argv[1], "--write-every-type") == 0;
  if (argc != 2 && !write) {
    std::fprintf(stderr, "usage: lcm_message_text LOG | --write-every-type LOG\n");
    return 2;
  }
  const char* path = argv[argc - 1];
  lcm_eventlog_t* log = lcm_eventlog_create(path, write ? "w" : "r");
  if (!log) {
    std::fprintf(stderr, "%s: cannot open\n", path);
    return 2;
  }
  if (write) {
    int64_t utime = 1000000;
    for (auto& [channel, bytes] : EveryTypeSample()) {
      lcm_eventlog_event_t event{};
      event.timestamp = utime++;
      event.channellen = static_cast<int32_t>(channel.size());
      event.channel = channel.data();
      event.datalen = static_cast<int32_t>(bytes.size());
      event.data = bytes.data();
      if (lcm_eventlog_write_event(log, &event) != 0) return 1;
    }
  } else {
    while (lcm_eventlog_event_t* event = lcm_eventlog_read_next_event(log)) {
      std::printf("%s %s\n", event->channel, MessageText(event->data, event->datalen).c_str());
      lcm_eventlog_free_event(event);
    }
  }
  lcm_eventlog_destroy(log);
  return 0;
}
