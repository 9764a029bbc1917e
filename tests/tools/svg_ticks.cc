// The report plots' tick rule (libcalib/src/io/svg_plot.h) for ranges read from stdin, one
// "LO HI" a line; prints per range a line "VALUE|LABEL VALUE|LABEL ...", values with 17
// significant digits. fleet_unit compares scripts/agvcal_fleet/svg.py's ticks with these.
#include <cstdio>
#include <iostream>

#include "io/svg_plot.h"

int main() {
  double lo, hi;
  while (std::cin >> lo >> hi) {
    const char* sep = "";
    for (const calib::SvgTick& t : calib::SvgTicks(lo, hi)) {
      std::printf("%s%.17g|%s", sep, t.value, t.label.c_str());
      sep = " ";
    }
    std::printf("\n");
  }
  return 0;
}
