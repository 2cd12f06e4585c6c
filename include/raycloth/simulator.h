// Steps a scene: the cloth model, its state, and the collision backend (CPU or CUDA).
#pragma once
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/totals.h"
#include "raycloth/vec3.h"

namespace raycloth {

struct ClothModel;
struct ObstacleSet;
class BodyReach;
struct StepResult;

struct SimOptions {
  std::string device = "cpu";      // cpu, cuda or auto
  bool allow_unstable_dt = false;  // run even when dt >= T0
  // The implicit integrator where a body moves: take a step again in more substeps where its
  // substeps let cloth into a body (Simulator::advance). Off, every step is taken once, at
  // kImplicitMaxBodyMove a substep (the tests compare the two).
  bool take_steps_again = true;
};

// Seconds spent in each stage, summed over all steps so far.
struct StageTimes {
  double integrate = 0;  // the integrator (sim/integrate/): spring forces, gravity, damping, the step
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
  // (tests of the bound's invariant), and (planes, optional) the directions it may not move against
  // from the centre, where a pair too near for a ball gave it planes (sim/bound.h). False on a
  // backend that does not give them.
  bool bound_balls(std::vector<Vec3>& centre, std::vector<float>& radius,
                   std::vector<std::vector<Vec3>>* planes = nullptr);
  std::vector<Vec3> obstacle_vertices() const;  // world space at time()
  uint64_t steps() const { return steps_; }
  double time() const { return double(steps_) * scene_.time.dt; }
  // Vertices with an entry in the collision buffer (W >= 0) in the last step.
  uint64_t last_hits() const { return last_hits_; }
  // What the steps did, summed over all of them (raycloth/totals.h): vertices an obstacle pushed out
  // at t + dt, vertices whose move the displacement bound shortened (each a place where the response
  // alone would have let cloth meet cloth), the bound's refreshes and further passes, the two-sided
  // contact solve's pairs, moves and rounds, and the implicit integrator's convergence.
  const RunTotals& totals() const { return totals_; }
  const StageTimes& stage_times() const { return times_; }

  // Checkpoints (io/checkpoint.h): the whole state after steps(), so that a Simulator built from the
  // same scene and restored steps on bit for bit as this one would. The CPU backend has them.
  bool can_checkpoint() const;
  void save_state(ByteWriter& out);
  void restore_state(ByteReader& in);

  // The most substeps a step was cut into so far: 1, or for the implicit integrator where a body
  // moves, as many as keep every body point within reach of the cloth in that step within
  // kImplicitMaxBodyMove per substep (sim/body_reach.h); chosen step by step.
  int substeps() const { return int(std::max<uint64_t>(1, totals_.max_substeps)); }
  // The steps the backend took: steps(), or the substeps of every step where they are cut.
  uint64_t solves() const { return totals_.solves; }
  // Whether the scene left the step to the mesh (TimeDef::dt_given false) and the mesh could not take
  // the scene's (or the default) dt, so that scene().time.dt was chosen below its explicit limit.
  bool dt_from_mesh() const { return dt_from_mesh_; }
  // Garments placed on a body (SceneDef::garment_fits): how far each of their panels was moved along
  // its normal to clear the body at the start (sim/garment_fit.h), in the scene's panel order.
  // How the fit placed each panel of a garment on a body (sim/garment_fit.h): metres along its
  // normal, whether it was wrapped around the legs, and the largest factor it was stretched by.
  struct PanelMove {
    std::string panel;
    float moved = 0;
    bool wrapped = false;
    float stretched = 1;
  };
  const std::vector<PanelMove>& panel_moves() const { return panel_moves_; }
  // Stitches (seams sewn from apart) welded into one vertex so far: every kWeldCheckTime, each
  // stitch within the close tolerance is welded.
  uint64_t stitches_welded() const { return stitches_welded_; }
  // Welds of closed stitches put off (tried again later): they would have put a cloth edge through a
  // cloth triangle or a welded vertex inside a body.
  uint64_t welds_put_off() const { return welds_put_off_; }

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
  bool dt_from_mesh_ = false;
  void choose_dt(double t0);
  // Where a body moves and the integrator is implicit: what chooses each step's substeps.
  std::unique_ptr<BodyReach> reach_;
  int substeps_now(double most);
  // Where steps are taken again (advance): how many halvings of kImplicitMaxBodyMove the next step
  // starts at, and the clean steps taken at it so far.
  int retry_level_ = 0, retry_clean_ = 0;
  bool take_steps_again_ = true;  // SimOptions::take_steps_again
  std::vector<PanelMove> panel_moves_;
  uint64_t stitches_welded_ = 0, weld_from_ = 0, weld_every_ = 1;
  uint64_t welds_put_off_ = 0;  // stitch welds skipped: they would have crossed the cloth or entered a body
  void advance(int n);
  void take(const StepResult& r, int n);
  size_t weld_closed_stitches();
  void rebuild_backend();
  std::unique_ptr<ClothModel> model_;
  std::unique_ptr<ObstacleSet> obstacles_;
  std::unique_ptr<Backend> backend_;
  std::vector<Vec3> x_, v_;
  bool synced_ = true;
  uint64_t steps_ = 0, last_hits_ = 0;
  RunTotals totals_;
  StageTimes times_;
};

// How often (simulated seconds) stitches within the close tolerance are welded.
inline constexpr double kWeldCheckTime = 0.002;

// The most a body point may move in one (sub)step of the implicit integrator, metres, at first. A
// step that leaves a vertex inside a body it was outside of (entered_obstacles) or blows up is taken
// again with half as much, up to kImplicitRetries times (to 0.125 mm); the steps that follow start
// where it ended, and go back up a level after kImplicitRetryHold clean steps (Simulator::advance).
// Up to 0.5.9 every step took 0.5 mm: clean on every scene measured, but twice the substeps where
// 1 mm is clean.
inline constexpr double kImplicitMaxBodyMove = 0.001;
inline constexpr int kImplicitRetries = 3;
// A step at the first try's length whose bound shortened a body's push out of it (push_clamped:
// cloth caught between the body and other cloth, which the bound keeps from crossing) is taken again
// at this level (0.5 mm): at 1 mm such pushes, though clean in the step, left the layers where a few
// steps later no substeps could keep the box under two sheets out of them.
inline constexpr int kImplicitPushLevel = 1;
inline constexpr int kImplicitRetryHold = 8;
// The fewest sweeps of a substep: 2, so that the last sweep's change still says how far the solve is
// from converged. A substep is near the explicit step's length (0.27 ms on the walking skirt against
// its explicit limit of 0.85 ms), so its solve starts near its answer; 4 were taken up to 0.5.0; 2 give
// the same contact tests passing and 1.2 times the steps per second (docs/performance.md).
inline constexpr int kMinSubstepSweeps = 2;

// T0 = pi sqrt(m/K) for the lightest free vertex and the stiffest spring (the paper's limit).
double natural_period(const SceneDef& scene);

}  // namespace raycloth
