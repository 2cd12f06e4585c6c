// Host build and refit of the LBVH (bvh.h) with oneTBB, and the Collider over it. The per-node work
// is the RC_HD code in bvh.h that the device build (collide/cuda/device_bvh.cu) runs as kernels.
#include "collide/bvh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <string>

#include "raycloth/error.h"

namespace raycloth {

namespace {

// RAYCLOTH_VALIDATE builds check every tree after each build and refit.
void validate(const HostBvh& bvh, const Vec3* vertices, const uint32_t* indices, const char* which) {
#if defined(RAYCLOTH_VALIDATE)
  const uint32_t bad = bvh_find_bad_node(bvh, vertices, indices);
  if (bad != kBvhNone)
    throw SimulationError(std::string("BVH invariant broken in the ") + which + " tree: node " + std::to_string(bad) +
                          " does not contain what is below it");
#else
  (void)bvh, (void)vertices, (void)indices, (void)which;
#endif
}

template <class F>
void parallel_for_index(uint32_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 256), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

}  // namespace

void build_bvh(HostBvh& bvh, const Vec3* vertices, const uint32_t* indices, uint32_t num_triangles) {
  const uint32_t n = num_triangles;
  bvh.num_prims = n;
  bvh.child.assign(n > 1 ? 2 * size_t(n - 1) : 0, kBvhNone);
  bvh.parent.assign(bvh_num_nodes(n), kBvhNone);
  bvh.bounds.assign(bvh_num_nodes(n), Aabb());
  bvh.prim.resize(n);
  bvh.counter.assign(n > 1 ? n - 1 : 0, 0u);
  ++bvh.builds;
  if (n == 0) {
    bvh.built_area = 0;
    return;
  }

  // Morton codes of the centroids in the centroids' box, then a stable sort by code: the same order
  // as the device's stable radix sort, so both build the same tree from the same input.
  std::vector<Vec3> centroid(n);
  parallel_for_index(n, [&](uint32_t i) { centroid[i] = triangle_centroid(vertices, indices, i); });
  const Aabb box = tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, n, 1024), Aabb(),
      [&](const tbb::blocked_range<uint32_t>& r, Aabb b) {
        for (uint32_t i = r.begin(); i != r.end(); ++i) b = aabb_union(b, Aabb{centroid[i], centroid[i]});
        return b;
      },
      [](const Aabb& a, const Aabb& b) { return aabb_union(a, b); });
  std::vector<uint64_t> code(n), sorted(n);
  parallel_for_index(n, [&](uint32_t i) { code[i] = morton_code(centroid[i], box); });
  std::iota(bvh.prim.begin(), bvh.prim.end(), 0u);
  std::stable_sort(bvh.prim.begin(), bvh.prim.end(), [&](uint32_t a, uint32_t b) { return code[a] < code[b]; });
  for (uint32_t k = 0; k < n; ++k) sorted[k] = code[bvh.prim[k]];

  BvhView view = bvh.view();
  parallel_for_index(n - 1, [&](uint32_t i) { build_internal_node(view, sorted.data(), i); });
  refit_bvh(bvh, vertices, indices);
  bvh.built_area = bvh_area(bvh.view());
}

void refit_bvh(HostBvh& bvh, const Vec3* vertices, const uint32_t* indices) {
  if (bvh.num_prims == 0) return;
  std::fill(bvh.counter.begin(), bvh.counter.end(), 0u);
  const BvhView view = bvh.view();
  parallel_for_index(bvh.num_prims, [&](uint32_t k) { refit_from_leaf(view, vertices, indices, k); });
}

float bvh_area(const BvhView& bvh) {
  if (bvh.num_prims == 0) return 0.0f;
  if (bvh.num_prims == 1) return aabb_half_area(bvh.bounds[0]);
  double sum = 0;  // sequential, in node order: the same number on every run
  for (uint32_t i = 0; i + 1 < bvh.num_prims; ++i) sum += internal_node_area(bvh, i);
  return float(sum);
}

