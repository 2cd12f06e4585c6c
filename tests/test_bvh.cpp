// The LBVH (collide/bvh.h) on the host: valid trees, hits equal to Embree's on triangle soups and on
// the default scene's cloth (before and after refitting), the own-triangle rule, the rebuild trigger.
// The same traversal and refit code runs in the CUDA kernels, so this is what CI can check of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <memory>
#include <cstdio>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "collide/bvh.h"
#include "collide/cpu/embree_collider.h"
#include "raycloth/simulator.h"
#include "sim/model.h"
#include "sim/backend.h"
#include "sim/stages.h"

using namespace raycloth;

namespace {

struct Soup {
  std::vector<Vec3> vertices;
  std::vector<uint32_t> indices;
  uint32_t num_triangles() const { return uint32_t(indices.size() / 3); }
};

Vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (;;) {
    const Vec3 d = make_vec3(g(rng), g(rng), g(rng));
    if (length(d) > 1e-3f) return normalize_or_zero(d);
  }
}

// n triangles of 2 to 20 cm scattered in a 2 m cube; `duplicates` of them repeated exactly (equal
// Morton codes and equal boxes: the tie-break path of the build).
Soup random_soup(uint32_t n, uint32_t seed, uint32_t duplicates = 0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.0f, 1.0f), size(0.02f, 0.2f);
  Soup s;
  for (uint32_t t = 0; t < n; ++t) {
    const Vec3 c = make_vec3(pos(rng), pos(rng), pos(rng));
    for (int k = 0; k < 3; ++k) {
      s.indices.push_back(uint32_t(s.vertices.size()));
      s.vertices.push_back(c + random_unit(rng) * size(rng));
    }
  }
  for (uint32_t d = 0; d < duplicates && n > 0; ++d) {
    const uint32_t t = d % n;
    for (int k = 0; k < 3; ++k) s.indices.push_back(s.indices[3 * t + k]);
  }
  return s;
}

// Short rays with random origins in the soup's cube and random directions.
std::vector<Ray> random_rays(size_t count, uint32_t seed, float max_length) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.1f, 1.1f), len(0.01f, max_length);
  std::vector<Ray> rays(count);
  for (Ray& r : rays) {
    r.org = make_vec3(pos(rng), pos(rng), pos(rng));
    r.dir = random_unit(rng);
    r.tmax = len(rng);
    r.vertex = kBvhNone;
  }
  return rays;
}

struct Comparison {
  size_t rays = 0, hits = 0, mismatches = 0;
  std::string first;
};

// Same kind, same primitive and t within 1e-5; a different primitive only at the same t (a ray
// through an edge shared by two triangles may report either).
Comparison compare(const std::vector<Ray>& rays, const std::vector<RawHit>& bvh, const std::vector<RawHit>& embree) {
  Comparison c;
  c.rays = rays.size();
  for (size_t i = 0; i < rays.size(); ++i) {
    const RawHit& a = bvh[i];
    const RawHit& b = embree[i];
    bool same = a.kind == b.kind;
    if (same && a.kind != kHitNone) same = std::fabs(a.t - b.t) <= 1e-5f;
    if (a.kind != kHitNone) ++c.hits;
    if (!same) {
      if (c.mismatches++ == 0)
        c.first = "ray " + std::to_string(i) + ": bvh kind " + std::to_string(a.kind) + " prim " +
                  std::to_string(a.prim) + " t " + std::to_string(a.t) + ", embree kind " + std::to_string(b.kind) +
                  " prim " + std::to_string(b.prim) + " t " + std::to_string(b.t);
    }
  }
  return c;
}

std::vector<RawHit> cast(Collider& c, const std::vector<Ray>& rays) {
  std::vector<RawHit> hits(rays.size());
  c.cast(rays.data(), rays.size(), hits.data());
  return hits;
}

