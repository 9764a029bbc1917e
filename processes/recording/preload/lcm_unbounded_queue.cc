// Preloaded into Debian's lcm-logger by scripts/agvcal-group-logger (LD_PRELOAD): every
// subscription it makes keeps all the messages it has not handled yet. LCM keeps at most 30
// per subscription by default and silently drops the rest while the subscriber's thread is
// held up (a loaded machine), and lcm-logger sets no other limit; the group's own processes
// lift the limit themselves (processes/common/bus_source.h). lcm-logger's own limit, on
// received but unwritten bytes (-m, 100 MB), still holds.
#include <dlfcn.h>
#include <lcm/lcm.h>

extern "C" lcm_subscription_t* lcm_subscribe(lcm_t* lcm, const char* channel, lcm_msg_handler_t handler,
                                             void* userdata) {
  using Subscribe = lcm_subscription_t* (*)(lcm_t*, const char*, lcm_msg_handler_t, void*);
  static const auto real = reinterpret_cast<Subscribe>(dlsym(RTLD_NEXT, "lcm_subscribe"));
  lcm_subscription_t* subscription = real(lcm, channel, handler, userdata);
  if (subscription) lcm_subscription_set_queue_capacity(subscription, 0);  // 0: no limit
  return subscription;
}
