// A backend runs whole steps over device-resident (CUDA) or host (CPU) state. Both run the same step
// (sim/step.h) with the scene's integrator (sim/integrate/); they differ in the loop driver and the
// ray tracer.
#pragma once
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "raycloth/simulator.h"
#include "sim/model.h"
#include "collide/collider.h"
#include "sim/step_view.h"

namespace raycloth {

class ByteWriter;
class ByteReader;

// The step the backend takes: a substep's dt and sweeps (Simulator: where a body moves, the
// implicit integrator's steps are cut into substeps); dt 0 for the scene's own.
struct StepSettings {
  double dt = 0;
  int iterations = 0;
  // The steps come in runs of this many, each run one step of the scene (its substeps): the
  // implicit integrator takes the bodies' planes at the first of a run and moves them on with the
  // bodies in the others.
  int substeps = 1;
};

// When a backend's steps happen: step `first` starts at simulated time `start`, and each lasts
// settings.dt with settings.iterations sweeps. A backend starts with first 0, start 0 and its
// BackendInput's step, so that step k starts at k dt; Simulator sets another before the steps of
// one scene step where the implicit integrator chooses that step's substeps (sim/body_reach.h).
struct StepClock {
  uint64_t first = 0;
  double start = 0;
  StepSettings settings;
  double time_at(uint64_t step) const { return start + double(step - first) * settings.dt; }
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;
  // Runs n steps starting at step `first_step` (timed by the clock: StepClock); stops early on a
  // blow-up (reported in the result).
  virtual StepResult step(int n, uint64_t first_step, StageTimes& times) = 0;
  virtual void download(std::vector<Vec3>& x, std::vector<Vec3>& v) = 0;
  // The displacement bound's balls (centre and radius per vertex), for tests of its invariant;
  // false where the backend does not give them.
  // planes (optional): per vertex, the planes it keeps (planes_of in sim/bound.h).
  virtual bool download_balls(std::vector<Vec3>& centre, std::vector<float>& radius,
                              std::vector<std::vector<Vec3>>* planes) {
    (void)centre, (void)radius, (void)planes;
    return false;
  }
  // Checkpoints: everything the next step reads that is not a function of the scene and the time.
  // restore() follows construction, with `steps` steps done. Backends without them say so.
  virtual bool can_checkpoint() const { return false; }
  virtual void save(ByteWriter& out) { (void)out; }
  virtual void restore(ByteReader& in, uint64_t steps) { (void)in, (void)steps; }
  // Steps taken again (Simulator: a step of the implicit integrator whose substeps left cloth inside
  // a moving body is taken again in more of them): keep() remembers the whole state at the current
  // step, back() returns to it, as often as asked, until the next keep(). The steps between are
  // forgotten (the clock is set again before the next). Backends without them say so.
  virtual bool can_go_back() const { return false; }
  virtual void keep() {}
  virtual void back() {}
  // Edits between steps (Simulator::set_state, pin, move_obstacle): whether the backend takes them,
  // and the state at the current step replaced (the displacement bound starting over from it). The
  // model's inv_mass and the obstacles' poses are read from the host every step by a backend that
  // takes edits.
  virtual bool can_edit() const { return false; }
  virtual void replace_state(const std::vector<Vec3>& x, const std::vector<Vec3>& v) { (void)x, (void)v; }
  // The clock of the steps that follow (StepClock).
  void set_clock(const StepClock& clock) { clock_ = clock; }
  const StepClock& clock() const { return clock_; }

