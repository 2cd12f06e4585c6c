#include "scene/transform.h"

#include <algorithm>
#include <cmath>

namespace raycloth {

Mat3 rotation_xyz_degrees(const Float3& deg) {
  const double k = M_PI / 180.0;
  const double cx = std::cos(deg[0] * k), sx = std::sin(deg[0] * k);
  const double cy = std::cos(deg[1] * k), sy = std::sin(deg[1] * k);
  const double cz = std::cos(deg[2] * k), sz = std::sin(deg[2] * k);
  // R = Rz * Ry * Rx (X applied first).
  Mat3 m;
  m.r0 = make_vec3(float(cz * cy), float(cz * sy * sx - sz * cx), float(cz * sy * cx + sz * sx));
  m.r1 = make_vec3(float(sz * cy), float(sz * sy * sx + cz * cx), float(sz * sy * cx - cz * sx));
  m.r2 = make_vec3(float(-sy), float(cy * sx), float(cy * cx));
  return m;
}

std::array<double, 4> rotation_quaternion_xyz_degrees(const Float3& deg) {
  // q = qz * qy * qx, matching R = Rz * Ry * Rx.
  const double k = M_PI / 360.0;  // half angles
  const double cx = std::cos(deg[0] * k), sx = std::sin(deg[0] * k);
  const double cy = std::cos(deg[1] * k), sy = std::sin(deg[1] * k);
  const double cz = std::cos(deg[2] * k), sz = std::sin(deg[2] * k);
  return {sx * cy * cz - cx * sy * sz, cx * sy * cz + sx * cy * sz, cx * cy * sz - sx * sy * cz,
          cx * cy * cz + sx * sy * sz};
}

TransformDef transform_at(const ObstacleDef& def, double t) {
  TransformDef td = def.transform;
  if (!def.motion) return td;
  const MotionDef& mo = *def.motion;
  const double tm = std::max(0.0, t - mo.start);
  for (int k = 0; k < 3; ++k) {
    td.position[k] += float(mo.velocity[k] * tm);
    td.rotation[k] += float(mo.angular_velocity[k] * tm);
  }
  return td;
}

Transform make_transform(const TransformDef& def) {
  Transform t;
  t.rotation = rotation_xyz_degrees(def.rotation);
  t.scale = to_vec3(def.scale);
  t.translation = to_vec3(def.position);
  return t;
}

}  // namespace raycloth
