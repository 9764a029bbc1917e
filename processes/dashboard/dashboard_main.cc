// agvcal-dashboard: the terminal dashboard (ncurses). Listens to every channel
// of the bus and shows the solver's residuals and estimates, the observability
// state, message rates and staleness, process health and the commander's state.
// The state lives in calib::DashboardModel; this file wires LCM and the keys.
#include <lcm/lcm-cpp.hpp>
#include <ncurses.h>
#include <poll.h>
#include <unistd.h>

#include <clocale>
#include <cstring>
#include <langinfo.h>
#include <optional>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/calib_residual_t.hpp"
#include "agvcal/commander_status_t.hpp"
#include "agvcal/heartbeat_t.hpp"
#include "agvcal/scan_match_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/log_summary.h"
#include "calib/io/messages.h"
#include "calib/live/dashboard_model.h"
#include "common/process_util.h"
#include "dashboard/dashboard_view.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Terminal dashboard of a live process group or an lcm-logplayer replay: the
solver's residuals per component (time plot and histogram), each parameter's
estimate with its sigma and convergence, the observability state, message rates
(on the bus, and of the data from its own timestamps) and staleness per channel,
process health from HEARTBEAT, the commander's state.)")
      .Option("--stale-after", "S", "a channel or process silent for longer than S s is stale (default 3)")
      .Flag("--ascii", "plain ASCII plots (default when the locale is not UTF-8)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Keys: 1 overview, 2 residuals, 3 parameters, 4 bus (channels, processes,\n"
              "commander), p pause/resume, ? help, q quit. Needs a terminal of 80x24 or more.\n"
              "Exit status: 0 quit (q, Ctrl-C, SIGTERM), 2 bad option or bus, 1 internal.\n");
}

// Feeds every message on the bus into the model. LCM calls this from C: nothing may throw.
class Listener {
 public:
  explicit Listener(calib::DashboardModel* model) : model_(model) {}

  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    try {
      Handle(rbuf, channel);
    } catch (const std::exception&) {
      // The model only keeps data; a failure here loses one message's display, nothing else.
    }
  }

 private:
  template <typename M>
  bool Read(const lcm::ReceiveBuffer* rbuf, M* message) {
    return calib::Decode(rbuf->data, static_cast<int>(rbuf->data_size), message);
  }

  void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (channel == "LCM_SELF_TEST") return;  // LCM's own probe when a bus opens
    const int64_t now = rbuf->recv_utime;
    std::string type;
    bool decoded = true;
    std::optional<int64_t> utime;
    if (channel == calib::kCalibEstimateChannel) {
      agvcal::calib_estimate_t m;
      type = "calib_estimate_t";
      if ((decoded = Read(rbuf, &m))) {
        utime = m.utime;
        model_->OnEstimate(m, now);
      }
    } else if (channel == calib::kCalibResidualsChannel) {
      agvcal::calib_residual_t m;
      type = "calib_residual_t";
      if ((decoded = Read(rbuf, &m))) {
        utime = m.utime_end;
        model_->OnResidual(m);
      }
    } else if (channel == calib::kScanMatchChannel) {
      agvcal::scan_match_t m;
      type = "scan_match_t";
      if ((decoded = Read(rbuf, &m))) utime = m.utime_end;
    } else if (const auto stamp = calib::StampOf(channel, static_cast<const uint8_t*>(rbuf->data),
                                                 rbuf->data_size)) {
      type = stamp->type;
      decoded = stamp->decoded;
      if (decoded) utime = stamp->utime;
      if (decoded && channel == calib::kHeartbeatChannel) {
        agvcal::heartbeat_t m;
        if (Read(rbuf, &m)) model_->OnHeartbeat(m, now);
        utime.reset();  // wall-clock beats of several processes: no data rate of one source
      } else if (decoded && channel == calib::kCommanderStatusChannel) {
        agvcal::commander_status_t m;
        if (Read(rbuf, &m)) model_->OnCommanderStatus(m, now);
      }
    }
    model_->OnMessage(channel, type, decoded, utime, now);
  }

  calib::DashboardModel* model_;
};

