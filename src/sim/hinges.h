// Hinge bending elements (Hinge in sim/model.h) built from a panel's rest triangles.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "collide/proximity.h"
#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

// The cotangent weights K of the hinge across edge (x0, x1) with opposite corners x2 and x3 (Bergou
// et al. 2006): K . (x0, x1, x2, x3) = 0 for every flat placement of the two triangles. False where
// a triangle is degenerate (no weights).
bool hinge_weights(DVec3 x0, DVec3 x1, DVec3 x2, DVec3 x3, std::array<double, 4>& k);

// One hinge per interior edge of `tris` (corners into `rest`, numbered from `base` in the model),
// with weights w = sqrt(B / (A0 + A1)) K, B = rigidity(across, normal): the bending rigidity (N m)
// for a curvature along `across` (the rest edge's in-plane perpendicular) in the plane of normal
// `normal`. Edges on one triangle or on more than two get none.
std::vector<Hinge> build_hinges(const std::vector<Vec3>& rest, const std::vector<uint32_t>& tris, uint32_t base,
                                const std::function<double(Vec3 across, Vec3 normal)>& rigidity);

}  // namespace raycloth
