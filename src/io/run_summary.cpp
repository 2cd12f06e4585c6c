#include "io/run_summary.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace raycloth {

namespace {

const Rgb kBackground{255, 255, 255}, kInk{30, 30, 30}, kGrid{225, 225, 225}, kError{200, 30, 30};
constexpr int kTextScale = 2;

double nice_step(double range, int max_ticks) {
  const double raw = range / max_ticks;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10 * p;
}

// Tick values of a linear axis: multiples of a round step within [lo, hi].
std::vector<double> linear_ticks(double lo, double hi, int max_ticks) {
  if (!(hi > lo)) return {lo};
  const double step = nice_step(hi - lo, max_ticks);
  std::vector<double> t;
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k += 1) t.push_back(k * step);
  return t;
}

std::string tick_label(double v, bool log) {
  if (log) {
    const int e = int(std::lround(std::log10(v)));
    return e >= 0 && e <= 4 ? fmt::format("{:g}", std::pow(10.0, e)) : fmt::format("1e{}", e);
  }
  if (std::abs(v) < 1e-12) return "0";
  return fmt::format("{:g}", v);
}

}  // namespace

PlotAxis nice_axis(double lo, double hi, bool log) {
  PlotAxis a;
  a.log = log;
  if (log) {
    if (!(lo > 0) || !(hi > 0)) return {1, 10, true};
    a.lo = std::pow(10.0, std::floor(std::log10(lo)));
    a.hi = std::pow(10.0, std::ceil(std::log10(hi)));
    if (a.hi <= a.lo) a.hi = a.lo * 10;
    return a;
  }
  a.lo = std::min(lo, 0.0);
  if (!(hi > a.lo)) hi = a.lo + 1;
  const double step = nice_step(hi - a.lo, 5);
  a.hi = std::ceil(hi / step - 1e-9) * step;
  return a;
}

double PlotArea::column(double v) const {
  const double s = x.log ? std::log10(v / x.lo) / std::log10(x.hi / x.lo) : (v - x.lo) / (x.hi - x.lo);
  return left + s * (right - left);
}

double PlotArea::row(double v) const {
  const double s = y.log ? std::log10(v / y.lo) / std::log10(y.hi / y.lo) : (v - y.lo) / (y.hi - y.lo);
  return bottom - s * (bottom - top);
}

PlotArea draw_plot(RgbImage& img, int left, int top, int width, int height, const std::string& title,
                   const PlotSeries& series, const PlotAxis& x, const PlotAxis& y) {
  const int th = text_height(kTextScale);
  PlotArea a;
  a.x = x, a.y = y;
  a.left = left + text_width("000000", kTextScale) + 16;
  a.right = left + width - 16;
  a.top = top + 10 + th + 8;
  a.bottom = top + height - th - 12;
  draw_text(img, a.left, top + 10, title, kInk, kTextScale);

  // Grid and tick labels.
  std::vector<double> yticks;
  if (y.log) {
    for (double e = std::round(std::log10(y.lo)); e <= std::round(std::log10(y.hi)); e += 1) yticks.push_back(std::pow(10.0, e));
    const size_t stride = (yticks.size() + 5) / 6;  // at most about six labels
    std::vector<double> kept;
    for (size_t i = 0; i < yticks.size(); i += stride) kept.push_back(yticks[i]);
    yticks = kept;
  } else {
    yticks = linear_ticks(y.lo, y.hi, 5);
  }
  for (double v : yticks) {
    const int r = int(std::lround(a.row(v)));
    draw_line(img, a.left, r, a.right, r, kGrid);
    const std::string s = tick_label(v, y.log);
    draw_text(img, a.left - 8 - text_width(s, kTextScale), r - th / 2 + 1, s, kInk, kTextScale);
  }
  for (double v : linear_ticks(x.lo, x.hi, 8)) {
    const int c = int(std::lround(a.column(v)));
    draw_line(img, c, a.top, c, a.bottom, kGrid);
    const std::string s = tick_label(v, false);
    draw_text(img, c - text_width(s, kTextScale) / 2, a.bottom + 6, s, kInk, kTextScale);
  }

  // The series, broken where a log axis cannot show a point.
  bool have_prev = false;
  double pc = 0, pr = 0;
  for (size_t i = 0; i < series.x.size() && i < series.y.size(); ++i) {
    const double yv = series.y[i];
    if (!std::isfinite(yv) || (y.log && !(yv > 0))) {
      have_prev = false;
      continue;
    }
    const double c = a.column(series.x[i]), r = std::clamp(a.row(yv), double(a.top), double(a.bottom));
    if (have_prev) draw_line(img, pc, pr, c, r, series.color, 2);
    else draw_line(img, c, r, c, r, series.color, 2);
    pc = c, pr = r, have_prev = true;
  }

  // Frame last, over the grid's ends.
  draw_line(img, a.left, a.top, a.right, a.top, kInk);
  draw_line(img, a.left, a.bottom, a.right, a.bottom, kInk);
  draw_line(img, a.left, a.top, a.left, a.bottom, kInk);
  draw_line(img, a.right, a.top, a.right, a.bottom, kInk);
  return a;
}