 protected:
  StepClock clock_;
};

struct BackendInput {
  const SceneDef* scene;
  const ClothModel* model;
  const ObstacleSet* obstacles;
  StepSettings substep;
  // The simulated time of the state the backend starts from: the obstacles are posed there (a
  // backend rebuilt mid-run, as after a weld, must not see the body jump from its t = 0 pose).
  double time = 0;
  // The step taken: the substep where one is given, else the scene's time step and sweeps.
  StepSettings step() const {
    return substep.dt > 0 ? substep : StepSettings{scene->time.dt, scene->time.iterations};
  }
};

// What a backend keeps in its own memory beyond the state: the model's arrays (their view), the
// obstacles at t + dt (and at t, where they move) and the two trees.
struct StepBuffers {
  ModelView model;
  const Vec3* obstacle_x = nullptr;
  const Vec3* obstacle_v = nullptr;
  const Vec3* obstacle_prev = nullptr;
  const uint32_t* obstacle_indices = nullptr;  // the collision triangles (ObstacleSet::collision_indices)
  uint32_t num_obstacle_vertices = 0;
  bool bodies_move = false;
  BvhView obstacle_bvh, cloth_bvh;
};

// How much of gravity acts at time t where gravity eases in (ClothModel::ease_gravity): a smoothstep
// over the seams' close time (sew_time), or where gravity waits (sewing.gravity_waits) none while
// they close, then a smoothstep to all of it over kGravityEase of that time. Waiting, panels float
// while their stitches draw them together around the body: eased in over the close time, a garment
// hanging from its shoulders (a jumpsuit, a dress) slides down the body before its shoulder seams
// close, and they close under the arms (the stitches are springs, not threads: they pull straight
// through the body once the panels have slid past it).
inline constexpr double kGravityEase = 0.5;

// 0 to 1 as u goes from 0 to 1 (clamped), with no jolt at either end.
inline float smoothstep01(double u) {
  u = std::min(1.0, std::max(0.0, u));
  return float(u * u * (3 - 2 * u));
}

inline float gravity_ease(double t, double sew_time, bool waits) {
  if (!(sew_time > 0)) return 1.0f;
  return smoothstep01(waits ? (t - sew_time) / (kGravityEase * sew_time) : t / sew_time);
}

// The step's view, the same on both backends: the scene's collision settings, the step's context
// (dt, how far seams have closed at the start of `step` by the clock, gravity), the backend's buffers and the
// state's arrays (SimState::wire).
template <class State>
StepView make_step_view(const BackendInput& in, const StepClock& clock, uint64_t step, const StepBuffers& b, State& st) {
  const SceneDef& scene = *in.scene;
  const ClothModel& model = *in.model;
  StepView s;
  const double t = clock.time_at(step);
  if (model.sew_time > 0) {
    s.ctx.sew = smoothstep01(t / double(model.sew_time));
  }
  s.ctx.dt = float(clock.settings.dt);
  s.ctx.substeps = uint32_t(std::max(1, clock.settings.substeps));
  s.ctx.substep = uint32_t((step - clock.first) % s.ctx.substeps);
  s.ctx.gravity = make_vec3(scene.gravity[0], scene.gravity[1], scene.gravity[2]);
  if (model.ease_gravity) s.ctx.gravity = s.ctx.gravity * gravity_ease(t, model.sew_time, model.gravity_waits);
  s.coll.tolerance = scene.collision.tolerance;
  s.coll.thickness = scene.collision.thickness;
  s.coll.friction = scene.collision.friction;
  s.model = b.model;
  s.geom.obstacle_vertices = b.obstacle_x;
  s.geom.obstacle_velocities = b.bodies_move ? b.obstacle_v : nullptr;
  s.geom.obstacle_indices = b.obstacle_indices;
  s.geom.cloth_indices = b.model.triangles;
  st.wire(s);
  s.mean_edge = model.mean_edge;
  s.cloth_contact = scene.collision.cloth_cloth;
  s.obstacle_bvh = b.obstacle_bvh;
  s.cloth_bvh = b.cloth_bvh;
  s.bodies_move = b.bodies_move;
  s.bound_planes = b.bodies_move || !model.stitches.empty();
  s.obstacle_prev = b.obstacle_prev;
  s.num_obstacle_vertices = b.num_obstacle_vertices;
  return s;
}

std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in);
// The CPU backend casting with another acceleration structure (tests compare Embree and the BVH).
std::unique_ptr<Backend> make_cpu_backend(const BackendInput& in, std::unique_ptr<Collider> collider);
// Defined by the CUDA backend when it is built; otherwise throws SimulationError.
std::unique_ptr<Backend> make_cuda_backend(const BackendInput& in);
// True when the CUDA backend is built and a GPU is usable; otherwise `why` says what is missing.
bool cuda_usable(std::string* why);
// The obstacles at simulated time t with the skinned bodies posed on the device, by the CUDA
// backend's own skinning (the rest as pose_at has them), for tests against pose_at. Throws
// SimulationError where the backend cannot run.
void cuda_pose_obstacles(const ObstacleSet& obstacles, double t, std::vector<Vec3>& x, std::vector<Vec3>& v);

}  // namespace raycloth
