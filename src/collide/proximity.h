// Proximity queries, host and device: which primitives lie near a box (BVH traversal with a
// per-primitive callback, as cuBQL hands the caller each candidate), closest points and distances
// between cloth features in double precision, and an order-independent atomic minimum.
//
// These feed the displacement bound of the step (sim/stages.h): distances are estimates used with a
// safety factor, never a yes/no on a degenerate case, so double precision with a margin is enough
// there. The yes/no "does this edge cross that triangle" is decided exactly by src/check/.
#pragma once
#include <cstdint>
#include <cstring>

#include "collide/bvh.h"
#include "raycloth/hd.h"
#include "raycloth/vec3.h"

#include <atomic>
#if defined(__CUDACC__)
#include <cuda/atomic>
#endif

namespace raycloth {

RC_HD bool aabb_overlap(const Aabb& a, const Aabb& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

RC_HD Aabb aabb_grow(Aabb b, float r) {
  b.lo = b.lo - make_vec3(r, r, r);
  b.hi = b.hi + make_vec3(r, r, r);
  return b;
}

RC_HD Aabb point_box(Vec3 p) {
  Aabb b;
  b.lo = p;
  b.hi = p;
  return b;
}

RC_HD Aabb segment_box(Vec3 a, Vec3 b) {
  Aabb r;
  r.lo = vmin(a, b);
  r.hi = vmax(a, b);
  return r;
}

// Calls f(prim) for every primitive whose leaf box overlaps `query`. f may shrink the query (it is
// passed by reference) to prune the rest of the traversal, as a nearest-point search does.
template <class F>
RC_HD void bvh_for_each_overlap(const BvhView& b, Aabb& query, F&& f) {
  const uint32_t n = b.num_prims;
  if (n == 0 || !aabb_overlap(b.bounds[0], query)) return;
  uint32_t stack[kBvhStackSize];
  int sp = 0;
  uint32_t node = 0;
  for (;;) {
    if (bvh_is_leaf(node, n)) {
      f(b.prim[node - bvh_first_leaf(n)]);
    } else {
      const uint32_t c0 = b.child[2 * node], c1 = b.child[2 * node + 1];
      const bool h0 = aabb_overlap(b.bounds[c0], query), h1 = aabb_overlap(b.bounds[c1], query);
      if (h0 && h1 && sp < kBvhStackSize) stack[sp++] = c1;
      if (h0 || h1) {
        node = h0 ? c0 : c1;
        continue;
      }
    }
    if (sp == 0) break;
    node = stack[--sp];
  }
}

// ---- Double-precision geometry -------------------------------------------------------------------

struct DVec3 {
  double x = 0, y = 0, z = 0;
};
RC_HD DVec3 dvec(Vec3 a) { return DVec3{double(a.x), double(a.y), double(a.z)}; }
RC_HD DVec3 operator+(DVec3 a, DVec3 b) { return DVec3{a.x + b.x, a.y + b.y, a.z + b.z}; }
RC_HD DVec3 operator-(DVec3 a, DVec3 b) { return DVec3{a.x - b.x, a.y - b.y, a.z - b.z}; }
RC_HD DVec3 operator*(DVec3 a, double s) { return DVec3{a.x * s, a.y * s, a.z * s}; }
RC_HD double ddot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
RC_HD DVec3 dcross(DVec3 a, DVec3 b) { return DVec3{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
RC_HD double dclamp01(double t) { return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t); }

// The point of triangle abc closest to p (Ericson, Real-Time Collision Detection 5.1.5), as
// barycentric weights (wa, wb, wc) summing to 1, and its squared distance to p.
struct TrianglePoint {
  double wa = 1, wb = 0, wc = 0;
  double dist2 = 0;
};

RC_HD TrianglePoint closest_on_triangle(DVec3 p, DVec3 a, DVec3 b, DVec3 c) {
  TrianglePoint r;
  const DVec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ddot(ab, ap), d2 = ddot(ac, ap);
  auto finish = [&](double wa, double wb, double wc) {
    r.wa = wa, r.wb = wb, r.wc = wc;
    const DVec3 q = a * wa + b * wb + c * wc;
    r.dist2 = ddot(p - q, p - q);
    return r;
  };
  if (d1 <= 0.0 && d2 <= 0.0) return finish(1, 0, 0);
  const DVec3 bp = p - b;
  const double d3 = ddot(ab, bp), d4 = ddot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return finish(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return finish(1 - v, v, 0);
  }
  const DVec3 cp = p - c;
  const double d5 = ddot(ab, cp), d6 = ddot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return finish(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return finish(1 - w, 0, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return finish(0, 1 - w, w);
  }
  const double denom = va + vb + vc;
  if (!(denom > 0.0)) {  // degenerate (zero-area) triangle: the nearest of its three edges
    return finish(1, 0, 0);
  }
  const double v = vb / denom, w = vc / denom;
  return finish(1 - v - w, v, w);
}

// The closest points of segments p1q1 and p2q2: parameters s, t in [0, 1] (Ericson 5.1.9),
// degenerate segments included.
RC_HD void closest_segment_params(DVec3 p1, DVec3 q1, DVec3 p2, DVec3 q2, double& s, double& t) {
  const DVec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = ddot(d1, d1), e = ddot(d2, d2), f = ddot(d2, r);
  const double eps = 1e-30;
  s = t = 0.0;
  if (a <= eps && e <= eps) return;
  if (a <= eps) {
    t = dclamp01(f / e);
    return;
  }
  const double c = ddot(d1, r);
  if (e <= eps) {
    s = dclamp01(-c / a);
    return;
  }
  const double b = ddot(d1, d2), denom = a * e - b * b;
  s = denom > 0.0 ? dclamp01((b * f - c * e) / denom) : 0.0;
  t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = dclamp01(-c / a);
  } else if (t > 1.0) {
    t = 1.0;
    s = dclamp01((b - c) / a);
  }
}

// Squared distance between segments p1q1 and p2q2.
RC_HD double segment_segment_dist2(DVec3 p1, DVec3 q1, DVec3 p2, DVec3 q2) {
  double s, t;
  closest_segment_params(p1, q1, p2, q2, s, t);
  const DVec3 u = (p1 + (q1 - p1) * s) - (p2 + (q2 - p2) * t);
  return ddot(u, u);
}

// ---- Order-independent atomics ------------------------------------------------------------------

// Minimum of non-negative floats kept as their bit patterns (which order like the floats): every
// thread order gives the same result, so the step stays deterministic.
RC_HD void atomic_min_nonneg(uint32_t* slot, float value) {
  uint32_t bits;
  memcpy(&bits, &value, sizeof bits);
#if defined(__CUDA_ARCH__)
  atomicMin(slot, bits);
#else
  std::atomic_ref<uint32_t> a(*slot);
  uint32_t cur = a.load(std::memory_order_relaxed);
  while (bits < cur && !a.compare_exchange_weak(cur, bits, std::memory_order_relaxed)) {
  }
#endif
}

// *slot = max(*slot, value) for a float value >= 0 kept as its bits (bit order = value order).
RC_HD void atomic_max_nonneg(uint32_t* slot, float value) {
  uint32_t bits;
  memcpy(&bits, &value, sizeof bits);
#if defined(__CUDA_ARCH__)
  atomicMax(slot, bits);
#else
  std::atomic_ref<uint32_t> a(*slot);
  uint32_t cur = a.load(std::memory_order_relaxed);
  while (bits > cur && !a.compare_exchange_weak(cur, bits, std::memory_order_relaxed)) {
  }
#endif
}

// *slot = 1 from any number of threads.
RC_HD void atomic_store_one(uint32_t* slot) {
#if defined(__CUDA_ARCH__)
  atomicExch(slot, 1u);
#else
  std::atomic_ref<uint32_t>(*slot).store(1u, std::memory_order_relaxed);
#endif
}

// Sums of float vectors in fixed point (1 unit = 2^-40, about 1e-12): integer addition is
// associative, so the sum is the same in every thread order (a float atomic add is not), and the
// step stays deterministic on both backends. Values are clamped to +-1e6 (no overflow).
struct FixedVec3 {
  long long x = 0, y = 0, z = 0;
};

inline constexpr double kFixedScale = 1099511627776.0;  // 2^40

RC_HD long long to_fixed(float v) {
  const double d = double(v);
  const double c = d > 1e6 ? 1e6 : (d < -1e6 ? -1e6 : d);
  return c == c ? (long long)(c * kFixedScale) : 0;
}

RC_HD void atomic_add_fixed(FixedVec3* slot, Vec3 v) {
  const long long a[3] = {to_fixed(v.x), to_fixed(v.y), to_fixed(v.z)};
  long long* out[3] = {&slot->x, &slot->y, &slot->z};
  for (int k = 0; k < 3; ++k) {
    if (a[k] == 0) continue;
#if defined(__CUDA_ARCH__)
    atomicAdd(reinterpret_cast<unsigned long long*>(out[k]), static_cast<unsigned long long>(a[k]));
#else
    std::atomic_ref<long long>(*out[k]).fetch_add(a[k], std::memory_order_relaxed);
#endif
  }
}

// *slot += 1; returns the value before.
RC_HD uint32_t atomic_fetch_add_one(uint32_t* slot) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(slot, 1u);
#else
  return std::atomic_ref<uint32_t>(*slot).fetch_add(1u, std::memory_order_relaxed);
#endif
}

// *slot += value; returns the value before.
RC_HD uint32_t atomic_fetch_add_u32(uint32_t* slot, uint32_t value) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(slot, value);
#else
  return std::atomic_ref<uint32_t>(*slot).fetch_add(value, std::memory_order_relaxed);
#endif
}

RC_HD Vec3 from_fixed(const FixedVec3& f) {
  return make_vec3(float(double(f.x) / kFixedScale), float(double(f.y) / kFixedScale), float(double(f.z) / kFixedScale));
}

RC_HD float float_from_bits(uint32_t bits) {
  float f;
  memcpy(&f, &bits, sizeof f);
  return f;
}

RC_HD uint32_t bits_from_float(float f) {
  uint32_t b;
  memcpy(&b, &f, sizeof b);
  return b;
}

// Keeps the `cap` nearest candidates (squared distance d2, key for ties) in ascending order
// (the contact solve's pair searches and the implicit solve's cloth search).
template <class T>
RC_HD void keep_nearest(uint32_t cap, uint32_t& found, double* d2s, uint32_t* keys, T* items, double d2, uint32_t key,
                        const T& item) {
  if (found == cap && !(d2 < d2s[found - 1] || (d2 == d2s[found - 1] && key < keys[found - 1]))) return;
  uint32_t k = found < cap ? found++ : found - 1;
  for (; k > 0 && (d2 < d2s[k - 1] || (d2 == d2s[k - 1] && key < keys[k - 1])); --k)
    d2s[k] = d2s[k - 1], keys[k] = keys[k - 1], items[k] = items[k - 1];
  d2s[k] = d2, keys[k] = key, items[k] = item;
}

}  // namespace raycloth
