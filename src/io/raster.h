// A small RGB raster for charts: rectangles, lines, text (stb_easy_font's quads, filled) and PNG
// output (stb_image_write, implemented by Debian's libstb that the library links).
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace raycloth {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // rows top to bottom, 3 bytes per pixel

  RgbImage(int w, int h, Rgb fill);
  Rgb at(int x, int y) const;
  void set(int x, int y, Rgb c);  // ignores pixels outside the image
};

// Fills [x0, x1) x [y0, y1), clipped to the image.
void fill_rect(RgbImage& img, int x0, int y0, int x1, int y1, Rgb c);
// A line between pixel centres, `thickness` pixels wide (a square brush stepped along it).
void draw_line(RgbImage& img, double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);
// Text with its top-left corner at (x, y); each font unit is `scale` pixels. Returns its width in pixels.
int draw_text(RgbImage& img, int x, int y, const std::string& text, Rgb c, int scale = 1);
int text_width(const std::string& text, int scale = 1);
int text_height(int scale = 1);  // of one line, capitals and descenders
// Writes a PNG under a temporary name and renames it (write_file_atomically).
void write_png(const std::filesystem::path& path, const RgbImage& img);

}  // namespace raycloth