// Every primitive in exactly one leaf, every box containing what is below it, parents consistent.
void expect_valid_tree(const HostBvh& bvh, const Vec3* vertices, const uint32_t* indices) {
  const uint32_t n = bvh.num_prims;
  EXPECT_EQ(bvh_find_bad_node(bvh, vertices, indices), kBvhNone);
  std::vector<int> seen(n, 0);
  for (uint32_t p : bvh.prim) ++seen[p];
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int k) { return k == 1; }));
  ASSERT_GT(n, 0u);
  EXPECT_EQ(bvh.parent[0], kBvhNone);
  // Every node is reached exactly once from the root.
  std::vector<int> reached(bvh_num_nodes(n), 0);
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const uint32_t node = stack.back();
    stack.pop_back();
    ++reached[node];
    if (!bvh_is_leaf(node, n)) {
      stack.push_back(bvh.child[2 * node]);
      stack.push_back(bvh.child[2 * node + 1]);
    }
  }
  EXPECT_TRUE(std::all_of(reached.begin(), reached.end(), [](int k) { return k == 1; }));
}

// The default scene's cloth and sphere, with the cloth at `positions`.
struct ClothScene {
  SceneDef scene = default_scene();
  ClothModel model = build_cloth_model(scene);
  ObstacleSet obstacles = build_obstacles(scene);

  void load(Collider& c) const {
    c.set_obstacles(obstacles.world.vertices.data(), obstacles.world.vertices.size(), obstacles.world.indices.data(),
                    obstacles.world.num_triangles(), false);
    c.set_cloth(model.num_vertices(), model.collision_triangles.data(), model.tri_alias.data(),
                model.num_collision_triangles(), true);
  }
};

// Rays from every free cloth vertex: along its velocity (the paper's ray) when it moves, and in a
// random direction, `length` long.
std::vector<Ray> cloth_rays(const ClothModel& m, const std::vector<Vec3>& x, const std::vector<Vec3>& v, float dt,
                            uint32_t seed, float length_scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> len(0.002f, length_scale);
  CollisionParams p;
  std::vector<Ray> rays;
  for (uint32_t i = 0; i < m.num_vertices(); ++i) {
    if (m.inv_mass[i] == 0.0f) continue;
    Ray r = velocity_ray(x[i], x[i] + v[i] * dt, m.alias[i], p);
    if (r.tmax > 0.0f) rays.push_back(r);
    Ray q;
    q.org = x[i];
    q.dir = random_unit(rng);
    q.tmax = len(rng);
    q.vertex = m.alias[i];
    rays.push_back(q);
  }
  return rays;
}

// The CPU backend's step (sim/step.h) with the collider as a parameter: what the CUDA backend does
// with its BVH, here on the host. With a second collider, every cast is repeated with it on the same
// rays and state and the two compared (the result of the first is used).
struct StagedRun {
  std::vector<Vec3> x;
  std::vector<uint64_t> hits;  // per step
  int first_hit_step = -1;     // first step with an entry in the collision buffer
  std::vector<Vec3> x_before_contact;  // state at the end of the step before first_hit_step
  size_t checked_rays = 0, mismatches = 0;
  std::string first_mismatch;
};

class CheckingCollider final : public Collider {
 public:
  CheckingCollider(std::unique_ptr<Collider> main, std::unique_ptr<Collider> check, StagedRun& run)
      : main_(std::move(main)), check_(std::move(check)), run_(run) {}
  void set_obstacles(const Vec3* v, size_t nv, const uint32_t* idx, size_t nt, bool dynamic) override {
    for (Collider* c : both()) if (c) c->set_obstacles(v, nv, idx, nt, dynamic);
  }
  void update_obstacles(const Vec3* v) override {
    for (Collider* c : both()) if (c) c->update_obstacles(v);
  }
  void set_cloth(size_t nv, const uint32_t* idx, const uint32_t* alias, size_t nt, bool on) override {
    for (Collider* c : both()) if (c) c->set_cloth(nv, idx, alias, nt, on);
  }
  void update_cloth(const Vec3* x) override {
    for (Collider* c : both()) if (c) c->update_cloth(x);
    ++updates_;
  }
  void cast(const Ray* rays, size_t count, RawHit* hits) override {
    main_->cast(rays, count, hits);
    if (!check_) return;
    other_.resize(count);
    check_->cast(rays, count, other_.data());
    const std::vector<Ray> r(rays, rays + count);
    const std::vector<RawHit> h(hits, hits + count);
    const Comparison c = compare(r, h, other_);
    run_.checked_rays += c.rays;
    if (c.mismatches && run_.mismatches == 0) run_.first_mismatch = "step " + std::to_string(updates_) + ", " + c.first;
    run_.mismatches += c.mismatches;
  }

