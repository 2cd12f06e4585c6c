#include "io/raster.h"

#include <algorithm>
#include <cmath>
#include <vector>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

namespace raycloth {

void fill_rect(RgbImage& img, int x0, int y0, int x1, int y1, Rgb c) {
  x0 = std::max(x0, 0), y0 = std::max(y0, 0), x1 = std::min(x1, img.width), y1 = std::min(y1, img.height);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) img.set(x, y, c);
}

void draw_line(RgbImage& img, double x0, double y0, double x1, double y1, Rgb c, int thickness) {
  const int lo = -(thickness - 1) / 2, hi = thickness / 2;
  const int n = int(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))) + 1;
  for (int i = 0; i <= n; ++i) {
    const double s = double(i) / n;
    const int x = int(std::lround(x0 + s * (x1 - x0))), y = int(std::lround(y0 + s * (y1 - y0)));
    fill_rect(img, x + lo, y + lo, x + hi + 1, y + hi + 1, c);
  }
}

namespace {
struct FontVertex {
  float x, y, z;
  unsigned char color[4];
};
}  // namespace

int draw_text(RgbImage& img, int x, int y, const std::string& text, Rgb c, int scale) {
  std::string s = text;
  std::vector<FontVertex> quads(s.size() * 80 + 64);  // ~270 bytes a character, 16 bytes a vertex
  const int n = stb_easy_font_print(0, 0, s.data(), nullptr, quads.data(), int(quads.size() * sizeof(FontVertex)));
  for (int q = 0; q < n; ++q) {
    const FontVertex* v = &quads[size_t(q) * 4];
    float x0 = v[0].x, x1 = v[0].x, y0 = v[0].y, y1 = v[0].y;
    for (int k = 1; k < 4; ++k)
      x0 = std::min(x0, v[k].x), x1 = std::max(x1, v[k].x), y0 = std::min(y0, v[k].y), y1 = std::max(y1, v[k].y);
    fill_rect(img, x + int(std::lround(x0 * scale)), y + int(std::lround(y0 * scale)), x + int(std::lround(x1 * scale)),
              y + int(std::lround(y1 * scale)), c);
  }
  return text_width(text, scale);
}

int text_width(const std::string& text, int scale) {
  std::string s = text;
  return stb_easy_font_width(s.data()) * scale;
}

int text_height(int scale) { return 9 * scale; }

}  // namespace raycloth
