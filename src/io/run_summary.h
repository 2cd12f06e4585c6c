// OUT/summary.png: the run at a glance, three plots over simulated time stacked: steps per second,
// collision hits per frame, kinetic energy (log scale). A run that settled, stalled or blew up
// shows as such.
#pragma once
#include <filesystem>
#include <string>
#include <vector>

#include "io/raster.h"
#include "io/run.h"

namespace raycloth {

struct PlotAxis {
  double lo = 0, hi = 1;
  bool log = false;  // lo and hi > 0
};

// Linear: from min(lo, 0) up to a round number at or above hi (1, 2 or 5 times a power of ten).
// Log: whole decades around the positive range [lo, hi].
PlotAxis nice_axis(double lo, double hi, bool log);

// Where a plot's data area lies in the image, and the values its edges stand for.
struct PlotArea {
  int left = 0, top = 0, right = 0, bottom = 0;  // pixels, inclusive
  PlotAxis x, y;
  double column(double x_value) const;
  double row(double y_value) const;  // y grows upwards in the plot, downwards in the image
};

struct PlotSeries {
  std::vector<double> x, y;  // points with y <= 0 are left out on a log axis
  Rgb color{31, 119, 180};
};

// Draws a titled plot into the box (left, top, width, height): frame, grid, tick labels, the series
// as a polyline. Returns the data area.
PlotArea draw_plot(RgbImage& img, int left, int top, int width, int height, const std::string& title,
                   const PlotSeries& series, const PlotAxis& x, const PlotAxis& y);

// The summary picture of a run (frames so far, and the error if it stopped).
RgbImage render_run_summary(const RunReport& report);
void write_run_summary(const std::filesystem::path& path, const RunReport& report);

}  // namespace raycloth
