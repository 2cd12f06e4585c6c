// One step of the simulation, written once. Every backend runs this same sequence through an
// executor that supplies the loops, the reductions and the ray cast (the backend seam):
//
//   StepView begin(uint64_t step)  obstacles posed at t + dt, ray structures updated (obstacles at
//                                  t + dt, cloth at x), counters zeroed
//   for_each(stage, n, f)          f(i) for i in [0, n)
//   phases(stage, sizes, f)        for each phase p in order, f(p, k) for k in [0, sizes.size[p])
//                                  (sim/stage_time.h: the GPU runs them as one kernel)
//   sum(stage, n, f, slot)         *slot += sum of f(i)            (uint32)
//   first(stage, n, f, slot)       *slot = min(*slot, smallest i with f(i) false)
//   cast(rays, n, hits)            nearest hit per ray against obstacles and cloth
//   refit_cloth(counters)          the cloth's proximity tree at x, needed when counters->refresh > 0
//   refit_cloth_at(x, counters)    the cloth's tree at x (a further pass of the bound, when active)
//   peek(slot, unknown)            *slot where the host can read it for free (CPU), else `unknown`
//                                  (GPU): lets the CPU skip loops that would do nothing
//   counters()                     the step's counters on the host (the GPU copies them back)
//   end()                          x, v <- x_next, v_next
//
// A step is five named phases (run_step): integrate (the integrator's own, sim/integrate/), respond,
// contact (sim/contact.h), bound (sim/bound.h) and finish; run_steps runs n of them with the
// counters and the blow-up stop. The integrator is a type with integrate() and after_response() and
// a property, kLongSteps; no stage asks which one runs.
//
// The state both executors step is one type (sim/state.h). The CPU executor runs oneTBB loops and
// casts with Embree (or the host BVH in tests); the CUDA executor launches kernels on one stream.
// The lambdas only capture the StepView (plain pointers) and read the counters from the backend's
// memory, so nothing returns to the host inside a step. Both time the same stages (Stage).
#pragma once
#include <cstdint>

#include "sim/bound.h"
#include "sim/contact.h"
#include "sim/stage_time.h"
#include "sim/stages.h"
#include "sim/swept_bound.h"

namespace raycloth {

// The displacement bound's refresh, once the step has decided it (counters->refresh) and the
// cloth's tree is at x: pass 0 as decided; a partial refresh that left a marked vertex short of
// room is redone as a full one (pass 1). Also run on its own by the bound's tests.
template <class Exec>
void run_bound_refresh(Exec& ex, const StepView& s) {
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices, nt = s.model.num_triangles;
  ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_bound_reset(s, i, 0); });
  ex.for_each(Stage::Bound, nt, [s] RC_LAMBDA(uint32_t t) { stage_bound(s, t, 0); });
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_partial_short(s, i); }, &c->starved);
  ex.for_each(Stage::Bound, 1, [s] RC_LAMBDA(uint32_t) { stage_escalate_refresh(s); });
  ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_bound_reset(s, i, 1); });
  ex.for_each(Stage::Bound, nt, [s] RC_LAMBDA(uint32_t t) { stage_bound(s, t, 1); });
}

