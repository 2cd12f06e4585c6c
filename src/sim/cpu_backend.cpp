// CPU backend: the shared stages in oneTBB loops, rays cast by Embree.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <utility>

#include "collide/cpu/embree_collider.h"
#include "sim/backend.h"
#include "sim/stages.h"

namespace raycloth {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point& t) {
  const auto now = Clock::now();
  const double s = std::chrono::duration<double>(now - t).count();
  t = now;
  return s;
}

template <class F>
void for_each_vertex(uint32_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 512), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

class CpuBackend final : public Backend {
 public:
  explicit CpuBackend(const BackendInput& in)
      : scene_(*in.scene), model_(*in.model), obstacles_(*in.obstacles), collider_(make_embree_collider()) {
    const uint32_t n = model_.num_vertices();
    x_ = model_.initial_positions;
    v_.assign(n, make_vec3(0, 0, 0));
    x_next_ = x_;
    v_next_ = v_;
    rays_.resize(n);
    hits_.resize(n);
    contacts_.resize(n);
    contact_normal_.assign(n, make_vec3(0, 0, 0));
    edge_rays_.resize(model_.num_edges());
    edge_hits_.resize(model_.num_edges());
    frozen_.assign(n, 0u);
    obstacles_.pose_at(0.0, obstacle_x_, obstacle_v_);
    collider_->set_obstacles(obstacle_x_.data(), obstacle_x_.size(), obstacles_.world.indices.data(),
                             obstacles_.world.num_triangles(), obstacles_.any_moving);
    collider_->set_cloth(n, model_.collision_triangles.data(), model_.tri_alias.data(), model_.num_collision_triangles(),
                         scene_.collision.cloth_cloth);
  }

  std::string name() const override { return "cpu"; }

  StepResult step(int n, uint64_t first_step, StageTimes& times) override {
    StepResult result;
    for (int k = 0; k < n; ++k) {
      const uint64_t step_index = first_step + uint64_t(k);
      StepView s = view();
      auto t = Clock::now();

      if (obstacles_.any_moving) {
        obstacles_.pose_at(double(step_index) * scene_.time.dt, obstacle_x_, obstacle_v_);
        collider_->update_obstacles(obstacle_x_.data());
      }
      // The crossing guard leaves the cloth's structure fitted to x_next, which is now x.
      if (!cloth_at_x_) collider_->update_cloth(x_.data());
      cloth_at_x_ = false;
      times.update += seconds_since(t);

      for_each_vertex(s.model.num_vertices, [&](uint32_t i) {
        stage_integrate(s, i);
        stage_velocity_ray(s, i);
      });
      times.integrate += seconds_since(t);

      collider_->cast(rays_.data(), rays_.size(), hits_.data());
      times.cast += seconds_since(t);
      for_each_vertex(s.model.num_vertices, [&](uint32_t i) { stage_respond_velocity(s, i); });
      times.respond += seconds_since(t);
      collider_->cast(rays_.data(), rays_.size(), hits_.data());
      times.cast += seconds_since(t);

      std::atomic<int64_t> bad{-1};
      result.hits = tbb::parallel_reduce(
          tbb::blocked_range<uint32_t>(0, s.model.num_vertices, 512), uint64_t(0),
          [&](const tbb::blocked_range<uint32_t>& r, uint64_t count) {
            for (uint32_t i = r.begin(); i != r.end(); ++i) {
              if (!stage_respond_contact(s, i)) {
                int64_t cur = bad.load(std::memory_order_relaxed);
                while ((cur < 0 || int64_t(i) < cur) && !bad.compare_exchange_weak(cur, int64_t(i))) {
                }
              }
              count += s.contacts[i].w >= 0.0f ? 1 : 0;
            }
            return count;
          },
          [](uint64_t a, uint64_t b) { return a + b; });
      times.respond += seconds_since(t);

      collider_->cast(rays_.data(), rays_.size(), hits_.data());
      times.cast += seconds_since(t);
      for_each_vertex(s.model.num_vertices, [&](uint32_t i) { stage_certify(s, i); });
      times.respond += seconds_since(t);

      if (scene_.collision.cloth_cloth) guard(s, times, t, result);

      std::swap(x_, x_next_);
      std::swap(v_, v_next_);
      if (bad.load() >= 0) {
        result.bad_vertex = bad.load();
        result.bad_step = step_index;
        return result;
      }
    }
    return result;
  }