 private:
  std::array<Collider*, 2> both() { return {main_.get(), check_.get()}; }
  std::unique_ptr<Collider> main_, check_;
  StagedRun& run_;
  std::vector<RawHit> other_;
  int updates_ = 0;
};

StagedRun run_stages(const ClothScene& cs, const ClothModel& model, std::unique_ptr<Collider> collider, int steps,
                     std::unique_ptr<Collider> check = nullptr) {
  StagedRun r;
  const BackendInput in{&cs.scene, &model, &cs.obstacles};
  auto backend = make_cpu_backend(in, std::make_unique<CheckingCollider>(std::move(collider), std::move(check), r));
  StageTimes times;
  std::vector<Vec3> x, v;
  for (int k = 0; k < steps; ++k) {
    backend->download(x, v);
    const StepResult s = backend->step(1, uint64_t(k), times);
    EXPECT_LT(s.bad_vertex, 0) << "step " << k;
    r.hits.push_back(s.hits);
    if (s.hits > 0 && r.first_hit_step < 0) {
      r.first_hit_step = k;
      r.x_before_contact = x;
    }
  }
  backend->download(r.x, v);
  return r;
}

// How far two runs of the same scene ended apart.
struct Divergence {
  double mean = 0, max = 0, centroid = 0, hits_ratio = 0;  // metres; hits over the last 100 steps, b / a
};

Divergence divergence(const StagedRun& a, const StagedRun& b) {
  Divergence d;
  Vec3 ca = make_vec3(0, 0, 0), cb = ca;
  for (size_t i = 0; i < a.x.size(); ++i) {
    const double e = length(a.x[i] - b.x[i]);
    d.mean += e;
    d.max = std::max(d.max, e);
    ca += a.x[i];
    cb += b.x[i];
  }
  d.mean /= double(a.x.size());
  d.centroid = length(ca - cb) / float(a.x.size());
  uint64_t ha = 0, hb = 0;
  for (size_t k = a.hits.size() - 100; k < a.hits.size(); ++k) ha += a.hits[k], hb += b.hits[k];
  d.hits_ratio = double(hb) / double(ha);
  return d;
}

}  // namespace

TEST(BvhBuild, TreesAreValidForAnySize) {
  for (uint32_t n : {1u, 2u, 3u, 5u, 17u, 64u, 1000u, 4099u}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    Soup s = random_soup(n, 7 + n, n / 3);
    HostBvh bvh;
    build_bvh(bvh, s.vertices.data(), s.indices.data(), s.num_triangles());
    EXPECT_EQ(bvh.num_prims, s.num_triangles());
    expect_valid_tree(bvh, s.vertices.data(), s.indices.data());
    EXPECT_GT(bvh.built_area, 0.0f);
    EXPECT_EQ(bvh_area(bvh.view()), bvh.built_area);
  }
}

TEST(BvhBuild, MortonCodesInterleaveAxesAndClampToTheBox) {
  Aabb box;
  box.lo = make_vec3(0, 0, 0);
  box.hi = make_vec3(1, 1, 1);
  EXPECT_EQ(morton_code(make_vec3(0, 0, 0), box), 0u);
  EXPECT_EQ(morton_code(make_vec3(1, 1, 1), box), (1ull << 63) - 1);
  EXPECT_EQ(morton_code(make_vec3(2, -1, 5), box), morton_code(make_vec3(1, 0, 1), box));
  // x is the most significant of each bit triple.
  EXPECT_GT(morton_code(make_vec3(0.9f, 0, 0), box), morton_code(make_vec3(0, 0.9f, 0.9f), box));
  // A flat axis (a cloth lying in a plane) quantizes to 0 instead of dividing by zero.
  box.hi.y = 0;
  EXPECT_EQ(morton_code(make_vec3(0, 0, 0), box), 0u);
}