RgbImage render_run_summary(const RunReport& r) {
  const int width = 960, header = 84, plot_height = 240;
  RgbImage img(width, header + 3 * plot_height + 30, kBackground);
  const int th = text_height(kTextScale), line = th + 4;

  draw_text(img, 16, 10,
            fmt::format("{}: {} frames, {:.3f} s simulated, {} steps, {:.0f} steps/s on {}", r.scene, r.frames.size(),
                        r.simulated_time, r.steps, r.steps_per_second, r.device),
            kInk, kTextScale);
  if (!r.error.empty()) {
    // The message, wrapped at spaces, on up to two lines.
    const size_t fit = size_t((width - 32) / text_width("m", kTextScale));
    std::vector<std::string> lines{""};
    std::istringstream words("stopped: " + r.error);
    for (std::string w; words >> w;) {
      if (!lines.back().empty() && lines.back().size() + 1 + w.size() > fit) lines.emplace_back();
      lines.back() += (lines.back().empty() ? "" : " ") + w;
    }
    if (lines.size() > 2 || lines[1 % lines.size()].size() > fit) {
      lines.resize(2);
      lines[1] = lines[1].substr(0, fit - 3) + "...";
    }
    for (size_t l = 0; l < lines.size(); ++l) draw_text(img, 16, 10 + int(l + 1) * line, lines[l].substr(0, fit), kError, kTextScale);
  } else {
    draw_text(img, 16, 10 + line, "completed", Rgb{40, 140, 60}, kTextScale);
  }

  PlotSeries rate, hits, energy;
  rate.color = Rgb{31, 119, 180};
  hits.color = Rgb{214, 110, 20};
  energy.color = Rgb{120, 60, 170};
  double max_rate = 0, max_hits = 0, min_e = 0, max_e = 0;
  for (const FrameRecord& f : r.frames) {
    if (f.index > 0) {  // frame 0 is the initial state: no steps, no casts
      rate.x.push_back(f.time), rate.y.push_back(f.steps_per_second);
      hits.x.push_back(f.time), hits.y.push_back(double(f.hits));
      max_rate = std::max(max_rate, f.steps_per_second);
      max_hits = std::max(max_hits, double(f.hits));
    }
    energy.x.push_back(f.time), energy.y.push_back(f.kinetic_energy);
    if (f.kinetic_energy > 0 && std::isfinite(f.kinetic_energy)) {
      min_e = min_e > 0 ? std::min(min_e, f.kinetic_energy) : f.kinetic_energy;
      max_e = std::max(max_e, f.kinetic_energy);
    }
  }
  // Up to where the run got; a stopped run has a red line where it stopped.
  const double t_end = std::max(r.simulated_time, r.frames.empty() ? 0.0 : r.frames.back().time);
  const PlotAxis time_axis{0, t_end > 0 ? t_end : 1, false};
  std::vector<PlotArea> areas;
  int top = header;
  areas.push_back(draw_plot(img, 0, top, width, plot_height, "steps per second (wall clock)", rate, time_axis,
                            nice_axis(0, max_rate, false)));
  top += plot_height;
  areas.push_back(draw_plot(img, 0, top, width, plot_height,
                            "collision hits per frame (vertices with a hit in the last step)", hits, time_axis,
                            nice_axis(0, max_hits, false)));
  top += plot_height;
  areas.push_back(draw_plot(img, 0, top, width, plot_height, "kinetic energy (J, log scale)", energy, time_axis,
                            max_e > 0 ? nice_axis(min_e, max_e, true) : nice_axis(0, 1, false)));
  if (!r.error.empty())
    for (const PlotArea& a : areas) draw_line(img, a.right - 1, a.top, a.right - 1, a.bottom, kError, 2);
  const PlotArea& ke = areas.back();
  const std::string xl = "simulated time (s)";
  draw_text(img, (ke.left + ke.right - text_width(xl, kTextScale)) / 2, ke.bottom + th + 12, xl, kInk, kTextScale);
  return img;
}

void write_run_summary(const std::filesystem::path& path, const RunReport& report) {
  write_png(path, render_run_summary(report));
}

}  // namespace raycloth
