#include "render/camera.h"

#include <algorithm>
#include <cmath>

namespace raycloth {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kMargin = 1.08f;  // room left around the framed box

Vec3 to_vec3(const Float3& f) { return make_vec3(f[0], f[1], f[2]); }

void set_basis(Camera& c) {
  c.forward = normalize_or_zero(c.target - c.eye);
  Vec3 world_up = make_vec3(0, 1, 0);
  if (std::fabs(dot(c.forward, world_up)) > 0.999f) world_up = make_vec3(0, 0, -1);  // looking straight up or down
  c.right = normalize_or_zero(cross(c.forward, world_up));
  c.up = cross(c.right, c.forward);
}

}  // namespace

Vec3 Camera::direction(float px, float py) const {
  const float t = std::tan(0.5f * fov * kPi / 180.0f);
  const float aspect = float(width) / float(height);
  const float sx = (2.0f * px / float(width) - 1.0f) * t * aspect;
  const float sy = (1.0f - 2.0f * py / float(height)) * t;
  return normalize_or_zero(forward + right * sx + up * sy);
}

bool Camera::project(Vec3 p, float& px, float& py) const {
  const Vec3 d = p - eye;
  const float z = dot(d, forward);
  if (!(z > 0)) return false;
  const float t = std::tan(0.5f * fov * kPi / 180.0f);
  const float aspect = float(width) / float(height);
  px = 0.5f * float(width) * (1.0f + dot(d, right) / (z * t * aspect));
  py = 0.5f * float(height) * (1.0f - dot(d, up) / (z * t));
  return true;
}

Camera make_camera(const CameraDef& def, const Bounds& bounds) {
  Camera c;
  c.fov = def.fov;
  c.width = def.width;
  c.height = def.height;
  c.samples = def.samples;
  const Bounds box = bounds.empty() ? [] { Bounds b; b.add(make_vec3(-1, -1, -1)); b.add(make_vec3(1, 1, 1)); return b; }()
                                    : bounds;
  c.target = def.target ? to_vec3(*def.target) : box.centre();
  if (def.position) {
    c.eye = to_vec3(*def.position);
    set_basis(c);
    return c;
  }
  const float az = kAutoAzimuthDeg * kPi / 180.0f, el = kAutoElevationDeg * kPi / 180.0f;
  const Vec3 to_eye = make_vec3(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  c.eye = c.target + to_eye;
  set_basis(c);
  // Distance along -forward from the target at which every corner of the box projects inside the
  // image: a corner at (x, y, z) in the camera's axes needs |x| <= tan_h (d + z) and |y| <= tan_v (d + z).
  const float tan_v = std::tan(0.5f * c.fov * kPi / 180.0f) / kMargin;
  const float tan_h = tan_v * float(c.width) / float(c.height);
  const float r = std::max(box.radius(), 1e-3f);
  float d = 0.1f * r;
  for (int i = 0; i < 8; ++i) {
    const Vec3 corner = make_vec3(i & 1 ? box.hi.x : box.lo.x, i & 2 ? box.hi.y : box.lo.y, i & 4 ? box.hi.z : box.lo.z);
    const Vec3 o = corner - c.target;
    const float x = dot(o, c.right), y = dot(o, c.up), z = dot(o, c.forward);
    d = std::max({d, std::fabs(x) / tan_h - z, std::fabs(y) / tan_v - z, 0.1f * r - z});
  }
  c.eye = c.target - c.forward * d;
  return c;
}

}  // namespace raycloth
