// The camera of rendered images: a pinhole with a vertical field of view, either placed by the
// scene (CameraDef) or framing the scene's bounds by itself.
#pragma once
#include "raycloth/scene.h"
#include "raycloth/vec3.h"

namespace raycloth {

struct Bounds {
  Vec3 lo = make_vec3(1e30f, 1e30f, 1e30f);
  Vec3 hi = make_vec3(-1e30f, -1e30f, -1e30f);
  void add(Vec3 p) { lo = vmin(lo, p), hi = vmax(hi, p); }
  void add(const Bounds& b) { lo = vmin(lo, b.lo), hi = vmax(hi, b.hi); }
  bool empty() const { return !(lo.x <= hi.x); }
  Vec3 centre() const { return (lo + hi) * 0.5f; }
  float radius() const { return empty() ? 0.0f : 0.5f * length(hi - lo); }
};

struct Camera {
  Vec3 eye, target;
  Vec3 forward, right, up;  // orthonormal; right x up = -forward
  float fov = 40;           // vertical, degrees
  int width = 1280, height = 720, samples = 4;

  // Direction of the ray through image point (px, py): pixels, x right, y down, (0, 0) the top-left corner.
  Vec3 direction(float px, float py) const;
  // Image point of a world point; false when it lies behind the camera.
  bool project(Vec3 p, float& px, float& py) const;
};

// The default view when the scene does not place the camera: from the front-right (30 degrees
// about y from +z) and 15 degrees above the target, so the ground recedes to a horizon near the top.
inline constexpr float kAutoAzimuthDeg = 30.0f;
inline constexpr float kAutoElevationDeg = 15.0f;

// A camera for `def`: an unset target is the centre of `bounds`; an unset position looks at the
// target from the default direction, just far enough back that the whole box is in view.
Camera make_camera(const CameraDef& def, const Bounds& bounds);

}  // namespace raycloth
