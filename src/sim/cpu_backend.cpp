// CPU backend: the step of sim/step.h with oneTBB loops; rays cast by Embree (or any Collider),
// proximity queries on the host BVH; checkpoints and edits between steps.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <utility>
#include <variant>

#include "collide/bvh.h"
#include "collide/cpu/embree_collider.h"
#include "core/bytes.h"
#include "sim/backend.h"
#include "sim/integrate/integrators.h"
#include "sim/state.h"
#include "sim/step.h"

namespace raycloth {

namespace {

using Clock = std::chrono::steady_clock;
constexpr uint32_t kGrain = 256;
constexpr uint32_t kPhaseGrain = 16;

class CpuBackend final : public Backend {
 public:
  CpuBackend(const BackendInput& in, std::unique_ptr<Collider> collider)
      : in_(in), scene_(*in.scene), model_(*in.model), obstacles_(*in.obstacles), collider_(std::move(collider)),
        st_(model_) {
    const uint32_t n = model_.num_vertices();
    clock_.settings = in.step();
    make_integrator(integrator_, scene_.time, n, clock_.settings.iterations);
    obstacles_.pose_at(0.0, obstacle_x_, obstacle_v_);
    collider_->set_obstacles(obstacle_x_.data(), obstacle_x_.size(), obstacles_.collision_indices.data(),
                             obstacles_.num_collision_triangles(), obstacles_.any_moving);
    collider_->set_cloth(n, model_.collision_triangles.data(), model_.tri_alias.data(), model_.num_collision_triangles(),
                         scene_.collision.cloth_cloth);
    build_bvh(obstacle_bvh_, obstacle_x_.data(), obstacles_.collision_indices.data(),
              uint32_t(obstacles_.num_collision_triangles()));
    build_bvh(cloth_bvh_, x().data(), model_.collision_triangles.data(), model_.num_triangles());
    // Built mid-run (after a weld): the trees as at t = 0 (their topology as a resumed run rebuilds
    // it), the obstacles where they are now, so that the next step sees the body's move over that
    // step and not its way from its t = 0 pose.
    if (in.time != 0.0) obstacles_.pose_at(in.time, obstacle_x_, obstacle_v_);
    obstacle_prev_ = obstacle_x_;
  }

  std::string name() const override { return "cpu"; }

  StepResult step(int n, uint64_t first_step, StageTimes& times) override {
    times_ = &times;
    return std::visit(
        [&](auto& integrator) {
          integrator.set_iterations(uint32_t(clock_.settings.iterations));
          return run_steps(*this, integrator, n, first_step);
        },
        integrator_);
  }

  void download(std::vector<Vec3>& x, std::vector<Vec3>& v) override {
    x = st_.x[st_.cur];
    v = st_.v[st_.cur];
  }

  bool download_balls(std::vector<Vec3>& centre, std::vector<float>& radius,
                      std::vector<std::vector<Vec3>>* planes) override {
    centre = st_.x_ref;
    radius.resize(st_.x_ref.size());
    StepView s;
    s.bound = st_.bound.data();
    s.bound_radius = st_.bound_radius.data();
    s.plane_count = st_.plane_count.data();
    s.plane_near = st_.plane_near.data();
    s.planes = st_.planes.data();
    for (uint32_t i = 0; i < radius.size(); ++i) radius[i] = allowance_of(s, i);
    if (planes) planes_by_vertex(s, uint32_t(radius.size()), *planes);
    return true;
  }

  bool can_checkpoint() const override { return true; }

  bool can_edit() const override { return true; }

  // The state and the obstacles' pose; the trees and Embree's scene are updated from them in the
  // next begin() (where a body moves, the cloth's tree every step), and the integrator's scratch is
  // rewritten by a run of substeps from its first.
  bool can_go_back() const override { return true; }
  void keep() override {
    if (!kept_) kept_ = std::make_unique<SimState<HostArray>>(model_);
    st_.for_each_array(*kept_, [](const auto& from, auto& to) { to = from; });
    kept_->cur = st_.cur;
    kept_obstacle_x_ = obstacle_x_;
    kept_obstacle_v_ = obstacle_v_;
  }
  void back() override {
    kept_->for_each_array(st_, [](const auto& from, auto& to) { to = from; });
    st_.cur = kept_->cur;
    obstacle_x_ = kept_obstacle_x_;
    obstacle_v_ = kept_obstacle_v_;
  }

  // As the constructor starts: the bound's balls at x with no room, so the first step refreshes it.
  void replace_state(const std::vector<Vec3>& x, const std::vector<Vec3>& v) override {
    st_.x[st_.cur] = x;
    st_.v[st_.cur] = v;
    st_.x_ref = x;
    std::fill(st_.bound.begin(), st_.bound.end(), 0u);
    std::fill(st_.bound_radius.begin(), st_.bound_radius.end(), 0.0f);
    std::fill(st_.plane_count.begin(), st_.plane_count.end(), 0u);
    st_.bound_age[0] = 0;
  }

