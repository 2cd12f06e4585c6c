#include "io/image.h"

#include <stb_image_write.h>

#include <stdexcept>

#include "io/atomic_file.h"

namespace raycloth {

RgbImage::RgbImage(int w, int h, Rgb fill) : width(w), height(h), pixels(size_t(w) * size_t(h) * 3) {
  for (size_t i = 0; i < pixels.size(); i += 3) pixels[i] = fill.r, pixels[i + 1] = fill.g, pixels[i + 2] = fill.b;
}

Rgb RgbImage::at(int x, int y) const {
  const size_t i = (size_t(y) * size_t(width) + size_t(x)) * 3;
  return {pixels[i], pixels[i + 1], pixels[i + 2]};
}

void RgbImage::set(int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const size_t i = (size_t(y) * size_t(width) + size_t(x)) * 3;
  pixels[i] = c.r, pixels[i + 1] = c.g, pixels[i + 2] = c.b;
}

void write_png(const std::filesystem::path& path, const RgbImage& image) {
  std::vector<unsigned char> png;
  auto append = [](void* ctx, void* data, int size) {
    auto* out = static_cast<std::vector<unsigned char>*>(ctx);
    out->insert(out->end(), static_cast<unsigned char*>(data), static_cast<unsigned char*>(data) + size);
  };
  if (!stbi_write_png_to_func(append, &png, image.width, image.height, 3, image.pixels.data(), image.width * 3))
    throw std::runtime_error(path.string() + ": cannot encode the PNG image");
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(png.data()), std::streamsize(png.size()));
  });
}

}  // namespace raycloth
