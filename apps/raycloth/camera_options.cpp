#include "camera_options.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "raycloth/error.h"

namespace raycloth::cli {

namespace {

constexpr const char* kSource = "command line";

bool parse_float(const std::string& s, float& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE) return false;
  out = float(v);
  return true;
}

bool parse_int(const std::string& s, int& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (end != s.c_str() + s.size() || errno == ERANGE || v < -1000000000L || v > 1000000000L) return false;
  out = int(v);
  return true;
}

Float3 parse_point(const std::string& s, const std::string& field) {
  Float3 p{};
  size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const size_t comma = k < 2 ? s.find(',', start) : s.size();
    if (comma == std::string::npos || !parse_float(s.substr(start, comma - start), p[k]))
      throw InputError(kSource, field, "expected x,y,z (got '" + s + "')");
    start = comma + 1;
  }
  return p;
}

}  // namespace

void add_camera_options(CLI::App* app, CameraArgs& a) {
  app->add_option("--camera-pos", a.position, "Camera position x,y,z in metres (default: frame the scene)");
  app->add_option("--camera-target", a.target, "Point looked at, x,y,z (default: centre of the scene)");
  app->add_option("--fov", a.fov, "Vertical field of view, degrees (default 40)");
  app->add_option("--resolution", a.resolution, "Image size WxH in pixels (default 1280x720)");
  app->add_option("--samples", a.samples, "Antialiasing samples per pixel (default 4)");
}

void apply_camera_options(const CameraArgs& a, OutputDef& output) {
  CameraDef& c = output.camera;
  if (!a.position.empty()) c.position = parse_point(a.position, "/output/camera/position");
  if (!a.target.empty()) c.target = parse_point(a.target, "/output/camera/target");
  if (!a.fov.empty() && !parse_float(a.fov, c.fov))
    throw InputError(kSource, "/output/camera/fov", "expected a number (got '" + a.fov + "')");
  if (!a.resolution.empty()) {
    const size_t x = a.resolution.find('x');
    if (x == std::string::npos || !parse_int(a.resolution.substr(0, x), c.width) ||
        !parse_int(a.resolution.substr(x + 1), c.height))
      throw InputError(kSource, "/output/camera/resolution", "expected WxH (got '" + a.resolution + "')");
  }
  if (!a.samples.empty() && !parse_int(a.samples, c.samples))
    throw InputError(kSource, "/output/camera/samples", "expected an integer (got '" + a.samples + "')");
  validate_output(output, kSource);
}

}  // namespace raycloth::cli
