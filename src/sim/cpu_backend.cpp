// CPU backend: the step of sim/step.h with oneTBB loops; rays cast by Embree (or any Collider),
// proximity queries on the host BVH.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <utility>

#include "collide/bvh.h"
#include "collide/cpu/embree_collider.h"
#include "io/checkpoint.h"
#include "sim/backend.h"
#include "sim/step.h"

namespace raycloth {

namespace {

using Clock = std::chrono::steady_clock;
constexpr uint32_t kGrain = 256;

class CpuBackend final : public Backend {
 public:
  CpuBackend(const BackendInput& in, std::unique_ptr<Collider> collider)
      : scene_(*in.scene), model_(*in.model), obstacles_(*in.obstacles), collider_(std::move(collider)) {
    const uint32_t n = model_.num_vertices();
    x_ = model_.initial_positions;
    v_.assign(n, make_vec3(0, 0, 0));
    x_next_ = x_;
    v_next_ = v_;
    rays_.resize(n);
    hits_.resize(n);
    contacts_.resize(n);
    contact_normal_.assign(n, make_vec3(0, 0, 0));
    bound_.assign(n, 0u);  // allowance 0: the first step that moves anything refreshes the bound
    bound_radius_.assign(n, 0.0f);
    x_ref_ = x_;
    flags_.assign(n, 0u);
    pairs_.resize(size_t(n) * kVertexPairs + size_t(model_.num_edges()) * kEdgePairs);
    pair_list_.resize(pairs_.size());
    push_.assign(n, FixedVec3());
    push_count_.assign(n, 0u);
    clearance_.assign(n, 0.0f);
    contact_shift_.assign(n, 0.0f);
    x_goal_.assign(n, make_vec3(0, 0, 0));
    v_goal_ = x_goal_;
    x_mid_ = x_goal_;
    obstacles_.pose_at(0.0, obstacle_x_, obstacle_v_);
    collider_->set_obstacles(obstacle_x_.data(), obstacle_x_.size(), obstacles_.collision_indices.data(),
                             obstacles_.num_collision_triangles(), obstacles_.any_moving);
    collider_->set_cloth(n, model_.collision_triangles.data(), model_.tri_alias.data(), model_.num_collision_triangles(),
                         scene_.collision.cloth_cloth);
    build_bvh(obstacle_bvh_, obstacle_x_.data(), obstacles_.collision_indices.data(),
              uint32_t(obstacles_.num_collision_triangles()));
    build_bvh(cloth_bvh_, x_.data(), model_.collision_triangles.data(), model_.num_triangles());
  }

  std::string name() const override { return "cpu"; }

  StepResult step(int n, uint64_t first_step, StageTimes& times) override {
    times_ = &times;
    return run_steps(*this, n, first_step);
  }

  void download(std::vector<Vec3>& x, std::vector<Vec3>& v) override {
    x = x_;
    v = v_;
  }

  bool download_balls(std::vector<Vec3>& centre, std::vector<float>& radius) override {
    centre = x_ref_;
    radius.resize(x_ref_.size());
    StepView s;
    s.bound = bound_.data();
    s.bound_radius = bound_radius_.data();
    for (uint32_t i = 0; i < radius.size(); ++i) radius[i] = allowance_of(s, i);
    return true;
  }

  bool can_checkpoint() const override { return true; }

  void save(ByteWriter& out) override {
    out.u64(model_.num_vertices());
    for (const auto* v : {&x_, &v_, &x_next_, &v_next_, &contact_normal_, &x_ref_, &obstacle_x_, &obstacle_v_, &obstacle_prev_})
      out.vec(*v);
    out.vec(rays_);
    out.vec(hits_);
    out.vec(contacts_);
    out.vec(bound_);
    out.vec(flags_);
    out.vec(bound_radius_);
    out.pod(counters_);
    out.u32(bound_age_);
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
    for (auto* v : {&x_, &v_, &x_next_, &v_next_, &contact_normal_, &x_ref_}) in.vec(*v, n, "cloth vertices");
    const size_t no = obstacles_.world.vertices.size();
    in.vec(obstacle_x_, no, "obstacle vertices");
    in.vec(obstacle_v_, no, "obstacle vertices");
    in.vec(obstacle_prev_);
    in.vec(rays_, n, "rays");
    in.vec(hits_, n, "hits");
    in.vec(contacts_, n, "contacts");
    in.vec(bound_, n, "bounds");
    in.vec(flags_, n, "flags");
    in.vec(bound_radius_, n, "bound radii");
    in.pod(counters_);
    bound_age_ = in.u32();
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
      obstacles_.pose_at(double(step + 1) * scene_.time.dt, obstacle_x_, obstacle_v_);
      collider_->update_obstacles(obstacle_x_.data());
      refit_bvh(obstacle_bvh_, obstacle_x_.data(), obstacles_.collision_indices.data());
      // A deforming (skinned) body can degrade the refit tree as the cloth's does.
      if (bvh_needs_rebuild(bvh_area(obstacle_bvh_.view()), obstacle_bvh_.built_area))
        build_bvh(obstacle_bvh_, obstacle_x_.data(), obstacles_.collision_indices.data(),
                  uint32_t(obstacles_.num_collision_triangles()));
    }
    collider_->update_cloth(x_.data());
    // The cloth's proximity tree at x: where a body moves, the contact solve looks for pairs in it
    // every step; otherwise only the bound's refreshes need it (refit_cloth).
    if (obstacles_.any_moving) refit_cloth_tree();
    counters_ = StepCounters();
    StepView s = view(step);
    add_time(Stage::Update, t);
    return s;
  }