// The two-sided contact solve (sim/contact.h): pairs found once, then rounds on positions (each
// followed by the obstacles) until one finds nothing to do, then one round on velocities.
template <class Exec>
void run_contact_solve(Exec& ex, const StepView& s) {
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices;
  // Where no body moves, nothing pushes one layer of cloth into the next but the cloth itself, and
  // the paper's one-sided response with the bound keeps it clean (every static scene is checked
  // exactly): the pair search, which would double the default scene's step, is left out.
  if (!s.bodies_move) return;
  ex.for_each(Stage::Contact, n, [s] RC_LAMBDA(uint32_t i) { stage_contact_reach(s, i); });
  ex.for_each(Stage::Contact, 1, [s] RC_LAMBDA(uint32_t) { stage_cloth_clear_decide(s); });
  const uint32_t slots = contact_slots(s.model);
  ex.for_each(Stage::Contact, n, [s] RC_LAMBDA(uint32_t i) { stage_contact_find_vertex(s, i); });
  ex.for_each(Stage::Contact, s.model.num_edges, [s] RC_LAMBDA(uint32_t e) { stage_contact_find_edge(s, e); });
  // The rounds go over the listed pairs: their number where the host knows it, else every slot.
  const uint32_t listed = ex.peek(&c->contact_pairs, slots);
  if (listed == 0u) return;
  for (uint32_t round = 0; round < kContactRounds && ex.peek(&c->contact_done, 0u) == 0u; ++round) {
    ex.sum(Stage::Contact, listed, [s] RC_LAMBDA(uint32_t k) { return stage_contact_push(s, k, 0u); }, &c->contact_active);
    ex.for_each(Stage::Contact, n, [s] RC_LAMBDA(uint32_t i) { stage_contact_apply(s, i, 0u); });
    ex.for_each(Stage::Contact, 1, [s] RC_LAMBDA(uint32_t) { stage_contact_round_end(s); });
  }
  ex.for_each(Stage::Contact, 1, [s] RC_LAMBDA(uint32_t) { stage_contact_velocity_begin(s); });
  ex.sum(Stage::Contact, listed, [s] RC_LAMBDA(uint32_t k) { return stage_contact_push(s, k, 1u); }, &c->contact_active);
  ex.for_each(Stage::Contact, n, [s] RC_LAMBDA(uint32_t i) { stage_contact_apply(s, i, 1u); });
  ex.sum(Stage::Contact, n, [s] RC_LAMBDA(uint32_t i) { return (s.flags[i] & kFlagContact) ? 1u : 0u; }, &c->contact_moved);
}

// Further passes of the bound after the first clamp, while a pushed vertex is held back (see
// kBoundPasses in sim/bound.h): each a full refresh at where the last clamp left the cloth, then
// the clamp along the rest of the move.
template <class Exec>
void run_bound_passes(Exec& ex, const StepView& s, bool every_clamp) {
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices;
  StepView m = s;
  m.x = s.x_mid;
  for (uint32_t pass = 1; pass < kBoundPasses && ex.peek(&c->held, 1u) > 0u && (pass == 1 || ex.peek(&c->pass_moved, 1u) > 0u);
       ++pass) {
    ex.for_each(Stage::Bound, 1, [s] RC_LAMBDA(uint32_t) { stage_bound_pass_begin(s); });
    ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_bound_pass_move(s, i); });
    ex.refit_cloth_at(s.x_mid, c);
    run_bound_refresh(ex, m);
    ex.sum(Stage::Bound, n, [s, m, every_clamp] RC_LAMBDA(uint32_t i) { return stage_bound_pass_clamp(s, m, i, every_clamp); },
           &c->held);
  }
}

// Respond: the collision buffer from the rays (two casts), the paper's response (and what the
// integrator does after it), then the obstacles at t + dt.
template <class Exec, class Integrator>
void run_respond(Exec& ex, Integrator& integrator, const StepView& s) {
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices;
  ex.cast(s.rays, n, s.hits);
  ex.for_each(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { stage_respond_velocity(s, i); });
  ex.cast(s.rays, n, s.hits);
  ex.sum(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { return stage_respond_contact(s, i); }, &c->hits);
  integrator.after_response(ex, s);
  ex.for_each(Stage::Respond, 1, [s] RC_LAMBDA(uint32_t) { stage_body_moved(s); });
  ex.for_each(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { stage_obstacles(s, i); });
}

// The swept bound (sim/swept_bound.h), for integrators of long steps: rounds of checks of every pair
// that may meet over the step, each followed by the vertices of failing pairs going less far, until
// one finds none; kSweptRounds of them not settling it, every vertex stays at x.
template <class Exec>
void run_swept_bound(Exec& ex, const StepView& s) {
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices, nt = s.model.num_triangles;
  ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_swept_begin(s, i); });
  uint32_t round = 0;
  for (; round < kSweptRounds; ++round) {
    ex.for_each(Stage::Bound, 1, [s, round] RC_LAMBDA(uint32_t) { stage_swept_round_begin(s, round); });
    ex.for_each(Stage::Bound, nt, [s, round] RC_LAMBDA(uint32_t t) { stage_swept_check(s, t, round); });
    if (ex.peek(&c->swept_failing, 1u) == 0u) break;
    ex.for_each(Stage::Bound, n, [s, round] RC_LAMBDA(uint32_t i) { stage_swept_apply(s, i, round); });
  }
  if (round == kSweptRounds) {
    ex.for_each(Stage::Bound, 1, [s, round] RC_LAMBDA(uint32_t) { stage_swept_round_begin(s, round); });
    ex.for_each(Stage::Bound, nt, [s, round] RC_LAMBDA(uint32_t t) { stage_swept_check(s, t, round); });
    ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_swept_stop(s, i); });
  }
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_swept_clamped(s, i); }, &c->clamped);
}