uint32_t bvh_find_bad_node(const HostBvh& bvh, const Vec3* vertices, const uint32_t* indices) {
  const uint32_t n = bvh.num_prims;
  auto contains = [](const Aabb& outer, const Aabb& inner) {
    return outer.lo.x <= inner.lo.x && outer.lo.y <= inner.lo.y && outer.lo.z <= inner.lo.z &&
           outer.hi.x >= inner.hi.x && outer.hi.y >= inner.hi.y && outer.hi.z >= inner.hi.z;
  };
  for (uint32_t node = 0; node < bvh_num_nodes(n); ++node) {
    if (bvh_is_leaf(node, n)) {
      if (!contains(bvh.bounds[node], triangle_box(vertices, indices, bvh.prim[node - bvh_first_leaf(n)])))
        return node;
    } else {
      const uint32_t a = bvh.child[2 * node], b = bvh.child[2 * node + 1];
      if (bvh.parent[a] != node || bvh.parent[b] != node) return node;
      if (!contains(bvh.bounds[node], bvh.bounds[a]) || !contains(bvh.bounds[node], bvh.bounds[b])) return node;
    }
  }
  return kBvhNone;
}

// ---- BvhCollider ---------------------------------------------------------------------------------

void BvhCollider::set_obstacles(const Vec3* vertices, size_t num_vertices, const uint32_t* indices,
                                size_t num_triangles, bool) {
  obstacle_vertices_.assign(vertices, vertices + num_vertices);
  obstacle_indices_.assign(indices, indices + 3 * num_triangles);
  obstacles_ = HostBvh();
  build_bvh(obstacles_, obstacle_vertices_.data(), obstacle_indices_.data(), uint32_t(num_triangles));
  validate(obstacles_, obstacle_vertices_.data(), obstacle_indices_.data(), "obstacle");
}

// Obstacles move rigidly, which keeps the hierarchy's quality: a refit is enough.
void BvhCollider::update_obstacles(const Vec3* vertices) {
  if (obstacles_.num_prims == 0) return;
  std::memcpy(obstacle_vertices_.data(), vertices, obstacle_vertices_.size() * sizeof(Vec3));
  refit_bvh(obstacles_, obstacle_vertices_.data(), obstacle_indices_.data());
  validate(obstacles_, obstacle_vertices_.data(), obstacle_indices_.data(), "obstacle");
}

void BvhCollider::set_cloth(size_t num_vertices, const uint32_t* indices, const uint32_t* tri_alias,
                            size_t num_triangles, bool cast_against_cloth) {
  cloth_ = HostBvh();
  cloth_built_ = false;
  cloth_area_ = 0;
  cloth_enabled_ = cast_against_cloth && num_triangles > 0;
  cloth_positions_.assign(num_vertices, make_vec3(0, 0, 0));
  cloth_indices_.assign(indices, indices + 3 * num_triangles);
  tri_alias_.assign(tri_alias, tri_alias + 3 * num_triangles);
}

void BvhCollider::update_cloth(const Vec3* positions) {
  if (!cloth_enabled_) return;
  std::memcpy(cloth_positions_.data(), positions, cloth_positions_.size() * sizeof(Vec3));
  const uint32_t n = uint32_t(cloth_indices_.size() / 3);
  if (!cloth_built_) {
    build_bvh(cloth_, cloth_positions_.data(), cloth_indices_.data(), n);
    cloth_built_ = true;
    cloth_area_ = cloth_.built_area;
    validate(cloth_, cloth_positions_.data(), cloth_indices_.data(), "cloth");
    return;
  }
  refit_bvh(cloth_, cloth_positions_.data(), cloth_indices_.data());
  cloth_area_ = bvh_area(cloth_.view());
  if (bvh_needs_rebuild(cloth_area_, cloth_.built_area)) {
    build_bvh(cloth_, cloth_positions_.data(), cloth_indices_.data(), n);
    cloth_area_ = cloth_.built_area;
  }
  validate(cloth_, cloth_positions_.data(), cloth_indices_.data(), "cloth");
}

BvhScene BvhCollider::scene() {
  BvhScene s;
  s.obstacles = obstacles_.view();
  s.obstacle_vertices = obstacle_vertices_.data();
  s.obstacle_indices = obstacle_indices_.data();
  if (cloth_built_) s.cloth = cloth_.view();  // like Embree: no cloth hits before the first update
  s.cloth_positions = cloth_positions_.data();
  s.cloth_indices = cloth_indices_.data();
  s.tri_alias = tri_alias_.data();
  return s;
}

void BvhCollider::cast(const Ray* rays, size_t count, RawHit* hits) {
  const BvhScene s = scene();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) hits[i] = trace_collision(s, rays[i]);
  });
}

std::unique_ptr<Collider> make_bvh_collider() { return std::make_unique<BvhCollider>(); }

}  // namespace raycloth
