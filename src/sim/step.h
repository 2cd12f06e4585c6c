// One step of the simulation, written once. Every backend runs this same sequence through an
// executor that supplies the loops, the reductions and the ray cast (the backend seam):
//
//   StepView begin(uint64_t step)  obstacles posed at t + dt, ray structures updated (obstacles at
//                                  t + dt, cloth at x), counters zeroed
//   for_each(stage, n, f)          f(i) for i in [0, n)
//   sum(stage, n, f, slot)         *slot += sum of f(i)            (uint32)
//   first(stage, n, f, slot)       *slot = min(*slot, smallest i with f(i) false)
//   cast(rays, n, hits)            nearest hit per ray against obstacles and cloth
//   refit_cloth(counters)          the cloth's proximity tree at x, needed when counters->refresh > 0
//   end()                          x, v <- x_next, v_next
//
// The CPU executor runs oneTBB loops and casts with Embree (or the host BVH in tests); the CUDA
// executor launches kernels into one graph. The lambdas only capture the StepView (plain pointers)
// and read the counters from the backend's memory, so nothing returns to the host inside a step.
#pragma once
#include <cstdint>

#include "sim/stages.h"

#if defined(__CUDACC__)
#define RC_LAMBDA __host__ __device__
#else
#define RC_LAMBDA
#endif

namespace raycloth {

enum class Stage { Integrate, Update, Cast, Respond, Bound };

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

template <class Exec>
void run_step(Exec& ex, uint64_t step) {
  const StepView s = ex.begin(step);
  StepCounters* c = s.counters;
  const uint32_t n = s.model.num_vertices, nt = s.model.num_triangles;

  ex.for_each(Stage::Integrate, n, [s] RC_LAMBDA(uint32_t i) { stage_integrate(s, i); });
  ex.cast(s.rays, n, s.hits);
  ex.for_each(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { stage_respond_velocity(s, i); });
  ex.cast(s.rays, n, s.hits);
  ex.sum(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { return stage_respond_contact(s, i); }, &c->hits);
  ex.for_each(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { stage_obstacles(s, i); });

  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_wants_refresh(s, i); }, &c->wants);
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_wants_refresh_now(s, i); }, &c->wants_now);
  ex.for_each(Stage::Bound, 1, [s] RC_LAMBDA(uint32_t) { stage_decide_refresh(s); });
  ex.refit_cloth(c);
  run_bound_refresh(ex, s);
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_clamp(s, i); }, &c->clamped);
  ex.sum(Stage::Bound, n, [s] RC_LAMBDA(uint32_t i) { return stage_conflict(s, i); }, &c->conflicts);
  ex.sum(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { return (s.flags[i] & kFlagPushed) ? 1u : 0u; }, &c->pushed);

  ex.first(Stage::Respond, n, [s] RC_LAMBDA(uint32_t i) { return stage_finish(s, i); }, &c->bad_vertex);
  ex.end();
}

}  // namespace raycloth
