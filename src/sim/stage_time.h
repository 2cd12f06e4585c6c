// The stages both executors time alike (sim/step.h), their books (StageTimes), and RC_LAMBDA, the
// mark of a lambda the step hands an executor (host and device under nvcc).
#pragma once

#include "raycloth/simulator.h"

#if defined(__CUDACC__)
#define RC_LAMBDA __host__ __device__
#else
#define RC_LAMBDA
#endif

namespace raycloth {

enum class Stage { Integrate, Update, Cast, Respond, Contact, Bound };

// A sequence of dependent loops handed to an executor at once (`phases`, sim/step.h): phase p runs
// f(p, k) for every k in [0, size[p]) and sees everything the phases before it wrote. The CPU runs
// them one parallel loop after another; the GPU runs them in one kernel with a barrier between
// phases, instead of a launch each.
inline constexpr uint32_t kMaxPhases = 128;

struct PhaseSizes {
  uint32_t count = 0;
  uint32_t size[kMaxPhases] = {};
  void add(uint32_t n) { size[count++] = n; }  // the caller keeps count below kMaxPhases
  uint32_t largest() const {
    uint32_t m = 0;
    for (uint32_t p = 0; p < count; ++p) m = size[p] > m ? size[p] : m;
    return m;
  }
};

// Books `seconds` to a stage's total.
inline void add_stage_time(StageTimes& t, Stage stage, double seconds) {
  switch (stage) {
    case Stage::Integrate: t.integrate += seconds; break;
    case Stage::Update: t.update += seconds; break;
    case Stage::Cast: t.cast += seconds; break;
    case Stage::Respond: t.respond += seconds; break;
    case Stage::Contact: t.contact += seconds; break;
    case Stage::Bound: t.bound += seconds; break;
  }
}

}  // namespace raycloth
