// The paper's explicit Euler, eq. (3): v' = v + dt f / m, x' = x + dt v', one pass over the vertices.
// Stable below T0 = pi sqrt(m/K) (Simulator refuses a dt above the mesh's limit).
#pragma once
#include <cstdint>

#include "sim/integrate/common.h"
#include "sim/stage_time.h"

namespace raycloth {

// Eq. (3): a = f / m, v' = v + dt a, x' = x + dt v'. Pinned vertices (inv_mass 0) stay put.
// `external` is any other force on the vertex (an attachment's pull).
RC_HD void integrate_vertex(const ModelView& m, const Vec3* x, const Vec3* v, uint32_t i, Vec3 gravity, float dt,
                            Vec3& v_next, Vec3& x_next, float sew = 1.0f, Vec3 external = Vec3{0, 0, 0}) {
  const float inv_mass = m.inv_mass[i];
  if (inv_mass == 0.0f) {
    v_next = make_vec3(0, 0, 0);
    x_next = x[i];
    return;
  }
  const Vec3 a = (spring_force(m, x, v, i, sew) + hinge_force(m, x, i) + membrane_force(m, x, i) + external) * inv_mass + gravity - v[i] * m.damping[i];
  v_next = v[i] + a * dt;
  x_next = x[i] + v_next * dt;
}

// The paper's explicit Euler, eq. (3).
RC_HD void stage_integrate(const StepView& s, uint32_t i) {
  integrate_vertex(s.model, s.x, s.v, i, s.ctx.gravity, s.ctx.dt, s.v_next[i], s.x_next[i], s.ctx.sew,
                   attachment_force(s, i));
  finish_integrate(s, i);
}

// The integrator of sim/step.h: no scratch of its own, short steps.
struct ExplicitEuler {
  // Its steps are short: the bound's further passes run only where a body moves, and only vertices
  // an obstacle or the contact solve pushed are held back by it.
  static constexpr bool kLongSteps = false;
  // It has no sweeps.
  void set_iterations(uint32_t) {}
  template <class Exec>
  void integrate(Exec& ex, const StepView& s) const {
    ex.for_each(Stage::Integrate, s.model.num_vertices, [s] RC_LAMBDA(uint32_t i) { stage_integrate(s, i); });
  }
  // After the response: nothing (x' = x + dt v' already holds).
  template <class Exec>
  void after_response(Exec&, const StepView&) const {}
};

}  // namespace raycloth