  template <class F>
  void for_each(Stage stage, uint32_t n, F&& f) {
    const auto t = Clock::now();
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, kGrain), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t i = r.begin(); i != r.end(); ++i) f(i);
    });
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
  // refit at x in begin(), for the contact solve.
  void refit_cloth(const StepCounters* c) {
    if (c->refresh == 0u || obstacles_.any_moving) return;
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

  void refit_cloth_tree() {
    refit_bvh(cloth_bvh_, x_.data(), model_.collision_triangles.data());
    if (bvh_needs_rebuild(bvh_area(cloth_bvh_.view()), cloth_bvh_.built_area))
      build_bvh(cloth_bvh_, x_.data(), model_.collision_triangles.data(), model_.num_triangles());
  }

  uint32_t peek(const uint32_t* slot, uint32_t) const { return *slot; }

  const StepCounters& counters() const { return counters_; }

  void end() {
    std::swap(x_, x_next_);
    std::swap(v_, v_next_);
  }

 private:
  void add_time(Stage stage, Clock::time_point since) {
    const double s = std::chrono::duration<double>(Clock::now() - since).count();
    switch (stage) {
      case Stage::Integrate: times_->integrate += s; break;
      case Stage::Update: times_->update += s; break;
      case Stage::Cast: times_->cast += s; break;
      case Stage::Respond: times_->respond += s; break;
      case Stage::Contact: times_->contact += s; break;
      case Stage::Bound: times_->bound += s; break;
    }
  }

  StepView view(uint64_t step) {
    StepView s = step_view_for(scene_, model_, step);
    s.model = model_.view();
    s.geom.obstacle_vertices = obstacle_x_.data();
    s.geom.obstacle_velocities = obstacles_.any_moving ? obstacle_v_.data() : nullptr;
    s.geom.obstacle_indices = obstacles_.collision_indices.data();
    s.geom.cloth_positions = x_.data();
    s.geom.cloth_velocities = v_.data();
    s.geom.cloth_indices = model_.collision_triangles.data();
    s.x = x_.data();
    s.v = v_.data();
    s.x_next = x_next_.data();
    s.v_next = v_next_.data();
    s.rays = rays_.data();
    s.hits = hits_.data();
    s.contacts = contacts_.data();
    s.contact_normal = contact_normal_.data();
    s.bound = bound_.data();
    s.bound_radius = bound_radius_.data();
    s.x_ref = x_ref_.data();
    s.bound_age = &bound_age_;
    s.mean_edge = model_.mean_edge;
    s.flags = flags_.data();
    s.pairs = pairs_.data();
    s.pair_list = pair_list_.data();
    s.clearance = clearance_.data();
    s.contact_shift = contact_shift_.data();
    s.x_goal = x_goal_.data();
    s.v_goal = v_goal_.data();
    s.x_mid = x_mid_.data();
    s.push = push_.data();
    s.push_count = push_count_.data();
    s.cloth_contact = scene_.collision.cloth_cloth;
    s.obstacle_bvh = obstacle_bvh_.view();
    s.cloth_bvh = cloth_bvh_.view();
    s.obstacle_reach = obstacle_reach();
    s.counters = &counters_;
    return s;
  }

  // How far any obstacle surface point moves in this step, at most: every vertex moves along a
  // straight line within the step, so the largest vertex displacement bounds every surface point's.
  float obstacle_reach() const {
    if (!obstacles_.any_moving || obstacle_prev_.size() != obstacle_x_.size()) return 0.0f;
    float d = 0.0f;
    for (size_t i = 0; i < obstacle_x_.size(); ++i) d = std::max(d, length(obstacle_x_[i] - obstacle_prev_[i]));
    return d * 1.01f + 1e-7f;
  }

  const SceneDef& scene_;
  const ClothModel& model_;
  const ObstacleSet& obstacles_;
  std::unique_ptr<Collider> collider_;
  std::vector<Vec3> x_, v_, x_next_, v_next_, contact_normal_, x_ref_;
  std::vector<Vec3> obstacle_x_, obstacle_v_, obstacle_prev_;
  std::vector<Ray> rays_;
  std::vector<RawHit> hits_;
  std::vector<Contact> contacts_;
  std::vector<uint32_t> bound_, flags_;
  std::vector<float> bound_radius_;
  std::vector<ContactPair> pairs_;
  std::vector<uint32_t> pair_list_;
  std::vector<float> clearance_, contact_shift_;
  std::vector<Vec3> x_goal_, v_goal_, x_mid_;
  std::vector<FixedVec3> push_;
  std::vector<uint32_t> push_count_;
  HostBvh obstacle_bvh_, cloth_bvh_;
  StepCounters counters_;
  uint32_t bound_age_ = 0;
  StageTimes* times_ = nullptr;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in, std::unique_ptr<Collider> collider) {
  return std::make_unique<CpuBackend>(in, std::move(collider));
}

std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in) {
  return make_cpu_backend(in, make_embree_collider());
}

}  // namespace raycloth