// Bound: decide and run the refresh, clamp every vertex into its ball, go on where a pushed vertex
// was held back (run_bound_passes), and count what the bound did to the pushes. With an integrator
// of long steps where a body moves, the swept bound (run_swept_bound) takes the clamp's and the
// passes' place.
template <class Integrator, class Exec>
void run_bound(Exec& ex, const StepView& step) {
  StepView s = step;
  // The swept bound where a body moves; a still scene keeps the balls and their further passes (on
  // the peers' drape the swept bound let the cloth strike the sphere at full speed, and 30 sweeps
  // left it 4.4 times as stretched: docs/performance.md).
  s.swept = Integrator::kLongSteps && s.bodies_move;
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices;
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_wants_refresh(s, i); }, &c->wants);
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_wants_refresh_now(s, i); }, &c->wants_now);
  ex.for_each(Stage::Bound, 1, [s] RC_LAMBDA(uint32_t) { stage_decide_refresh(s); });
  ex.refit_cloth(c);
  run_bound_refresh(ex, s);
  if (s.swept) {
    ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_swept_out(s, i); });
    run_swept_bound(ex, s);
    ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_push_clamped(s, i); }, &c->push_clamped);
    ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_conflict(s, i); }, &c->conflicts);
    return;
  }
  // Further passes only where a body moves, or with an integrator of long steps (a vertex falling
  // freely may move farther in one than its ball allows).
  constexpr bool kEveryClamp = Integrator::kLongSteps;
  const bool moving = s.bodies_move || kEveryClamp;
  if (moving) ex.for_each(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { stage_save_goal(s, i); });
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_clamp(s, i); }, &c->clamped);
  if (moving) {
    ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_held(s, i, kEveryClamp); }, &c->held);
    run_bound_passes(ex, s, kEveryClamp);
  }
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_push_clamped(s, i); }, &c->push_clamped);
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_conflict(s, i); }, &c->conflicts);
}

// Finish: count the pushes, weld seam partners, stop on a blow-up.
template <class Exec>
void run_finish(Exec& ex, const StepView& s) {
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices;
  ex.sum(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { return (s.flags[i] & kFlagPushed) ? 1u : 0u; }, &c->pushed);
  ex.first(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { return stage_finish(s, i); }, &c->bad_vertex);
}

// One step: the named phases in order, the same on every backend.
template <class Exec, class Integrator>
void run_step(Exec& ex, Integrator& integrator, uint64_t step) {
  const StepView s = ex.begin(step);
  if (s.bodies_move)
    ex.for_each(Stage::Update, s.num_obstacle_vertices, [s] RC_LAMBDA(uint32_t i) { stage_obstacle_move(s, i); });
  integrator.integrate(ex, s);
  run_respond(ex, integrator, s);
  run_contact_solve(ex, s);
  run_bound<Integrator>(ex, s);
  // Where the steps are long and a body moves, vertices that entered a body (a step with one is taken
  // again in more substeps: Simulator::advance).
  if (Integrator::kLongSteps && s.bodies_move)
    ex.sum(Stage::Respond, s.model.num_vertices, [s] RC_LAMBDA(uint32_t i) { return stage_entered(s, i); }, &s.counters->entered);
  run_finish(ex, s);
  ex.end();
}

// n steps from step `first_step`, stopping after one that blew up: the loop, the counters and the
// blow-up stop, the same for every backend. counters() gives the step's counters on the host (the
// GPU copies them back: the only transfer per step).
template <class Exec, class Integrator>
StepResult run_steps(Exec& ex, Integrator& integrator, int n, uint64_t first_step) {
  StepResult result;
  for (int k = 0; k < n; ++k) {
    const uint64_t step_index = first_step + uint64_t(k);
    run_step(ex, integrator, step_index);
    const StepCounters& c = ex.counters();
    add_step(result, c);
    if (c.bad_vertex != 0xFFFFFFFFu) {
      result.bad_vertex = c.bad_vertex;
      result.bad_step = step_index;
      break;
    }
  }
  return result;
}

}  // namespace raycloth
