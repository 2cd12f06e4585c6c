// Rigid placement of panels and obstacles: scale, then rotate X, Y, Z (degrees), then translate.
#pragma once
#include "raycloth/vec3.h"
#include "raycloth/scene.h"

namespace raycloth {

struct Mat3 {
  Vec3 r0, r1, r2;  // rows
};

inline Vec3 mul(const Mat3& m, Vec3 v) { return make_vec3(dot(m.r0, v), dot(m.r1, v), dot(m.r2, v)); }
Mat3 rotation_xyz_degrees(const Float3& deg);
inline Vec3 to_vec3(const Float3& f) { return make_vec3(f[0], f[1], f[2]); }

struct Transform {
  Mat3 rotation;
  Vec3 scale{1, 1, 1};
  Vec3 translation{0, 0, 0};
  Vec3 apply(Vec3 p) const {
    return mul(rotation, make_vec3(p.x * scale.x, p.y * scale.y, p.z * scale.z)) + translation;
  }
};

Transform make_transform(const TransformDef& def);
// The same rotation as a unit quaternion (x, y, z, w), for formats that store rotations so.
std::array<double, 4> rotation_quaternion_xyz_degrees(const Float3& deg);
// Where an obstacle's motion has taken its transform at simulated time t: position += velocity * tm,
// rotation += angular_velocity * tm, with tm = max(0, t - start); the transform itself without motion.
TransformDef transform_at(const ObstacleDef& def, double t);

}  // namespace raycloth
