// Drawing on an RGB image (io/image.h) for charts: rectangles, lines and text (stb_easy_font's
// quads, filled).
#pragma once
#include <string>

#include "io/image.h"

namespace raycloth {

// Fills [x0, x1) x [y0, y1), clipped to the image.
void fill_rect(RgbImage& img, int x0, int y0, int x1, int y1, Rgb c);
// A line between pixel centres, `thickness` pixels wide (a square brush stepped along it).
void draw_line(RgbImage& img, double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);
// Text with its top-left corner at (x, y); each font unit is `scale` pixels. Returns its width in pixels.
int draw_text(RgbImage& img, int x, int y, const std::string& text, Rgb c, int scale = 1);
int text_width(const std::string& text, int scale = 1);
int text_height(int scale = 1);  // of one line, capitals and descenders

}  // namespace raycloth