  // x and v, the state arrays the next step reads (SimState::for_each_kept), the obstacles and the
  // trees.
  void save(ByteWriter& out) override {
    out.u64(model_.num_vertices());
    st_.for_each_kept([&](const auto& array, const char*) { out.vec(array); });
    for (const auto* v : {&obstacle_x_, &obstacle_v_, &obstacle_prev_}) out.vec(*v);
    for (const HostBvh* b : {&obstacle_bvh_, &cloth_bvh_}) {
      out.u32(b->num_prims);
      for (const auto* v : {&b->child, &b->parent, &b->prim, &b->counter}) out.vec(*v);
      out.vec(b->bounds);
      out.pod(b->built_area);
      out.u32(b->builds);
    }
  }

  // The Embree trees are refit every step over the topology of their first build, so that build is
  // repeated as it happened (cloth at its initial positions; the obstacles were built at t = 0 by the
  // constructor) before the restored positions come in with the next step's refit.
  void restore(ByteReader& in, uint64_t steps) override {
    const size_t n = model_.num_vertices();
    if (in.u64() != n) in.fail("was written for a cloth of another size");
    st_.for_each_kept([&](auto& array, const char* what) {
      const size_t size = array.size();
      in.vec(array, size, what);
    });
    const size_t no = obstacles_.world.vertices.size();
    in.vec(obstacle_x_, no, "obstacle vertices");
    in.vec(obstacle_v_, no, "obstacle vertices");
    in.vec(obstacle_prev_);
    for (HostBvh* b : {&obstacle_bvh_, &cloth_bvh_}) {
      b->num_prims = in.u32();
      for (auto* v : {&b->child, &b->parent, &b->prim, &b->counter}) in.vec(*v);
      in.vec(b->bounds);
      in.pod(b->built_area);
      b->builds = in.u32();
    }
    if (obstacle_bvh_.num_prims != obstacles_.num_collision_triangles() || cloth_bvh_.num_prims != model_.num_triangles())
      in.fail("was written for other meshes");
    if (steps > 0) collider_->update_cloth(model_.initial_positions.data());
    if (obstacles_.any_moving) collider_->update_obstacles(obstacle_x_.data());
  }

  // ---- The executor of sim/step.h ----

  StepView begin(uint64_t step) {
    const auto t = Clock::now();
    if (obstacles_.any_moving) {
      obstacle_prev_ = obstacle_x_;
      obstacles_.pose_at(clock_.time_at(step + 1), obstacle_x_, obstacle_v_);
      collider_->update_obstacles(obstacle_x_.data());
      refit_bvh(obstacle_bvh_, obstacle_x_.data(), obstacles_.collision_indices.data());
      // A deforming (skinned) body can degrade the refit tree as the cloth's does.
      if (bvh_needs_rebuild(bvh_area(obstacle_bvh_.view()), obstacle_bvh_.built_area))
        build_bvh(obstacle_bvh_, obstacle_x_.data(), obstacles_.collision_indices.data(),
                  uint32_t(obstacles_.num_collision_triangles()));
    }
    collider_->update_cloth(x().data());
    // The cloth's proximity tree at x: where a body moves, the contact solve looks for pairs in it
    // every step, and so does the implicit integrator's solve (stage_implicit_cloth); otherwise only
    // the bound's refreshes need it (refit_cloth).
    if (tree_every_step()) refit_cloth_tree();
    st_.counters[0] = StepCounters();
    StepView s = view(step);
    add_time(Stage::Update, t);
    return s;
  }