// initscr() in the constructor, endwin() in the destructor: the terminal is
// restored on every way out, exceptions included.
class CursesSession {
 public:
  CursesSession() {
    if (!isatty(STDIN_FILENO) || !isatty(STDOUT_FILENO))
      throw calib::InputError("terminal", "stdin/stdout", "not a terminal (run it in one)");
    if (!initscr()) throw calib::InputError("terminal", "TERM", "ncurses cannot use this terminal");
    cbreak();
    noecho();
    keypad(stdscr, TRUE);
    nodelay(stdscr, TRUE);
    curs_set(0);
  }
  ~CursesSession() { endwin(); }
  CursesSession(const CursesSession&) = delete;
  CursesSession& operator=(const CursesSession&) = delete;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-dashboard");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  calib::DashboardOptions options;
  options.stale_after_s = args.GetDouble("--stale-after", options.stale_after_s);
  if (!(options.stale_after_s > 0))
    throw calib::InputError("command line", "--stale-after", "must be > 0");

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  calib::DashboardModel model(options);
  Listener listener(&model);
  // LCM's default queue of 30 messages per subscription drops what arrives while the screen
  // is drawn: the solver's final burst of CALIB_RESIDUALS (one per interval) then shows fewer
  // intervals than its CALIB_ESTIMATE. A bounded larger queue keeps them; a flood beyond it
  // still cannot grow the dashboard without limit.
  if (lcm::Subscription* all = lcm.subscribe(".*", &Listener::OnMessage, &listener))
    all->setQueueCapacity(100000 /* messages */);

  std::setlocale(LC_ALL, "");
  agvcal_dashboard::ViewState state;
  if (args.Has("--ascii") || std::strcmp(nl_langinfo(CODESET), "UTF-8") != 0)
    state.glyphs = calib::Glyphs::kAscii;
  InstallStopHandlers();  // before initscr(), which then leaves SIGINT and SIGTERM to us
  CursesSession session;
  agvcal_dashboard::InitColors(&state);

  std::optional<calib::DashboardModel> frozen;  // what a paused screen shows
  int64_t frozen_at = 0, last_draw = 0;
  bool dirty = true;
  while (!g_stop_requested) {
    pollfd fds[2] = {{lcm.getFileno(), POLLIN, 0}, {STDIN_FILENO, POLLIN, 0}};
    poll(fds, 2, 100 /* ms */);
    // Drain the bus, but keep the keys responsive under a flood.
    for (int i = 0; i < 2000 && lcm.handleTimeout(0) > 0; ++i) {
    }
    for (int key = getch(); key != ERR; key = getch()) {
      dirty = true;
      if (state.help && key != KEY_RESIZE) {
        state.help = false;
        continue;
      }
      switch (key) {
        case 'q': case 'Q': g_stop_requested = true; break;
        case '1': state.view = agvcal_dashboard::View::kOverview; break;
        case '2': state.view = agvcal_dashboard::View::kResiduals; break;
        case '3': state.view = agvcal_dashboard::View::kParameters; break;
        case '4': state.view = agvcal_dashboard::View::kBus; break;
        case '?': case 'h': state.help = true; break;
        case 'p': case 'P': case ' ':
          state.paused = !state.paused;
          if (state.paused) {
            frozen = model;
            frozen_at = WallMicros();
          } else {
            frozen.reset();
          }
          break;
        default: break;  // KEY_RESIZE: ncurses has updated LINES and COLS; redraw
      }
    }
    const int64_t now = WallMicros();
    if (g_stop_requested || (!dirty && now - last_draw < 250000)) continue;
    if (frozen)
      agvcal_dashboard::Draw(*frozen, frozen_at, state);
    else
      agvcal_dashboard::Draw(model, now, state);
    last_draw = now;
    dirty = false;
  }
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-dashboard", Run, argc, argv); }