TEST(BvhTrace, SoupHitsEqualEmbree) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    Soup s = random_soup(3000, seed, 50);
    auto bvh = make_bvh_collider();
    auto embree = make_embree_collider();
    for (Collider* c : {bvh.get(), embree.get()})
      c->set_obstacles(s.vertices.data(), s.vertices.size(), s.indices.data(), s.num_triangles(), false);
    const std::vector<Ray> rays = random_rays(50000, 100 + seed, 0.6f);
    const Comparison c = compare(rays, cast(*bvh, rays), cast(*embree, rays));
    EXPECT_GT(c.hits, rays.size() / 20) << "too few hits to mean anything";
    EXPECT_EQ(c.mismatches, 0u) << c.first;
  }
}

TEST(BvhTrace, SoupHitsEqualEmbreeAfterMovingAndRefitting) {
  Soup s = random_soup(3000, 11, 20);
  auto bvh = make_bvh_collider();
  auto embree = make_embree_collider();
  for (Collider* c : {bvh.get(), embree.get()})
    c->set_obstacles(s.vertices.data(), s.vertices.size(), s.indices.data(), s.num_triangles(), true);
  std::mt19937 rng(12);
  std::normal_distribution<float> jitter(0.0f, 0.05f);
  for (int round = 0; round < 3; ++round) {
    for (Vec3& v : s.vertices) v += make_vec3(jitter(rng), jitter(rng), jitter(rng));
    for (Collider* c : {bvh.get(), embree.get()}) c->update_obstacles(s.vertices.data());
    const auto& tree = static_cast<BvhCollider&>(*bvh).obstacle_tree();
    EXPECT_EQ(bvh_find_bad_node(tree, s.vertices.data(), s.indices.data()), kBvhNone);
    const std::vector<Ray> rays = random_rays(30000, 200 + round, 0.6f);
    const Comparison c = compare(rays, cast(*bvh, rays), cast(*embree, rays));
    EXPECT_EQ(c.mismatches, 0u) << "round " << round << ": " << c.first;
  }
}

TEST(BvhTrace, DefaultSceneClothHitsEqualEmbreeAfterRefitting) {
  ClothScene cs;
  auto bvh = make_bvh_collider();
  auto embree = make_embree_collider();
  for (Collider* c : {bvh.get(), embree.get()}) cs.load(*c);
  // The real drape: positions and velocities of the CPU simulation at 0, 0.12, 0.24 and 0.4 s.
  Simulator sim(cs.scene);
  const float dt = float(cs.scene.time.dt);
  for (int round = 0; round < 4; ++round) {
    if (round > 0) sim.step(round == 3 ? 400 : 300);
    const std::vector<Vec3> x = sim.positions(), v = sim.velocities();
    for (Collider* c : {bvh.get(), embree.get()}) c->update_cloth(x.data());
    auto& tree = static_cast<BvhCollider&>(*bvh);
    EXPECT_EQ(bvh_find_bad_node(tree.cloth_tree(), x.data(), cs.model.collision_triangles.data()), kBvhNone);
    const std::vector<Ray> rays = cloth_rays(cs.model, x, v, dt, 300 + round, 0.05f);
    const std::vector<RawHit> a = cast(*bvh, rays), b = cast(*embree, rays);
    const Comparison c = compare(rays, a, b);
    size_t cloth_hits = 0;
    for (const RawHit& h : a) cloth_hits += h.kind == kHitCloth;
    EXPECT_EQ(c.mismatches, 0u) << "t = " << sim.time() << ": " << c.first;
    if (round > 0) EXPECT_GT(cloth_hits, 0u) << "the drape should have cloth-cloth hits";
  }
}

