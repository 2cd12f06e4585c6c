// Google Benchmark: the host LBVH (collide/bvh.h) against Embree on the default scene's collision
// rays, and the measurement behind the cloth tree's rebuild trigger (docs/gpu.md):
//
//   raycloth_bench --benchmark_filter='Bvh|Embree'        refit and cast, BVH vs Embree
//   raycloth_bench --benchmark_filter=ClothTreeDegradation  refit-only tree vs fresh build over 3 s
#include <benchmark/benchmark.h>

#include <map>
#include <string>
#include <memory>
#include <vector>

#include "collide/bvh.h"
#include "collide/cpu/embree_collider.h"
#include "raycloth/simulator.h"
#include "sim/model.h"

using namespace raycloth;

namespace {

// The default scene simulated on the CPU, positions and velocities kept at the requested steps.
struct Trajectory {
  SceneDef scene = default_scene();
  ClothModel model = build_cloth_model(scene);
  ObstacleSet obstacles = build_obstacles(scene);
  std::map<int, std::vector<Vec3>> x, v;

  explicit Trajectory(const std::vector<int>& steps) {
    Simulator sim(scene);
    for (int s : steps) {
      sim.step(s - int(sim.steps()));
      x[s] = sim.positions();
      v[s] = sim.velocities();
    }
  }

  // The paper's velocity ray from every free vertex, as finish_integrate builds it.
  std::vector<Ray> rays(int step) const {
    CollisionParams p;
    p.tolerance = scene.collision.tolerance;
    p.thickness = scene.collision.thickness;
    const float dt = float(scene.time.dt);
    std::vector<Ray> r;
    for (uint32_t i = 0; i < model.num_vertices(); ++i) {
      const Vec3 xi = x.at(step)[i];
      const Ray ray = velocity_ray(xi, xi + v.at(step)[i] * dt, model.alias[i], p);
      if (model.inv_mass[i] != 0.0f && ray.tmax > 0.0f) r.push_back(ray);
    }
    return r;
  }

  void load(Collider& c) const {
    c.set_obstacles(obstacles.world.vertices.data(), obstacles.world.vertices.size(), obstacles.world.indices.data(),
                    obstacles.world.num_triangles(), false);
    c.set_cloth(model.num_vertices(), model.collision_triangles.data(), model.tri_alias.data(),
                model.num_collision_triangles(), scene.collision.cloth_cloth);
  }
};

constexpr int kDrapeStep = 1000;  // 0.4 s: the cloth lies on the sphere and folds over itself

const Trajectory& drape() {
  static const Trajectory t({kDrapeStep});
  return t;
}

std::unique_ptr<Collider> loaded(bool bvh) {
  auto c = bvh ? make_bvh_collider() : make_embree_collider();
  drape().load(*c);
  c->update_cloth(drape().model.initial_positions.data());
  return c;
}

void refit(benchmark::State& state, bool bvh) {
  const Trajectory& t = drape();
  auto c = loaded(bvh);
  const std::vector<Vec3>& a = t.model.initial_positions;
  const std::vector<Vec3>& b = t.x.at(kDrapeStep);
  bool flip = false;
  for (auto _ : state) {
    c->update_cloth((flip ? a : b).data());
    flip = !flip;
  }
  state.counters["triangles"] = double(t.model.num_collision_triangles());
}

void cast(benchmark::State& state, bool bvh) {
  const Trajectory& t = drape();
  auto c = loaded(bvh);
  c->update_cloth(t.x.at(kDrapeStep).data());
  const std::vector<Ray> rays = t.rays(kDrapeStep);
  std::vector<RawHit> hits(rays.size());
  for (auto _ : state) {
    c->cast(rays.data(), rays.size(), hits.data());
    benchmark::DoNotOptimize(hits.data());
  }
  size_t n = 0;
  for (const RawHit& h : hits) n += h.kind != kHitNone;
  state.counters["rays"] = double(rays.size());
  state.counters["hits"] = double(n);
  state.counters["rays/s"] = benchmark::Counter(double(rays.size()) * double(state.iterations()),
                                                benchmark::Counter::kIsRate);
}

// A full host build of the draped cloth: what a rebuild costs.
void BM_BvhBuildCloth(benchmark::State& state) {
  const Trajectory& t = drape();
  const std::vector<Vec3>& x = t.x.at(kDrapeStep);
  HostBvh tree;
  for (auto _ : state) build_bvh(tree, x.data(), t.model.collision_triangles.data(), t.model.num_collision_triangles());
  state.counters["triangles"] = double(t.model.num_collision_triangles());
}

void BM_BvhRefitCloth(benchmark::State& state) { refit(state, true); }
void BM_EmbreeRefitCloth(benchmark::State& state) { refit(state, false); }
void BM_BvhCast(benchmark::State& state) { cast(state, true); }
void BM_EmbreeCast(benchmark::State& state) { cast(state, false); }
BENCHMARK(BM_BvhBuildCloth)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_BvhRefitCloth)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_EmbreeRefitCloth)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_BvhCast)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_EmbreeCast)->Unit(benchmark::kMicrosecond)->UseRealTime();

// ---- The rebuild trigger ----------------------------------------------------------------------------

