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
