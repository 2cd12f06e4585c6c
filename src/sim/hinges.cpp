// Hinge bending elements from a panel's rest triangles (sim/hinges.h).
#include "sim/hinges.h"

#include <cmath>
#include <map>
#include <utility>

namespace raycloth {

namespace {

// cot of the angle between a and b; false when they are parallel.
bool cot(DVec3 a, DVec3 b, double& c) {
  const DVec3 n = dcross(a, b);
  const double s = std::sqrt(ddot(n, n));
  if (!(s > 1e-30)) return false;
  c = ddot(a, b) / s;
  return true;
}

}  // namespace

bool hinge_weights(DVec3 x0, DVec3 x1, DVec3 x2, DVec3 x3, std::array<double, 4>& k) {
  const DVec3 e0 = x1 - x0, e1 = x2 - x0, e2 = x3 - x0, e3 = x2 - x1, e4 = x3 - x1;
  double c01, c02, c03, c04;
  if (!cot(e0, e1, c01) || !cot(e0, e2, c02) || !cot(e0 * -1.0, e3, c03) || !cot(e0 * -1.0, e4, c04)) return false;
  k = {c03 + c04, c01 + c02, -c01 - c03, -c02 - c04};
  return true;
}

std::vector<Hinge> build_hinges(const std::vector<Vec3>& rest, const std::vector<uint32_t>& tris, uint32_t base,
                                const std::function<double(Vec3 across, Vec3 normal)>& rigidity) {
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> opposite;  // edge -> corners across it
  for (size_t t = 0; t + 2 < tris.size(); t += 3)
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t p = tris[t + k], q = tris[t + (k + 1) % 3];
      opposite[{std::min(p, q), std::max(p, q)}].push_back(tris[t + (k + 2) % 3]);
    }
  std::vector<Hinge> out;
  for (const auto& [e, opp] : opposite) {
    if (opp.size() != 2 || opp[0] == opp[1]) continue;
    const DVec3 x0 = dvec(rest[e.first]), x1 = dvec(rest[e.second]), x2 = dvec(rest[opp[0]]), x3 = dvec(rest[opp[1]]);
    std::array<double, 4> k;
    if (!hinge_weights(x0, x1, x2, x3, k)) continue;
    const DVec3 n0 = dcross(x1 - x0, x2 - x0), n1 = dcross(x3 - x0, x1 - x0);
    const double areas = 0.5 * (std::sqrt(ddot(n0, n0)) + std::sqrt(ddot(n1, n1)));
    if (!(areas > 0)) continue;
    // The rest edge's perpendicular in the mean plane of its two triangles: the curvature it bends.
    DVec3 n = n0 + n1;
    const double nn = std::sqrt(ddot(n, n));
    if (!(nn > 0)) continue;
    n = n * (1.0 / nn);
    const DVec3 across = dcross(n, x1 - x0);
    const double b = rigidity(make_vec3(float(across.x), float(across.y), float(across.z)),
                              make_vec3(float(n.x), float(n.y), float(n.z)));
    if (!(b > 0)) continue;
    const double scale = std::sqrt(b / areas);
    Hinge h;
    h.v = {base + e.first, base + e.second, base + opp[0], base + opp[1]};
    for (size_t j = 0; j < 4; ++j) h.w[j] = float(scale * k[j]);
    out.push_back(h);
  }
  return out;
}

}  // namespace raycloth