TEST(BvhTrace, RaysNeverHitTheirOwnTrianglesOrTheirSeamPartners) {
  ClothScene cs;
  BvhCollider bvh;
  cs.load(bvh);
  const std::vector<Vec3>& x = cs.model.initial_positions;
  bvh.update_cloth(x.data());
  // From just above and just below every vertex, rays back through the cloth's plane close to the
  // vertex: without the rule most would hit one of the vertex's own triangles.
  std::vector<Ray> rays;
  for (uint32_t i = 0; i < cs.model.num_vertices(); ++i)
    for (float side : {-1.0f, 1.0f}) {
      Ray r;
      r.dir = normalize_or_zero(make_vec3(0.3f, -side, 0.2f));
      r.org = x[i] - r.dir * 1e-3f;
      r.tmax = 0.01f;
      r.vertex = cs.model.alias[i];
      rays.push_back(r);
    }
  std::vector<RawHit> hits(rays.size());
  bvh.cast(rays.data(), rays.size(), hits.data());
  const BvhScene scene = bvh.scene();
  size_t own_without_rule = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (hits[i].kind == kHitCloth)
      EXPECT_FALSE(is_own_triangle(cs.model.tri_alias.data(), hits[i].prim, rays[i].vertex)) << "ray " << i;
    const RawHit any = trace_nearest(scene.cloth, scene.cloth_positions, scene.cloth_indices, rays[i], AcceptAll(),
                                     kHitCloth);
    if (any.kind == kHitCloth && is_own_triangle(cs.model.tri_alias.data(), any.prim, rays[i].vertex))
      ++own_without_rule;
  }
  EXPECT_GT(own_without_rule, rays.size() / 2) << "the rays should start on their own triangles";
  // Seam partners share an alias: a ray from half_a's top edge skips half_b's bottom-row triangles.
  const Piece& a = cs.model.pieces[0];
  const uint32_t top_left = a.first_vertex + (a.resolution_v - 1) * a.resolution_u;
  uint32_t partner_triangles = 0;
  for (uint32_t t = 0; t < cs.model.num_collision_triangles(); ++t)
    if (t >= cs.model.pieces[1].first_triangle &&
        is_own_triangle(cs.model.tri_alias.data(), t, cs.model.alias[top_left + 1]))
      ++partner_triangles;
  EXPECT_GT(partner_triangles, 0u) << "half_b's triangles at the seam carry half_a's aliases";
}

TEST(BvhTrace, NoClothHitsBeforeTheFirstUpdateLikeEmbree) {
  ClothScene cs;
  auto bvh = make_bvh_collider();
  auto embree = make_embree_collider();
  for (Collider* c : {bvh.get(), embree.get()}) cs.load(*c);
  const std::vector<Vec3> v(cs.model.num_vertices(), make_vec3(0, -1, 0));
  const std::vector<Ray> rays = cloth_rays(cs.model, cs.model.initial_positions, v, 0.01f, 5, 0.1f);
  const Comparison c = compare(rays, cast(*bvh, rays), cast(*embree, rays));
  EXPECT_EQ(c.mismatches, 0u) << c.first;
}

