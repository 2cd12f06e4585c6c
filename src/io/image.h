// An 8-bit RGB image and its PNG file: what the renderer's frames (render/) and the run's summary
// chart (io/run_summary.h) are drawn into and written as (stb_image_write, implemented by Debian's
// libstb that the library links).
#pragma once
#include <cstdint>
#include <filesystem>
#include <vector>

namespace raycloth {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // rows top to bottom, 3 bytes per pixel (sRGB)

  RgbImage() = default;
  RgbImage(int w, int h, Rgb fill = {});
  Rgb at(int x, int y) const;
  void set(int x, int y, Rgb c);  // ignores pixels outside the image
};

// Writes `image` as PNG under a temporary name and renames it (write_file_atomically); throws
// std::runtime_error naming the file.
void write_png(const std::filesystem::path& path, const RgbImage& image);

}  // namespace raycloth
