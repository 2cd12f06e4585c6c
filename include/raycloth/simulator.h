// Steps a scene: the cloth model, its state, and the collision backend (CPU or CUDA).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/vec3.h"

namespace raycloth {

struct ClothModel;
struct ObstacleSet;

struct SimOptions {
  std::string device = "cpu";      // cpu, cuda or auto
  bool allow_unstable_dt = false;  // run even when dt >= T0
};

// Seconds spent in each stage, summed over all steps so far.
struct StageTimes {
  double integrate = 0;  // spring forces, gravity, damping, Euler step
  double update = 0;     // acceleration-structure refit
  double cast = 0;       // collision rays
  double respond = 0;    // collision response
  double total() const { return integrate + update + cast + respond; }
};

class Backend;

class Simulator {
 public:
  // Builds the model and the backend; throws InputError for a scene that does not fit together and
  // SimulationError for dt >= T0 (unless allowed) or a device that cannot run.
  explicit Simulator(const SceneDef& scene, const SimOptions& options = {});
  ~Simulator();
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  // Advances n steps of dt; throws SimulationError naming the step and the vertex on a blow-up.
  void step(int n = 1);

  const SceneDef& scene() const { return scene_; }
  const ClothModel& model() const { return *model_; }
  const ObstacleSet& obstacles() const { return *obstacles_; }
  std::string device() const;

  const std::vector<Vec3>& positions();   // state at time(), copied from the device if needed
  const std::vector<Vec3>& velocities();
  std::vector<Vec3> obstacle_vertices() const;  // world space at time()
  uint64_t steps() const { return steps_; }
  double time() const { return double(steps_) * scene_.time.dt; }
  // Vertices with an entry in the collision buffer (W >= 0) in the last step.
  uint64_t last_hits() const { return last_hits_; }
  // Vertices the crossing guard put back to their start-of-step position, summed over all steps:
  // each is a place where the response alone would have let cloth pass through cloth.
  uint64_t frozen_total() const { return frozen_total_; }
  // Crossing-guard rounds (one ray per cloth edge each) summed over all steps, and the most one step
  // needed; both 0 where the backend does not count them (CUDA runs a fixed number).
  uint64_t guard_rounds_total() const { return guard_rounds_total_; }
  uint32_t guard_rounds_max() const { return guard_rounds_max_; }
  const StageTimes& stage_times() const { return times_; }

 private:
  SceneDef scene_;
  std::unique_ptr<ClothModel> model_;
  std::unique_ptr<ObstacleSet> obstacles_;
  std::unique_ptr<Backend> backend_;
  std::vector<Vec3> x_, v_;
  bool synced_ = true;
  uint64_t steps_ = 0, last_hits_ = 0, frozen_total_ = 0, guard_rounds_total_ = 0;
  uint32_t guard_rounds_max_ = 0;
  StageTimes times_;
};

// T0 = pi sqrt(m/K) for the lightest free vertex and the stiffest spring (the paper's limit).
double natural_period(const SceneDef& scene);

}  // namespace raycloth
