// A linear BVH over triangles (Karras 2012), plain data passed by value as a BvhView of pointers.
// Every per-node step is an RC_HD function, so the host build/refit below (bvh.cpp, oneTBB) and the
// device build/refit (collide/cuda/device_bvh.cu) run the same code; so does the traversal.
//
//   build   Morton code of each triangle centroid in the scene box -> stable sort -> radix tree
//           (one independent function per internal node) -> refit
//   refit   one thread per leaf climbs to the root; an atomic counter per internal node lets the
//           second child to arrive compute the parent's box (the first one stops)
//   trace   stack-based nearest hit, Moeller-Trumbore, with a filter that can reject a primitive
//
// Layout for n primitives: internal nodes [0, n-1), leaves [n-1, 2n-1), root = node 0 (for n = 1
// the root is the only leaf). Leaf k holds primitive prim[k].
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "collide/collider.h"
#include "collide/rules.h"
#include "raycloth/hd.h"
#include "raycloth/vec3.h"

#include <atomic>
#include <bit>
#if defined(__CUDACC__)
#include <cuda/atomic>
#endif

namespace raycloth {

inline constexpr uint32_t kBvhNone = 0xFFFFFFFFu;
// Deepest possible Karras tree: 63 Morton bits plus 32 bits of index tie-break.
inline constexpr int kBvhStackSize = 100;
// Cloth trees are rebuilt when refitting has grown the summed node area past this factor of the
// area right after the last build (docs/gpu.md has the measurement behind the number).
inline constexpr float kBvhRebuildFactor = 2.0f;

struct Aabb {
  Vec3 lo = make_vec3(INFINITY, INFINITY, INFINITY);
  Vec3 hi = make_vec3(-INFINITY, -INFINITY, -INFINITY);
};

RC_HD Aabb aabb_union(const Aabb& a, const Aabb& b) {
  Aabb r;
  r.lo = vmin(a.lo, b.lo);
  r.hi = vmax(a.hi, b.hi);
  return r;
}

RC_HD Aabb triangle_box(const Vec3* v, const uint32_t* idx, uint32_t prim) {
  const Vec3 a = v[idx[3 * prim]], b = v[idx[3 * prim + 1]], c = v[idx[3 * prim + 2]];
  Aabb r;
  r.lo = vmin(a, vmin(b, c));
  r.hi = vmax(a, vmax(b, c));
  return r;
}

// A leaf's box: the triangle's, grown by about 8 ulps of its largest coordinate. Moeller-Trumbore
// rounds differently from the slab test, and without the margin a ray that meets a triangle exactly
// at a face of its box (through a shared vertex, nearly parallel to that face) can lose the hit to
// the box test in one tree and keep it in another.
RC_HD Aabb leaf_box(const Vec3* v, const uint32_t* idx, uint32_t prim) {
  Aabb b = triangle_box(v, idx, prim);
  const float m = fmaxf(fmaxf(fmaxf(fabsf(b.lo.x), fabsf(b.hi.x)), fmaxf(fabsf(b.lo.y), fabsf(b.hi.y))),
                        fmaxf(fabsf(b.lo.z), fabsf(b.hi.z)));
  const float pad = m * 1e-6f + 1e-30f;
  b.lo = b.lo - make_vec3(pad, pad, pad);
  b.hi = b.hi + make_vec3(pad, pad, pad);
  return b;
}

RC_HD Vec3 triangle_centroid(const Vec3* v, const uint32_t* idx, uint32_t prim) {
  return (v[idx[3 * prim]] + v[idx[3 * prim + 1]] + v[idx[3 * prim + 2]]) * (1.0f / 3.0f);
}

// Half the surface area; 0 for an empty box.
RC_HD float aabb_half_area(const Aabb& b) {
  const Vec3 d = b.hi - b.lo;
  if (d.x < 0.0f || d.y < 0.0f || d.z < 0.0f) return 0.0f;
  return d.x * d.y + d.y * d.z + d.z * d.x;
}

// Plain pointers to one tree's arrays (host or device memory).
struct BvhView {
  uint32_t num_prims = 0;
  uint32_t* child = nullptr;    // 2 per internal node
  uint32_t* parent = nullptr;   // per node; kBvhNone for the root
  Aabb* bounds = nullptr;       // per node
  uint32_t* prim = nullptr;     // per leaf: the triangle it holds
  uint32_t* counter = nullptr;  // per internal node: refit arrivals (zeroed before each refit)
};

RC_HD uint32_t bvh_num_nodes(uint32_t n) { return n == 0 ? 0 : 2 * n - 1; }
RC_HD uint32_t bvh_first_leaf(uint32_t n) { return n - 1; }
RC_HD bool bvh_is_leaf(uint32_t node, uint32_t n) { return node >= n - 1; }

// ---- Build ---------------------------------------------------------------------------------------

// Spreads the low 21 bits of x so that two zero bits follow each one.
RC_HD uint64_t morton_spread(uint64_t x) {
  x &= 0x1FFFFFull;
  x = (x | x << 32) & 0x1F00000000FFFFull;
  x = (x | x << 16) & 0x1F0000FF0000FFull;
  x = (x | x << 8) & 0x100F00F00F00F00Full;
  x = (x | x << 4) & 0x10C30C30C30C30C3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

// Cell of v along one axis of the scene box, 0 to 2^21 - 1; a flat axis quantizes to 0.
RC_HD uint64_t morton_quantize(float v, float lo, float extent) {
  const float kCells = 2097151.0f;
  if (!(extent > 0.0f)) return 0;
  return uint64_t(fminf(fmaxf((v - lo) / extent * kCells, 0.0f), kCells));
}

// 63-bit Morton code of a point in `box`, 21 bits per axis.
RC_HD uint64_t morton_code(Vec3 p, const Aabb& box) {
  const Vec3 d = box.hi - box.lo;
  return (morton_spread(morton_quantize(p.x, box.lo.x, d.x)) << 2) |
         (morton_spread(morton_quantize(p.y, box.lo.y, d.y)) << 1) | morton_spread(morton_quantize(p.z, box.lo.z, d.z));
}

RC_HD int count_leading_zeros64(uint64_t x) {
#if defined(__CUDA_ARCH__)
  return __clzll((long long)x);
#else
  return std::countl_zero(x);
#endif
}

// Karras' delta: length of the common prefix of sorted keys i and j, with the index as tie-break
// for equal codes; -1 outside [0, n).
RC_HD int karras_delta(const uint64_t* codes, uint32_t n, int64_t i, int64_t j) {
  if (j < 0 || j >= int64_t(n)) return -1;
  const uint64_t a = codes[i], b = codes[j];
  if (a == b) return 64 + count_leading_zeros64(uint64_t(uint32_t(i) ^ uint32_t(j))) - 32;
  return count_leading_zeros64(a ^ b);
}

// Karras 2012, Fig. 4: the range and split of internal node i over n >= 2 sorted codes; writes
// its two children and their parent pointers. Independent per node, so it runs in parallel.
RC_HD void build_internal_node(const BvhView& b, const uint64_t* codes, uint32_t i) {
  const uint32_t n = b.num_prims;
  const int64_t ii = int64_t(i);
  const int d = karras_delta(codes, n, ii, ii + 1) - karras_delta(codes, n, ii, ii - 1) >= 0 ? 1 : -1;
  const int delta_min = karras_delta(codes, n, ii, ii - d);
  int64_t l_max = 2;
  while (karras_delta(codes, n, ii, ii + l_max * d) > delta_min) l_max *= 2;
  int64_t l = 0;
  for (int64_t t = l_max / 2; t >= 1; t /= 2)
    if (karras_delta(codes, n, ii, ii + (l + t) * d) > delta_min) l += t;
  const int64_t j = ii + l * d;
  const int delta_node = karras_delta(codes, n, ii, j);
  int64_t s = 0;
  for (int64_t t = (l + 1) / 2;; t = (t + 1) / 2) {
    if (karras_delta(codes, n, ii, ii + (s + t) * d) > delta_node) s += t;
    if (t <= 1) break;
  }
  const int64_t gamma = ii + s * d + (d < 0 ? -1 : 0);
  const int64_t lo = ii < j ? ii : j, hi = ii < j ? j : ii;
  const uint32_t first_leaf = bvh_first_leaf(n);
  const uint32_t left = lo == gamma ? first_leaf + uint32_t(gamma) : uint32_t(gamma);
  const uint32_t right = hi == gamma + 1 ? first_leaf + uint32_t(gamma + 1) : uint32_t(gamma + 1);
  b.child[2 * i] = left;
  b.child[2 * i + 1] = right;
  b.parent[left] = i;
  b.parent[right] = i;
}

// ---- Refit ---------------------------------------------------------------------------------------

// The second child to arrive at a node refits it: acquire/release on the counter makes the sibling's
// box visible. Host threads (oneTBB) use std::atomic_ref, device threads cuda::atomic_ref.
RC_HD uint32_t bvh_arrive(uint32_t* counter) {
#if defined(__CUDA_ARCH__)
  cuda::atomic_ref<uint32_t, cuda::thread_scope_device> a(*counter);
  return a.fetch_add(1u, cuda::memory_order_acq_rel);
#else
  std::atomic_ref<uint32_t> a(*counter);
  return a.fetch_add(1u, std::memory_order_acq_rel);
#endif
}

// Leaf k's box from its triangle, then up the tree as far as this thread is the last to arrive.
// Counters must be zero before the first leaf starts.
RC_HD void refit_from_leaf(const BvhView& b, const Vec3* vertices, const uint32_t* indices, uint32_t k) {
  const uint32_t n = b.num_prims;
  uint32_t node = bvh_first_leaf(n) + k;
  b.bounds[node] = leaf_box(vertices, indices, b.prim[k]);
  for (node = b.parent[node]; node != kBvhNone; node = b.parent[node]) {
    if (bvh_arrive(&b.counter[node]) == 0) return;  // the sibling is still on its way
    b.bounds[node] = aabb_union(b.bounds[b.child[2 * node]], b.bounds[b.child[2 * node + 1]]);
  }
}

// Summed half areas of the internal nodes: the cost the rebuild trigger watches.
RC_HD float internal_node_area(const BvhView& b, uint32_t node) { return aabb_half_area(b.bounds[node]); }

// ---- Traversal -----------------------------------------------------------------------------------

// One slab of the box test, as pbrt-v4 writes it: the far distance is widened by 1 + 2 gamma(3) so
// that a ray that hits a triangle is never culled by rounding at that triangle's box (flat boxes
// included), and the comparisons are ordered so that a NaN (0 * inf, for an axis-parallel ray whose
// origin lies on the slab) leaves the interval unchanged instead of rejecting the box.
RC_HD void clip_slab(float lo, float hi, float org, float inv_dir, float& t0, float& t1) {
  float tn = (lo - org) * inv_dir, tf = (hi - org) * inv_dir;
  if (tn > tf) {
    const float tmp = tn;
    tn = tf;
    tf = tmp;
  }
  tf *= 1.0000004f;
  t0 = tn > t0 ? tn : t0;
  t1 = tf < t1 ? tf : t1;
}

// Does the ray meet the box within [0, tfar]? tnear is where it enters.
RC_HD bool ray_box(const Aabb& b, Vec3 org, Vec3 inv_dir, float tfar, float& tnear) {
  float t0 = 0.0f, t1 = tfar;
  clip_slab(b.lo.x, b.hi.x, org.x, inv_dir.x, t0, t1);
  clip_slab(b.lo.y, b.hi.y, org.y, inv_dir.y, t0, t1);
  clip_slab(b.lo.z, b.hi.z, org.z, inv_dir.z, t0, t1);
  tnear = t0;
  return t0 <= t1;
}

// Moeller-Trumbore, two-sided, accepting 0 < t <= tfar: Embree's depth test with tnear = 0 (a hit
// exactly at the origin does not count, one exactly at tfar does).
RC_HD bool ray_triangle(const Vec3* v, const uint32_t* idx, uint32_t prim, Vec3 org, Vec3 dir, float tfar, float& t) {
  const Vec3 a = v[idx[3 * prim]], b = v[idx[3 * prim + 1]], c = v[idx[3 * prim + 2]];
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = cross(dir, e2);
  const float det = dot(e1, p);
  if (det == 0.0f) return false;
  const float inv_det = 1.0f / det;
  const Vec3 s = org - a;
  const float u = dot(s, p) * inv_det;
  if (u < 0.0f || u > 1.0f) return false;
  const Vec3 q = cross(s, e1);
  const float w = dot(dir, q) * inv_det;
  if (w < 0.0f || u + w > 1.0f) return false;
  const float th = dot(e2, q) * inv_det;
  if (!(th > 0.0f && th <= tfar)) return false;
  t = th;
  return true;
}

struct AcceptAll {
  RC_HD bool operator()(uint32_t) const { return true; }
};

// The shared cloth rule: a ray never hits the triangles of its own vertex (or its seam partners).
struct SkipOwnTriangles {
  const uint32_t* tri_alias;
  uint32_t ray_alias;
  uint32_t ray_alias2 = kNoAlias;
  RC_HD bool operator()(uint32_t prim) const {
    return !is_own_triangle(tri_alias, prim, ray_alias) && !is_own_triangle(tri_alias, prim, ray_alias2);
  }
};

// Counts work for the rebuild measurement; the default does nothing and compiles away.
struct NoTraceStats {
  RC_HD void node() {}
  RC_HD void triangle() {}
};
struct TraceStats {
  uint64_t nodes = 0, triangles = 0;
  RC_HD void node() { ++nodes; }
  RC_HD void triangle() { ++triangles; }
};

// Nearest accepted hit along `ray` within [0, ray.tmax]; kind is kHitNone when there is none.
template <class Filter, class Stats = NoTraceStats>
RC_HD RawHit trace_nearest(const BvhView& b, const Vec3* vertices, const uint32_t* indices, const Ray& ray,
                           Filter filter, uint32_t kind, Stats* stats = nullptr) {
  RawHit best;
  const uint32_t n = b.num_prims;
  if (n == 0 || !(ray.tmax > 0.0f)) return best;
  const Vec3 inv_dir = make_vec3(1.0f / ray.dir.x, 1.0f / ray.dir.y, 1.0f / ray.dir.z);
  float tfar = ray.tmax;
  float tn;
  if (stats) stats->node();
  if (!ray_box(b.bounds[0], ray.org, inv_dir, tfar, tn)) return best;
  uint32_t stack[kBvhStackSize];
  int sp = 0;
  uint32_t node = 0;
  for (;;) {
    if (bvh_is_leaf(node, n)) {
      const uint32_t prim = b.prim[node - bvh_first_leaf(n)];
      float t;
      if (stats) stats->triangle();
      // Equal distances (a ray through a shared vertex or edge) go to the lowest primitive id, so
      // the hit does not depend on the tree's shape: rebuilding never changes a simulation.
      if (ray_triangle(vertices, indices, prim, ray.org, ray.dir, tfar, t) &&
          (best.kind == kHitNone || t < tfar || prim < best.prim) && filter(prim)) {
        tfar = t;
        best.t = t;
        best.prim = prim;
        best.kind = kind;
      }
    } else {
      const uint32_t c0 = b.child[2 * node], c1 = b.child[2 * node + 1];
      float t0, t1;
      if (stats) stats->node(), stats->node();
      const bool h0 = ray_box(b.bounds[c0], ray.org, inv_dir, tfar, t0);
      const bool h1 = ray_box(b.bounds[c1], ray.org, inv_dir, tfar, t1);
      if (h0 && h1) {
        const bool near0 = t0 <= t1;
        if (sp < kBvhStackSize) stack[sp++] = near0 ? c1 : c0;
        node = near0 ? c0 : c1;
        continue;
      }
      if (h0 || h1) {
        node = h0 ? c0 : c1;
        continue;
      }
    }
    if (sp == 0) break;
    node = stack[--sp];
  }
  return best;
}

// Both trees of a collision scene and the geometry they index.
struct BvhScene {
  BvhView obstacles;
  const Vec3* obstacle_vertices = nullptr;
  const uint32_t* obstacle_indices = nullptr;
  BvhView cloth;  // num_prims = 0 when cloth-cloth casting is off
  const Vec3* cloth_positions = nullptr;
  const uint32_t* cloth_indices = nullptr;
  const uint32_t* tri_alias = nullptr;
};

// The collision ray cast, as EmbreeCollider::cast does it: obstacles first, then the cloth with
// tmax shrunk to the obstacle hit, so that the nearer of the two wins (the cloth on a tie).
template <class Stats = NoTraceStats>
RC_HD RawHit trace_collision(const BvhScene& s, const Ray& ray, Stats* stats = nullptr) {
  if (!(ray.tmax > 0.0f)) return RawHit();
  RawHit h = trace_nearest(s.obstacles, s.obstacle_vertices, s.obstacle_indices, ray, AcceptAll(), kHitObstacle, stats);
  if (s.cloth.num_prims > 0) {
    Ray r = ray;
    if (h.kind != kHitNone) r.tmax = h.t;
    const RawHit c = trace_nearest(s.cloth, s.cloth_positions, s.cloth_indices, r,
                                   SkipOwnTriangles{s.tri_alias, ray.vertex, ray.vertex2}, kHitCloth, stats);
    if (c.kind != kHitNone) h = c;
  }
  return h;
}

// ---- Host trees ----------------------------------------------------------------------------------

// A tree in host memory (std::vector storage); view() hands out its pointers.
struct HostBvh {
  uint32_t num_prims = 0;
  std::vector<uint32_t> child, parent, prim, counter;
  std::vector<Aabb> bounds;
  float built_area = 0;  // bvh_area right after the last build
  uint32_t builds = 0;   // number of builds so far (the first one included)
  BvhView view() {
    BvhView v;
    v.num_prims = num_prims;
    v.child = child.data();
    v.parent = parent.data();
    v.bounds = bounds.data();
    v.prim = prim.data();
    v.counter = counter.data();
    return v;
  }
};

// Builds over the triangles `indices` (3 per triangle) of `vertices`; oneTBB-parallel.
void build_bvh(HostBvh& bvh, const Vec3* vertices, const uint32_t* indices, uint32_t num_triangles);
// Recomputes every box for moved vertices, keeping the hierarchy.
void refit_bvh(HostBvh& bvh, const Vec3* vertices, const uint32_t* indices);
// Summed half areas of the internal nodes (the leaf boxes for a one-triangle tree).
float bvh_area(const BvhView& bvh);
// True when refitting has degraded the tree past kBvhRebuildFactor times its built area.
inline bool bvh_needs_rebuild(float area, float built_area, float factor = kBvhRebuildFactor) {
  return area > factor * built_area;
}
// Checks that every internal box contains its children and every leaf its triangle; returns the
// first bad node or kBvhNone (tests and RAYCLOTH_VALIDATE builds).
uint32_t bvh_find_bad_node(const HostBvh& bvh, const Vec3* vertices, const uint32_t* indices);

// The Collider interface over these trees on the host (tests, CI, benchmarks). The cloth tree is
// refit on every update_cloth and rebuilt when bvh_needs_rebuild says so.
class BvhCollider final : public Collider {
 public:
  void set_obstacles(const Vec3* vertices, size_t num_vertices, const uint32_t* indices, size_t num_triangles,
                     bool dynamic) override;
  void update_obstacles(const Vec3* vertices) override;
  void set_cloth(size_t num_vertices, const uint32_t* indices, const uint32_t* tri_alias, size_t num_triangles,
                 bool cast_against_cloth) override;
  void update_cloth(const Vec3* positions) override;
  void cast(const Ray* rays, size_t count, RawHit* hits) override;

  const HostBvh& obstacle_tree() const { return obstacles_; }
  const HostBvh& cloth_tree() const { return cloth_; }
  // Cloth builds so far, the first one included; last summed area after a refit.
  uint32_t cloth_builds() const { return cloth_.builds; }
  float cloth_area() const { return cloth_area_; }
  BvhScene scene();

 private:
  HostBvh obstacles_, cloth_;
  std::vector<Vec3> obstacle_vertices_, cloth_positions_;
  std::vector<uint32_t> obstacle_indices_, cloth_indices_, tri_alias_;
  bool cloth_enabled_ = false, cloth_built_ = false;
  float cloth_area_ = 0;
};

std::unique_ptr<Collider> make_bvh_collider();

}  // namespace raycloth