TEST(BvhRebuild, RefitKeepsTheTreeUntilItHasDegradedPastTheFactor) {
  ClothScene cs;
  auto embree = make_embree_collider();
  BvhCollider bvh;
  for (Collider* c : {static_cast<Collider*>(&bvh), embree.get()}) cs.load(*c);
  std::vector<Vec3> x = cs.model.initial_positions;
  bvh.update_cloth(x.data());
  EXPECT_EQ(bvh.cloth_builds(), 1u);
  const float built = bvh.cloth_tree().built_area;
  EXPECT_EQ(bvh.cloth_area(), built);

  // A rigid shift keeps every box's shape: refit only.
  for (Vec3& p : x) p += make_vec3(0.1f, -0.2f, 0.05f);
  bvh.update_cloth(x.data());
  EXPECT_EQ(bvh.cloth_builds(), 1u);
  EXPECT_NEAR(bvh.cloth_area() / built, 1.0f, 1e-3f);

  // Folding the cloth in half in x brings far-apart triangles together: the boxes of the old
  // hierarchy stretch over the fold, but less than the factor.
  for (Vec3& p : x) p.x = std::fabs(p.x - 0.1f);
  bvh.update_cloth(x.data());
  EXPECT_LT(bvh.cloth_area(), kBvhRebuildFactor * built);
  EXPECT_EQ(bvh.cloth_builds(), 1u);

  // Scattering the vertices through a cube makes every box span it: far past the factor, so rebuilt;
  // the fresh tree's area is the new reference. (Not a shuffle of the flat grid: rays starting inside
  // coplanar slivers are a tie between rounding errors, not a test of the tree.)
  std::vector<Vec3> scrambled = x;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> cube(-0.8f, 0.8f);
  for (Vec3& p : scrambled) p = make_vec3(cube(rng), cube(rng), cube(rng));
  bvh.update_cloth(scrambled.data());
  EXPECT_EQ(bvh.cloth_builds(), 2u);
  EXPECT_EQ(bvh.cloth_area(), bvh.cloth_tree().built_area);
  expect_valid_tree(bvh.cloth_tree(), scrambled.data(), cs.model.collision_triangles.data());
  embree->update_cloth(scrambled.data());
  const std::vector<Vec3> v(cs.model.num_vertices(), make_vec3(0, -1, 0));
  const std::vector<Ray> rays = cloth_rays(cs.model, scrambled, v, 0.01f, 9, 0.2f);
  const Comparison c = compare(rays, cast(bvh, rays), cast(*embree, rays));
  EXPECT_EQ(c.mismatches, 0u) << c.first;
}

TEST(BvhRebuild, TriggerIsAStrictFactorOfTheBuiltArea) {
  EXPECT_FALSE(bvh_needs_rebuild(2.0f, 1.0f));
  EXPECT_TRUE(bvh_needs_rebuild(2.01f, 1.0f));
  EXPECT_FALSE(bvh_needs_rebuild(1.4f, 1.0f, 1.5f));
  EXPECT_TRUE(bvh_needs_rebuild(1.6f, 1.0f, 1.5f));
}