// Every 0.2 s of the 3 s drape (dt = 4e-4 s: 500 steps).
const Trajectory& full_drape() {
  static const Trajectory t([] {
    std::vector<int> steps;
    for (int s = 0; s <= 7500; s += 500) steps.push_back(s);
    return steps;
  }());
  return t;
}

// Cloth-tree work per velocity ray: boxes and triangles tested.
TraceStats cloth_work(HostBvh& tree, const Trajectory& t, const std::vector<Vec3>& x, const std::vector<Ray>& rays) {
  TraceStats stats;
  const BvhView view = tree.view();
  for (const Ray& r : rays)
    trace_nearest(view, x.data(), t.model.collision_triangles.data(), r,
                  SkipOwnTriangles{t.model.tri_alias.data(), r.vertex}, kHitCloth, &stats);
  return stats;
}

// At step range(0): the tree built at t = 0 and refit ever since against a tree built now. Counters:
// area_vs_built (what the trigger watches: refit area / area at the build), area_vs_fresh (refit
// area / a fresh build's), nodes_ratio and triangles_ratio (traversal work, refit / fresh).
void BM_ClothTreeDegradation(benchmark::State& state) {
  const Trajectory& t = full_drape();
  const int step = int(state.range(0));
  const std::vector<Vec3>& x0 = t.x.at(0);
  const std::vector<Vec3>& x = t.x.at(step);
  const uint32_t n = t.model.num_collision_triangles();
  HostBvh old_tree, fresh;
  build_bvh(old_tree, x0.data(), t.model.collision_triangles.data(), n);
  refit_bvh(old_tree, x.data(), t.model.collision_triangles.data());
  build_bvh(fresh, x.data(), t.model.collision_triangles.data(), n);
  const std::vector<Ray> rays = t.rays(step);
  TraceStats refit_work, fresh_work;
  for (auto _ : state) {
    refit_work = cloth_work(old_tree, t, x, rays);
    fresh_work = cloth_work(fresh, t, x, rays);
  }
  const float area = bvh_area(old_tree.view());
  state.counters["t_s"] = double(step) * t.scene.time.dt;
  state.counters["area_vs_built"] = area / old_tree.built_area;
  state.counters["area_vs_fresh"] = area / fresh.built_area;
  state.counters["nodes_ratio"] = double(refit_work.nodes) / double(fresh_work.nodes);
  state.counters["triangles_ratio"] = double(refit_work.triangles) / double(fresh_work.triangles);
  state.counters["fresh_nodes_per_ray"] = double(fresh_work.nodes) / double(rays.size());
}
BENCHMARK(BM_ClothTreeDegradation)->DenseRange(500, 7500, 500)->Iterations(1)->Unit(benchmark::kMillisecond);

// The trigger itself over the whole 3 s drape, checked after every step as BvhCollider does, for
// several factors at once: how many rebuilds each causes (rebuilds_F), when the first happens
// (first_rebuild_s_F), and the traversal work of its tree against a fresh build, averaged over
// every 0.2 s (nodes_ratio_F).
void BM_ClothRebuildTrigger(benchmark::State& state) {
  const SceneDef scene = default_scene();
  const ClothModel model = build_cloth_model(scene);
  const uint32_t n = model.num_collision_triangles();
  const float factors[] = {1.25f, 1.5f, 2.0f, 3.0f};
  constexpr int kFactors = 4;
  for (auto _ : state) {
    Simulator sim(scene);
    HostBvh trees[kFactors];
    int rebuilds[kFactors] = {};
    double first[kFactors] = {}, ratio_sum[kFactors] = {};
    int samples = 0;
    for (HostBvh& tree : trees) build_bvh(tree, model.initial_positions.data(), model.collision_triangles.data(), n);
    for (int step = 1; step <= 7500; ++step) {
      sim.step(1);
      const std::vector<Vec3>& x = sim.positions();
      for (int f = 0; f < kFactors; ++f) {
        refit_bvh(trees[f], x.data(), model.collision_triangles.data());
        if (bvh_needs_rebuild(bvh_area(trees[f].view()), trees[f].built_area, factors[f])) {
          build_bvh(trees[f], x.data(), model.collision_triangles.data(), n);
          if (rebuilds[f]++ == 0) first[f] = sim.time();
        }
      }
      if (step % 500 == 0) {
        Trajectory t({});
        t.x[step] = x;
        t.v[step] = sim.velocities();
        const std::vector<Ray> rays = t.rays(step);
        HostBvh fresh;
        build_bvh(fresh, x.data(), model.collision_triangles.data(), n);
        const double fresh_nodes = double(cloth_work(fresh, t, x, rays).nodes);
        for (int f = 0; f < kFactors; ++f) ratio_sum[f] += double(cloth_work(trees[f], t, x, rays).nodes) / fresh_nodes;
        ++samples;
      }
    }
    for (int f = 0; f < kFactors; ++f) {
      const std::string suffix = "_" + std::to_string(factors[f]).substr(0, 4);
      state.counters["rebuilds" + suffix] = rebuilds[f];
      state.counters["first_rebuild_s" + suffix] = first[f];
      state.counters["nodes_ratio" + suffix] = ratio_sum[f] / samples;
    }
  }
}
BENCHMARK(BM_ClothRebuildTrigger)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