  // The crossing guard (sim/stages.h): edge rays at x_next until no edge crosses the cloth. Each
  // round freezes more vertices at their crossing-free x, so it ends; past kMaxGuardRounds every
  // vertex is frozen. Adds the vertices frozen and the rounds run to `result`.
  void guard(const StepView& s, StageTimes& times, Clock::time_point& t, StepResult& result) {
    constexpr uint32_t kMaxGuardRounds = 32;
    const uint32_t ne = s.model.num_edges;
    for (uint32_t round = 0;; ++round) {
      collider_->update_cloth(x_next_.data());
      times.update += seconds_since(t);
      tbb::parallel_for(tbb::blocked_range<uint32_t>(0, ne, 1024), [&](const tbb::blocked_range<uint32_t>& r) {
        for (uint32_t e = r.begin(); e != r.end(); ++e) stage_edge_ray(s, e);
      });
      collider_->cast_cloth(edge_rays_.data(), ne, edge_hits_.data());
      times.cast += seconds_since(t);
      // Marks are written serially: several edges may mark one vertex.
      bool any = false;
      for (uint32_t e = 0; e < ne; ++e) any = stage_edge_mark(s, e) || any;
      if (!any) {
        times.respond += seconds_since(t);
        cloth_at_x_ = true;
        result.guard_rounds += round + 1;
        result.guard_rounds_max = std::max(result.guard_rounds_max, round + 1);
        return;
      }
      if (round + 1 == kMaxGuardRounds) std::fill(frozen_.begin(), frozen_.end(), 1u);
      result.frozen += tbb::parallel_reduce(
          tbb::blocked_range<uint32_t>(0, s.model.num_vertices, 512), uint64_t(0),
          [&](const tbb::blocked_range<uint32_t>& r, uint64_t count) {
            for (uint32_t i = r.begin(); i != r.end(); ++i) count += stage_freeze(s, i) ? 1 : 0;
            return count;
          },
          [](uint64_t a, uint64_t b) { return a + b; });
      times.respond += seconds_since(t);
    }
  }

  void download(std::vector<Vec3>& x, std::vector<Vec3>& v) override {
    x = x_;
    v = v_;
  }

 private:
  StepView view() {
    StepView s = step_view_for(scene_);
    s.model = model_.view();
    s.geom.obstacle_vertices = obstacle_x_.data();
    s.geom.obstacle_velocities = obstacles_.any_moving ? obstacle_v_.data() : nullptr;
    s.geom.obstacle_indices = obstacles_.world.indices.data();
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
    s.edge_rays = edge_rays_.data();
    s.edge_hits = edge_hits_.data();
    s.frozen = frozen_.data();
    return s;
  }

  const SceneDef& scene_;
  const ClothModel& model_;
  const ObstacleSet& obstacles_;
  std::unique_ptr<Collider> collider_;
  std::vector<Vec3> x_, v_, x_next_, v_next_, contact_normal_;
  std::vector<Vec3> obstacle_x_, obstacle_v_;
  std::vector<Ray> rays_;
  std::vector<RawHit> hits_;
  std::vector<Contact> contacts_;
  std::vector<Ray> edge_rays_;
  std::vector<RawHit> edge_hits_;
  std::vector<uint32_t> frozen_;
  bool cloth_at_x_ = false;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in) { return std::make_unique<CpuBackend>(in); }

}  // namespace raycloth
