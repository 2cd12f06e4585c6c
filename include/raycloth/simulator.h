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
  double contact = 0;    // the two-sided contact solve (cloth pairs, rounds, obstacles again)
  double bound = 0;      // displacement bound: proximity queries and the clamp
  double total() const { return integrate + update + cast + respond + contact + bound; }
};

class Backend;
class ByteWriter;
class ByteReader;

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
  // The displacement bound's balls: per vertex the centre and the radius it must stay within
  // (tests of the bound's invariant). False on a backend that does not give them.
  bool bound_balls(std::vector<Vec3>& centre, std::vector<float>& radius);
  std::vector<Vec3> obstacle_vertices() const;  // world space at time()
  uint64_t steps() const { return steps_; }
  double time() const { return double(steps_) * scene_.time.dt; }
  // Vertices with an entry in the collision buffer (W >= 0) in the last step.
  uint64_t last_hits() const { return last_hits_; }
  // Summed over all steps: vertices an obstacle pushed out at t + dt; vertices whose move the
  // displacement bound shortened (each a place where the response alone would have let cloth meet
  // cloth); vertices the bound kept from leaving an obstacle completely (cloth on both sides).
  uint64_t pushed_total() const { return pushed_total_; }
  uint64_t clamped_total() const { return clamped_total_; }
  uint64_t conflicts_total() const { return conflicts_total_; }
  // Summed over all steps: vertices whose push out of an obstacle the bound shortened (most stay
  // outside: the push goes to the thickness beyond the surface).
  uint64_t push_clamped_total() const { return push_clamped_total_; }
  // Steps that recomputed the displacement bound of every vertex (the others reuse it, or refresh
  // only the vertices that need more room).
  uint64_t bound_refreshes() const { return refreshes_total_; }
  // Steps that recomputed the bound only for the vertices that needed more room.
  uint64_t bound_partial_refreshes() const { return partial_refreshes_total_; }
  // The two-sided contact solve, summed over all steps: cloth vertex-triangle pairs found within the
  // thickness, vertices it moved, and its position rounds that acted.
  uint64_t contact_pairs() const { return contact_pairs_total_; }
  uint64_t contact_moved() const { return contact_moved_total_; }
  uint64_t contact_rounds() const { return contact_rounds_total_; }
  // Further passes of the displacement bound, summed over all steps.
  uint64_t bound_passes() const { return bound_passes_total_; }
  // The implicit integrator (time.integrator "implicit"): steps whose last sweep still moved a
  // vertex more than time.tolerance, and the largest such last-sweep step (metres).
  uint64_t unconverged_steps() const { return unconverged_total_; }
  double max_residual() const { return max_residual_; }
  const StageTimes& stage_times() const { return times_; }

  // Checkpoints (io/checkpoint.h): the whole state after steps(), so that a Simulator built from the
  // same scene and restored steps on bit for bit as this one would. The CPU backend has them.
  bool can_checkpoint() const;
  void save_state(ByteWriter& out);
  void restore_state(ByteReader& in);

  // Substeps per step: 1, or for the implicit integrator where a body moves, as many as keep its
  // fastest point within kImplicitMaxBodyMove per substep.
  int substeps() const { return substeps_; }
  // Garments placed on a body (SceneDef::garment_fits): how far each of their panels was moved along
  // its normal to clear the body at the start (sim/garment_fit.h), in the scene's panel order.
  struct PanelMove {
    std::string panel;
    float moved = 0;
  };
  const std::vector<PanelMove>& panel_moves() const { return panel_moves_; }
  // Stitches (seams sewn from apart) welded into one vertex so far: every kWeldCheckTime, each
  // stitch within the close tolerance is welded.
  uint64_t stitches_welded() const { return stitches_welded_; }

  // Edits between steps (src/sim/simulator_edit.cpp), for callers that drive the simulation
  // themselves (the Python module). The CPU backend has them; elsewhere they throw SimulationError.
  // set_state: positions and velocities of every cloth vertex at time() (seam partners take their
  // representative's); the displacement bound starts over from them. Throws InputError for a wrong
  // size or a value that is not finite.
  void set_state(const std::vector<Vec3>& x, const std::vector<Vec3>& v);
  // Pins cloth vertices where they are (a seam partner pins its whole seam group): they stop, and
  // stay put until set_state moves them.
  void pin(const std::vector<uint32_t>& vertices);
  // Moves obstacle `obstacle` (in the order of the scene's obstacles) to these world-space vertices
  // over the next step, in a straight line (its velocity in that step is the move / dt); it stays
  // there, at rest, until moved again, its scene motion or animation replaced.
  void move_obstacle(size_t obstacle, const std::vector<Vec3>& vertices);

 private:
  SceneDef scene_;
  SceneDef step_scene_;  // what the backend steps: scene_ with dt / substeps_
  int substeps_ = 1;
  std::vector<PanelMove> panel_moves_;
  uint64_t stitches_welded_ = 0, weld_from_ = 0, weld_every_ = 1;
  void advance(int n);
  size_t weld_closed_stitches();
  void rebuild_backend();
  std::unique_ptr<ClothModel> model_;
  std::unique_ptr<ObstacleSet> obstacles_;
  std::unique_ptr<Backend> backend_;
  std::vector<Vec3> x_, v_;
  bool synced_ = true;
  uint64_t steps_ = 0, last_hits_ = 0, pushed_total_ = 0, clamped_total_ = 0, conflicts_total_ = 0, refreshes_total_ = 0;
  uint64_t partial_refreshes_total_ = 0, contact_pairs_total_ = 0, contact_moved_total_ = 0, contact_rounds_total_ = 0;
  uint64_t push_clamped_total_ = 0, bound_passes_total_ = 0, unconverged_total_ = 0;
  double max_residual_ = 0;
  StageTimes times_;
};

// How often (simulated seconds) stitches within the close tolerance are welded.
inline constexpr double kWeldCheckTime = 0.002;

// The most a body point may move in one (sub)step of the implicit integrator, metres.
inline constexpr double kImplicitMaxBodyMove = 0.0005;
inline constexpr int kMinSubstepSweeps = 4;

// T0 = pi sqrt(m/K) for the lightest free vertex and the stiffest spring (the paper's limit).
double natural_period(const SceneDef& scene);

}  // namespace raycloth