  // f(i) for i in [0, n), in ranges of at least `grain`.
  template <class F>
  static void parallel(uint32_t n, uint32_t grain, F&& f) {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, grain), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t i = r.begin(); i != r.end(); ++i) f(i);
    });
  }

  template <class F>
  void for_each(Stage stage, uint32_t n, F&& f) {
    const auto t = Clock::now();
    parallel(n, kGrain, f);
    add_time(stage, t);
  }

  // One parallel loop after another. A phase is small (a colour of the implicit sweeps: 60-odd
  // vertices on the walking skirt), so it is cut finer than kGrain, or it would run in one thread.
  template <class F>
  void phases(Stage stage, const PhaseSizes& p, F&& f) {
    const auto t = Clock::now();
    for (uint32_t q = 0; q < p.count; ++q) parallel(p.size[q], kPhaseGrain, [&](uint32_t k) { f(q, k); });
    add_time(stage, t);
  }

  template <class F>
  void sum(Stage stage, uint32_t n, F&& f, uint32_t* slot) {
    const auto t = Clock::now();
    *slot += tbb::parallel_reduce(
        tbb::blocked_range<uint32_t>(0, n, kGrain), uint32_t(0),
        [&](const tbb::blocked_range<uint32_t>& r, uint32_t acc) {
          for (uint32_t i = r.begin(); i != r.end(); ++i) acc += f(i);
          return acc;
        },
        [](uint32_t a, uint32_t b) { return a + b; });
    add_time(stage, t);
  }

  template <class F>
  void first(Stage stage, uint32_t n, F&& f, uint32_t* slot) {
    const auto t = Clock::now();
    *slot = std::min(*slot, tbb::parallel_reduce(
                                tbb::blocked_range<uint32_t>(0, n, kGrain), 0xFFFFFFFFu,
                                [&](const tbb::blocked_range<uint32_t>& r, uint32_t acc) {
                                  for (uint32_t i = r.begin(); i != r.end(); ++i)
                                    if (!f(i)) acc = std::min(acc, i);
                                  return acc;
                                },
                                [](uint32_t a, uint32_t b) { return std::min(a, b); }));
    add_time(stage, t);
  }

  void cast(const Ray* rays, uint32_t n, RawHit* hits) {
    const auto t = Clock::now();
    collider_->cast(rays, n, hits);
    add_time(Stage::Cast, t);
  }

  // The step's view of cloth_bvh_ was taken in begin(); a rebuild keeps the same array sizes (the
  // triangle count never changes), so its pointers stay valid. Where a body moves the tree was
  // refit at x in begin(), for the contact solve (and with the implicit integrator, for its solve).
  void refit_cloth(const StepCounters* c) {
    if (c->refresh == 0u || tree_every_step()) return;
    const auto t = Clock::now();
    refit_cloth_tree();
    add_time(Stage::Update, t);
  }

  // A further pass of the bound: the tree at the pass's start (and back at x for the next step).
  void refit_cloth_at(const Vec3* x, const StepCounters* c) {
    if (!c->pass_active) return;
    const auto t = Clock::now();
    refit_bvh(cloth_bvh_, x, model_.collision_triangles.data());
    add_time(Stage::Update, t);
  }

  bool tree_every_step() const {
    return obstacles_.any_moving || (scene_.time.integrator == Integrator::Implicit && scene_.collision.cloth_cloth);
  }

  void refit_cloth_tree() {
    refit_bvh(cloth_bvh_, x().data(), model_.collision_triangles.data());
    if (bvh_needs_rebuild(bvh_area(cloth_bvh_.view()), cloth_bvh_.built_area))
      build_bvh(cloth_bvh_, x().data(), model_.collision_triangles.data(), model_.num_triangles());
  }

  uint32_t peek(const uint32_t* slot, uint32_t) const { return *slot; }

  const StepCounters& counters() const { return st_.counters[0]; }

  void end() { st_.flip(); }

 private:
  void add_time(Stage stage, Clock::time_point since) {
    add_stage_time(*times_, stage, std::chrono::duration<double>(Clock::now() - since).count());
  }

  StepView view(uint64_t step) {
    StepBuffers b;
    b.model = model_.view();
    b.obstacle_x = obstacle_x_.data();
    b.obstacle_v = obstacle_v_.data();
    b.obstacle_prev = obstacle_prev_.data();
    b.obstacle_indices = obstacles_.collision_indices.data();
    b.num_obstacle_vertices = uint32_t(obstacle_x_.size());
    b.bodies_move = obstacles_.any_moving;
    b.obstacle_bvh = obstacle_bvh_.view();
    b.cloth_bvh = cloth_bvh_.view();
    return make_step_view(in_, clock_, step, b, st_);
  }

  const BackendInput in_;
  const SceneDef& scene_;
  const ClothModel& model_;
  const ObstacleSet& obstacles_;
  std::unique_ptr<Collider> collider_;
  SimState<HostArray> st_;
  AnyIntegrator<HostArray> integrator_;
  std::vector<Vec3> obstacle_x_, obstacle_v_, obstacle_prev_;
  HostBvh obstacle_bvh_, cloth_bvh_;
  std::unique_ptr<SimState<HostArray>> kept_;  // keep()
  std::vector<Vec3> kept_obstacle_x_, kept_obstacle_v_;
  StageTimes* times_ = nullptr;

  const std::vector<Vec3>& x() const { return st_.x[st_.cur]; }
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in, std::unique_ptr<Collider> collider) {
  return std::make_unique<CpuBackend>(in, std::move(collider));
}

std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in) {
  return make_cpu_backend(in, make_embree_collider());
}

}  // namespace raycloth
