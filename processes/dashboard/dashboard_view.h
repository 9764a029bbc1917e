#pragma once
// Drawing of the dashboard's views with ncurses, from a DashboardModel. Every
// view fits the terminal's current size (80x24 and up; smaller terminals get
// what fits) and is redrawn whole each time, so a resize only needs a redraw.

#include <cstdint>

#include "calib/io/text_plot.h"
#include "calib/live/dashboard_model.h"

namespace agvcal_dashboard {

enum class View { kOverview = 1, kResiduals = 2, kParameters = 3, kBus = 4 };

struct ViewState {
  View view = View::kOverview;
  bool paused = false;
  bool help = false;
  calib::Glyphs glyphs = calib::Glyphs::kUnicode;
  bool color = false;
};

// Sets up the colour pairs (when the terminal has colours); call after initscr().
void InitColors(ViewState* state);

// Draws the whole screen for the model's state at `now_us`.
void Draw(const calib::DashboardModel& model, int64_t now_us, const ViewState& state);

}  // namespace agvcal_dashboard
