// The integrators of the step (sim/step.h), each in its own file here: the paper's explicit Euler
// (explicit.h) and implicit Euler by vertex block descent (vbd.h). The one place that picks one is
// make_integrator, from the scene's time.integrator; a backend holds the result and visits it once
// per batch of steps.
#pragma once
#include <cstddef>
#include <variant>

#include "raycloth/scene.h"
#include "sim/integrate/explicit.h"
#include "sim/integrate/vbd.h"

namespace raycloth {

template <template <class> class Array>
using AnyIntegrator = std::variant<ExplicitEuler, VertexBlockDescent<Array>>;

// The scene's integrator for n vertices, with `iterations` sweeps per step (the implicit one).
template <template <class> class Array>
void make_integrator(AnyIntegrator<Array>& out, const TimeDef& time, size_t n, int iterations) {
  if (time.integrator == Integrator::Implicit)
    out.template emplace<VertexBlockDescent<Array>>(n, uint32_t(iterations), float(time.tolerance));
  else
    out.template emplace<ExplicitEuler>();
}

}  // namespace raycloth
