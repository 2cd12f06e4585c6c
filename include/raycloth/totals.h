// What a run's steps did, summed over its steps: the step counters a run reports, declared once.
// Each line of RAYCLOTH_SUMMED_COUNTERS makes a counter of the step (StepCounters, sim/step_view.h),
// its sum over a batch and over the run (RunTotals), its place in checkpoints and its name in
// run.json and in the Python module's stats. A new one is a line here plus the stage that counts it.
#pragma once
#include <cstdint>

namespace raycloth {

// X(name, name in run.json and stats, run.json section): summed over the steps.
#define RAYCLOTH_SUMMED_COUNTERS(X)                                                                          \
  X(pushed, "pushed_by_obstacles", "contact")     /* vertices pushed out of (or off) an obstacle at t + dt */ \
  X(clamped, "clamped_by_bound", "contact")       /* vertices whose move the bound shortened */              \
  X(conflicts, "obstacle_conflicts", "contact")   /* vertices the bound left inside an obstacle it had been pushed out of */ \
  X(push_clamped, "push_shortened_by_bound", "contact") /* vertices whose push out of an obstacle the bound shortened */ \
  X(contact_pairs, "cloth_contact_pairs", "contact")    /* cloth pairs within the thickness (sim/contact.h) */ \
  X(contact_moved, "moved_by_contact_solve", "contact") /* vertices the contact solve moved */               \
  X(contact_rounds, "contact_solve_rounds", "contact")  /* rounds of the position solve that found a pair to act on */ \
  X(bound_passes, "bound_passes", "contact")      /* further passes of the bound (run_bound_passes) */       \
  X(overlap_exits, "pushed_out_of_overlaps", "contact") /* pushes that landed inside another part of a body and went out of every part instead */ \
  X(swept_rounds, "swept_bound_rounds", "contact") /* rounds of the swept bound after one that found a failing pair */ \
  X(swept_stops, "swept_bound_stops", "contact") /* steps whose swept bound did not settle: every vertex stayed where it was */ \
  X(entered, "entered_obstacles", "contact") /* vertices that ended a step inside an obstacle they had not been inside of (implicit steps where a body moves) */ \
  X(unconverged, "unconverged_steps", "integrator") /* 1 when the implicit solve's last sweep exceeded the tolerance */

// The sums over a batch of steps, or over a run (Simulator::totals).
struct RunTotals {
#define RAYCLOTH_TOTAL_FIELD(name, json, section) uint64_t name = 0;
  RAYCLOTH_SUMMED_COUNTERS(RAYCLOTH_TOTAL_FIELD)
#undef RAYCLOTH_TOTAL_FIELD
  // Derived from the step's counters (add_step, sim/step_view.h):
  uint64_t refreshes = 0;          // steps that recomputed the displacement bound of every vertex
  uint64_t partial_refreshes = 0;  // steps that recomputed it for the vertices that needed room
  double max_residual = 0;         // implicit integrator: the largest last-sweep step of any step (metres)
  double max_obstacle_move = 0;    // the largest move of an obstacle vertex in one step (metres)
  uint64_t solves = 0;             // steps the backend took: one a scene step, or one a substep
  uint64_t max_substeps = 0;       // the most substeps one scene step was cut into (Simulator)
  uint64_t retried = 0;            // tries of a scene step that were undone and taken again in more substeps (Simulator)

  void add(const RunTotals& o) {
#define RAYCLOTH_TOTAL_ADD(name, json, section) name += o.name;
    RAYCLOTH_SUMMED_COUNTERS(RAYCLOTH_TOTAL_ADD)
#undef RAYCLOTH_TOTAL_ADD
    refreshes += o.refreshes;
    partial_refreshes += o.partial_refreshes;
    max_residual = max_residual > o.max_residual ? max_residual : o.max_residual;
    max_obstacle_move = max_obstacle_move > o.max_obstacle_move ? max_obstacle_move : o.max_obstacle_move;
    solves += o.solves;
    max_substeps = max_substeps > o.max_substeps ? max_substeps : o.max_substeps;
    retried += o.retried;
  }
};

// f(name in run.json, section, value) for every total, as run.json and the stats report them.
template <class F>
void for_each_total(const RunTotals& t, F&& f) {
#define RAYCLOTH_TOTAL_VISIT(name, json, section) f(json, section, t.name);
  RAYCLOTH_SUMMED_COUNTERS(RAYCLOTH_TOTAL_VISIT)
#undef RAYCLOTH_TOTAL_VISIT
  f("bound_refreshes", "contact", t.refreshes);
  f("bound_partial_refreshes", "contact", t.partial_refreshes);
  f("steps_taken_again", "integrator", t.retried);
}

}  // namespace raycloth
