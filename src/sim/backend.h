// A backend runs whole steps over device-resident (CUDA) or host (CPU) state. Both call the same
// per-vertex stages (sim/stages.h); they differ in the loop driver and the ray tracer.
#pragma once
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "raycloth/simulator.h"
#include "sim/model.h"
#include "collide/collider.h"
#include "sim/stages.h"

namespace raycloth {

class ByteWriter;
class ByteReader;

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;
  // Runs n steps starting at step `first_step`; stops early on a blow-up (reported in the result).
  virtual StepResult step(int n, uint64_t first_step, StageTimes& times) = 0;
  virtual void download(std::vector<Vec3>& x, std::vector<Vec3>& v) = 0;
  // The displacement bound's balls (centre and radius per vertex), for tests of its invariant;
  // false where the backend does not give them.
  virtual bool download_balls(std::vector<Vec3>& centre, std::vector<float>& radius) {
    (void)centre, (void)radius;
    return false;
  }
  // Checkpoints: everything the next step reads that is not a function of the scene and the time.
  // restore() follows construction, with `steps` steps done. Backends without them say so.
  virtual bool can_checkpoint() const { return false; }
  virtual void save(ByteWriter& out) { (void)out; }
  virtual void restore(ByteReader& in, uint64_t steps) { (void)in, (void)steps; }
  // Edits between steps (Simulator::set_state, pin, move_obstacle): whether the backend takes them,
  // and the state at the current step replaced (the displacement bound starting over from it). The
  // model's inv_mass and the obstacles' poses are read from the host every step by a backend that
  // takes edits.
  virtual bool can_edit() const { return false; }
  virtual void replace_state(const std::vector<Vec3>& x, const std::vector<Vec3>& v) { (void)x, (void)v; }
};

struct BackendInput {
  const SceneDef* scene;
  const ClothModel* model;
  const ObstacleSet* obstacles;
};

// A step view with the scene's scalar parameters (collision settings, dt, gravity, how far seams
// have closed at the start of `step`) filled in; the backend adds its own array pointers.
inline StepView step_view_for(const SceneDef& scene, const ClothModel& model, uint64_t step) {
  StepView s;
  if (model.sew_time > 0) {
    const double u = std::min(1.0, double(step) * scene.time.dt / double(model.sew_time));
    s.sew = float(u * u * (3 - 2 * u));  // smoothstep: no jolt at either end
  }
  s.coll.tolerance = scene.collision.tolerance;
  s.coll.thickness = scene.collision.thickness;
  s.coll.friction = scene.collision.friction;
  s.coll.dt = float(scene.time.dt);
  s.implicit = scene.time.integrator == Integrator::Implicit;
  s.iterations = uint32_t(scene.time.iterations);
  s.tolerance = float(scene.time.tolerance);
  s.gravity = make_vec3(scene.gravity[0], scene.gravity[1], scene.gravity[2]);
  if (model.ease_gravity) s.gravity = s.gravity * s.sew;
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
