// The measured fabrics' stretch springs (measured.h): a spring of stiffness k at no strain whose
// stiffness grows to k + dk at the strain the data were sampled at (kMeasuredStrain, 1/6), linearly
// in its strain, and stays there beyond, as ARCSim's coefficients do between the files' row 0 and
// rows 1-5. Compressed, it keeps k. Host and device: the spring force (sim/physics.h) calls it.
#pragma once
#include "raycloth/hd.h"

namespace raycloth::fabric {

// The stiffness of a spring stretched by `stretch` (metres) over its rest length `rest`.
RC_HD float stiffened(float k, float dk, float stretch, float rest) {
  if (dk == 0.0f || !(stretch > 0.0f) || !(rest > 0.0f)) return k;
  const float w = stretch * 6.0f / rest;  // the strain over 1/6
  return k + dk * (w < 1.0f ? w : 1.0f);
}

// d(force)/d(length) of that spring: the force is stiffened(...) * stretch, so below 1/6 the
// stiffness grows twice as fast as the secant's. Never below 0 (a spring that softens, dk < 0, would
// otherwise give the implicit step's block Hessian a negative direction).
RC_HD float stiffened_tangent(float k, float dk, float stretch, float rest) {
  if (dk == 0.0f || !(stretch > 0.0f) || !(rest > 0.0f)) return k;
  const float w = stretch * 6.0f / rest;
  const float t = w < 1.0f ? k + 2.0f * dk * w : k + dk;
  return t > 0.0f ? t : 0.0f;
}

}  // namespace raycloth::fabric