// The whole drape with the BVH in place of Embree: the CUDA backend's collision path, run on the
// host for 1000 steps (0.4 s: the cloth falls, wraps the sphere and folds onto itself).
//  - Every cast of the BVH run is repeated with Embree on the same rays and state: equal hits.
//  - Until the first contact the two runs are bit-identical; the Embree run also reproduces the CPU
//    backend bit for bit, which shows that the staged loop is the backend's step.
//  - After contact the drape is chaotic: hits that differ in the last bits of t (two intersection
//    formulas) grow into centimetres. The run with one vertex moved by one ulp shows how far chaos
//    alone takes it; the bounds below, which tests/test_cuda.cpp uses for the GPU too, sit above
//    both. Printed so that docs/gpu.md's numbers come from this command.
TEST(BvhTrace, DrapeWithTheBvhMatchesEmbreeCastByCastAndStaysWithinChaos) {
  ClothScene cs;
  const int steps = 1000;
  const StagedRun a = run_stages(cs, cs.model, make_embree_collider(), steps);
  const StagedRun b = run_stages(cs, cs.model, make_bvh_collider(), steps, make_embree_collider());
  EXPECT_GT(b.checked_rays, size_t(steps) * cs.model.num_vertices());
  // Neither ray test is watertight. The obstacle stage puts a vertex resting over the sphere's pole
  // exactly on the pole vertex's normal, so its contact ray runs through a vertex shared by 24
  // triangles, where the two Moeller implementations round differently (20 of 8.5 million rays
  // here). Rays only estimate contacts; the displacement bound and the exact check decide safety.
  EXPECT_LE(b.mismatches, b.checked_rays / 100000) << b.first_mismatch;

  ASSERT_GT(a.first_hit_step, 0);
  EXPECT_EQ(a.first_hit_step, b.first_hit_step);
  size_t off = 0;
  for (size_t i = 0; i < a.x_before_contact.size(); ++i) {
    const Vec3 p = a.x_before_contact[i], q = b.x_before_contact[i];
    off += p.x != q.x || p.y != q.y || p.z != q.z;
  }
  EXPECT_EQ(off, 0u) << "vertices that differ before the first contact (step " << a.first_hit_step << ")";

  Simulator sim(cs.scene);
  sim.step(steps);
  size_t off_cpu = 0;
  for (size_t i = 0; i < a.x.size(); ++i) {
    const Vec3 p = sim.positions()[i], q = a.x[i];
    off_cpu += p.x != q.x || p.y != q.y || p.z != q.z;
  }
  EXPECT_EQ(off_cpu, 0u) << "the Simulator's CPU backend and the backend with Embree passed in differ";
  EXPECT_EQ(sim.last_hits(), a.hits.back());

  std::vector<std::pair<std::string, Divergence>> d{{"bvh vs embree", divergence(a, b)}};
  for (uint32_t vertex : {777u, 1500u}) {
    ClothModel nudged = cs.model;
    nudged.initial_positions[vertex].y = std::nextafter(nudged.initial_positions[vertex].y, 1.0f);
    d.emplace_back("ulp at " + std::to_string(vertex) + " vs embree",
                   divergence(a, run_stages(cs, nudged, make_embree_collider(), steps)));
  }
  for (const auto& [name, e] : d)
    std::printf("%-22s after %d steps: mean %.4f m, max %.4f m, centroid %.4f m, hits (last 100 steps) x %.3f\n",
                name.c_str(), steps, e.mean, e.max, e.centroid, e.hits_ratio);
  const Divergence& bvh_vs_embree = d.front().second;
  EXPECT_LT(bvh_vs_embree.centroid, 0.03);
  EXPECT_LT(bvh_vs_embree.mean, 0.08);
  EXPECT_NEAR(bvh_vs_embree.hits_ratio, 1.0, 0.25);
}

// Rays through shared vertices meet several triangles at (nearly) the same t; the lowest primitive
// id wins ties, so two differently built trees over the same triangles give identical hits and a
// rebuild, whenever it happens, never changes a simulation.
TEST(BvhRebuild, HitsDoNotDependOnTheTreesShape) {
  ClothScene cs;
  const std::vector<Vec3>& v = cs.obstacles.world.vertices;
  const std::vector<uint32_t>& idx = cs.obstacles.world.indices;
  const uint32_t n = uint32_t(cs.obstacles.world.num_triangles());
  HostBvh fresh, refit;
  build_bvh(fresh, v.data(), idx.data(), n);
  std::vector<Vec3> scattered(v.size());
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> cube(-1.0f, 1.0f);
  for (Vec3& p : scattered) p = make_vec3(cube(rng), cube(rng), cube(rng));
  build_bvh(refit, scattered.data(), idx.data(), n);
  refit_bvh(refit, v.data(), idx.data());
  ASSERT_NE(fresh.prim, refit.prim) << "the two trees should differ";
  size_t hits = 0;
  for (const Vec3& p : v) {
    const Vec3 out = normalize_or_zero(p);
    Ray r;
    r.org = p + out * 0.01f;
    r.dir = -out;
    r.tmax = 0.02f;
    const RawHit a = trace_nearest(fresh.view(), v.data(), idx.data(), r, AcceptAll(), kHitObstacle);
    const RawHit b = trace_nearest(refit.view(), v.data(), idx.data(), r, AcceptAll(), kHitObstacle);
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.prim, b.prim);
    EXPECT_EQ(a.t, b.t);
    hits += a.kind != kHitNone;
  }
  // Moeller-Trumbore is not watertight: some rays through a vertex slip between its triangles (as
  // with Embree's Moeller test); most do not.
  EXPECT_GT(hits, v.size() * 3 / 4);
}
