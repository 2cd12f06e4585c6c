// Small float vector used by all per-vertex physics; plain data, usable on host and device.
#pragma once
#include <cmath>
#include "raycloth/hd.h"

namespace raycloth {

struct Vec3 {
  float x = 0, y = 0, z = 0;
};

RC_HD Vec3 make_vec3(float x, float y, float z) { Vec3 v; v.x = x; v.y = y; v.z = z; return v; }
RC_HD Vec3 operator+(Vec3 a, Vec3 b) { return make_vec3(a.x + b.x, a.y + b.y, a.z + b.z); }
RC_HD Vec3 operator-(Vec3 a, Vec3 b) { return make_vec3(a.x - b.x, a.y - b.y, a.z - b.z); }
RC_HD Vec3 operator-(Vec3 a) { return make_vec3(-a.x, -a.y, -a.z); }
RC_HD Vec3 operator*(Vec3 a, float s) { return make_vec3(a.x * s, a.y * s, a.z * s); }
RC_HD Vec3 operator*(float s, Vec3 a) { return a * s; }
RC_HD Vec3 operator/(Vec3 a, float s) { return a * (1.0f / s); }
RC_HD Vec3& operator+=(Vec3& a, Vec3 b) { a = a + b; return a; }
RC_HD Vec3& operator-=(Vec3& a, Vec3 b) { a = a - b; return a; }
RC_HD Vec3& operator*=(Vec3& a, float s) { a = a * s; return a; }
RC_HD float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
RC_HD Vec3 cross(Vec3 a, Vec3 b) {
  return make_vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
RC_HD float length_sq(Vec3 a) { return dot(a, a); }
RC_HD float length(Vec3 a) { return sqrtf(dot(a, a)); }
RC_HD Vec3 normalize_or_zero(Vec3 a) {
  float l2 = dot(a, a);
  return l2 > 0.0f ? a * (1.0f / sqrtf(l2)) : make_vec3(0, 0, 0);
}
// Plain comparisons rather than fminf/fmaxf: the host compiler does not inline those (NaN rules),
// and boxes are built in the hottest loops.
RC_HD float min_of(float a, float b) { return b < a ? b : a; }
RC_HD float max_of(float a, float b) { return a < b ? b : a; }
RC_HD Vec3 vmin(Vec3 a, Vec3 b) { return make_vec3(min_of(a.x, b.x), min_of(a.y, b.y), min_of(a.z, b.z)); }
RC_HD Vec3 vmax(Vec3 a, Vec3 b) { return make_vec3(max_of(a.x, b.x), max_of(a.y, b.y), max_of(a.z, b.z)); }
RC_HD bool is_finite(float f) {
#if defined(__CUDA_ARCH__)
  return isfinite(f);
#else
  return std::isfinite(f);
#endif
}
RC_HD bool is_finite(Vec3 a) { return is_finite(a.x) && is_finite(a.y) && is_finite(a.z); }

}  // namespace raycloth
