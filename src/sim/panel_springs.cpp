// One panel's vertices, masses, triangles and springs: the paper's grid (Fig. 1) for a rectangle,
// a stretch spring per edge and a bend spring per hinge for a triangle mesh; a fabric's measurements
// (src/fabric/kes.h) give the density and each spring's stiffness from the mesh around it.
#include <algorithm>
#include <map>
#include <optional>

#include "fabric/kes.h"
#include "raycloth/error.h"
#include "sim/model_build.h"

namespace raycloth {

void add_panel(ClothModel& m, const SceneDef& s, size_t pi, const PanelMesh& pm) {
  const PanelDef& pd = s.panels[pi];
  const MaterialDef& mat = find_material(s, pd.material, pi);
  Piece p;
  p.name = pd.name;
  p.first_vertex = m.num_vertices();
  p.vertex_count = pm.size();
  p.resolution_u = pm.grid ? pm.nu : 0;
  p.resolution_v = pm.grid ? pm.nv : 0;
  p.first_triangle = m.num_triangles();
  const uint32_t base = p.first_vertex;
  m.initial_positions.insert(m.initial_positions.end(), pm.placed.begin(), pm.placed.end());
  m.rest_positions.insert(m.rest_positions.end(), pm.rest.begin(), pm.rest.end());
  for (uint32_t i : pm.tris) m.triangles.push_back(base + i);
  auto spring = [&](uint32_t a, uint32_t b, float k, SpringType t) {
    const float rest = length(pm.rest[b] - pm.rest[a]);
    m.springs.push_back({base + a, base + b, rest, k, mat.spring_damping, t});
  };
  // A fabric's measurements (src/fabric/kes.h) give the density and, for each spring, a stiffness
  // from the mesh around it; the fields given explicitly keep their value.
  const std::optional<fabric::Continuum> measured =
      mat.fabric ? std::optional<fabric::Continuum>(fabric::to_continuum(*mat.fabric)) : std::nullopt;
  const float density = measured && !mat.density_set ? float(measured->density) : mat.density;
  if (pm.grid) {
    // The paper's grid (Fig. 1): equal masses, stretch, shear and bend springs.
    const uint32_t nu = pm.nu, nv = pm.nv;
    const float vertex_mass = density * pd.width * pd.height / float(nu * nv);
    auto at = [&](uint32_t u, uint32_t v) { return v * nu + u; };
    // A fabric's grid carries each vertex's own share of the area (half on an edge, a quarter at a
    // corner), and the springs along an edge half the width of those inside: the sheet's moduli
    // hold up to its edges.
    auto edge_share = [](uint32_t i, uint32_t n) { return i == 0 || i + 1 == n ? 0.5f : 1.0f; };
    if (measured) {
      const float cell = density * pd.width * pd.height / float((nu - 1) * (nv - 1));
      for (uint32_t v = 0; v < nv; ++v)
        for (uint32_t u = 0; u < nu; ++u) m.mass.push_back(cell * edge_share(u, nu) * edge_share(v, nv));
    } else {
      m.mass.insert(m.mass.end(), pm.size(), vertex_mass);
    }
    float stretch_u = mat.stretch, stretch_v = mat.stretch, shear = mat.shear, bend_u = mat.bend, bend_v = mat.bend;
    if (measured) {
      const double hx = length(pm.rest[at(1, 0)] - pm.rest[at(0, 0)]), hy = length(pm.rest[at(0, 1)] - pm.rest[at(0, 0)]);
      fabric::Continuum c = *measured;
      c.density = density;
      const fabric::GridSprings g = fabric::grid_springs(c, hx, hy);
      if (!mat.stretch_set) stretch_u = float(g.stretch_u), stretch_v = float(g.stretch_v);
      if (!mat.shear_set) shear = float(g.shear);
      if (!mat.bend_set) bend_u = float(g.bend_u), bend_v = float(g.bend_v);
    }
    for (uint32_t v = 0; v < nv; ++v)
      for (uint32_t u = 0; u < nu; ++u) {
        // Explicit stiffnesses are each spring's, as given; computed ones follow the width they carry.
        const bool ms = measured && !mat.stretch_set, mb = measured && !mat.bend_set;
        const float row = edge_share(v, nv), column = edge_share(u, nu);
        if (u + 1 < nu) spring(at(u, v), at(u + 1, v), ms ? stretch_u * row : stretch_u, SpringType::Stretch);
        if (v + 1 < nv) spring(at(u, v), at(u, v + 1), ms ? stretch_v * column : stretch_v, SpringType::Stretch);
        if (u + 1 < nu && v + 1 < nv) {
          spring(at(u, v), at(u + 1, v + 1), shear, SpringType::Shear);
          spring(at(u + 1, v), at(u, v + 1), shear, SpringType::Shear);
        }
        if (u + 2 < nu) spring(at(u, v), at(u + 2, v), mb ? bend_u * row : bend_u, SpringType::Bend);
        if (v + 2 < nv) spring(at(u, v), at(u, v + 2), mb ? bend_v * column : bend_v, SpringType::Bend);
      }
  } else {
    // A triangle mesh: a third of each triangle's rest area to each corner; a stretch spring on
    // every edge; a bend spring across every interior edge, between the two opposite corners.
    std::vector<float> mass(pm.size(), 0.0f);
    std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> opposite;
    std::map<std::pair<uint32_t, uint32_t>, double> edge_area;  // the areas of each edge's triangles
    for (size_t t = 0; t < pm.tris.size(); t += 3) {
      const uint32_t a = pm.tris[t], b = pm.tris[t + 1], c = pm.tris[t + 2];
      const float area = 0.5f * length(cross(pm.rest[b] - pm.rest[a], pm.rest[c] - pm.rest[a]));
      for (int k = 0; k < 3; ++k) {
        mass[pm.tris[t + k]] += density * area / 3.0f;
        const uint32_t p = pm.tris[t + k], q = pm.tris[t + (k + 1) % 3];
        opposite[{std::min(p, q), std::max(p, q)}].push_back(pm.tris[t + (k + 2) % 3]);
        edge_area[{std::min(p, q), std::max(p, q)}] += double(area);
      }
    }
    for (uint32_t i = 0; i < pm.size(); ++i)
      if (!(mass[i] > 0))
        throw InputError(s.source, "/panels/" + std::to_string(pi),
                         "vertex " + std::to_string(i) + " of panel '" + pd.name + "' has no area around it (degenerate triangles)");
    if (pd.min_mass_share > 0) {
      // Lift the lightest vertices to the floor; the others pay for it in proportion to their mass.
      std::vector<float> sorted = mass;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double floor = double(pd.min_mass_share) * double(sorted[sorted.size() / 2]);
      double lifted = 0, rest = 0;
      for (float w : mass) {
        if (double(w) < floor) lifted += floor - double(w);
        else rest += double(w);
      }
      if (lifted > 0 && rest > lifted) {
        const double keep = (rest - lifted) / rest;
        for (float& w : mass) w = double(w) < floor ? float(floor) : float(double(w) * keep);
      }
    }
    m.mass.insert(m.mass.end(), mass.begin(), mass.end());
    fabric::Continuum c;
    if (measured) c = *measured, c.density = density;
    struct Planned {
      uint32_t a, b;
      double k;
      SpringType type;
    };
    std::vector<Planned> planned;
    double stretch_trace = 0, bend_trace = 0;  // sum of k l^2 over each kind: their in-plane stiffness
    for (const auto& [e, opp] : opposite) {
      const double area = edge_area[e];
      const double l = length(pm.rest[e.second] - pm.rest[e.first]);
      const double ks = measured && !mat.stretch_set ? fabric::edge_stretch(c, area, l) : double(mat.stretch);
      planned.push_back({e.first, e.second, ks, SpringType::Stretch});
      stretch_trace += ks * l * l;
      if (opp.size() == 2 && opp[0] != opp[1]) {
        const double lb = length(pm.rest[opp[1]] - pm.rest[opp[0]]);
        const double kb = measured && !mat.bend_set ? fabric::hinge_bend(c, area, lb) : double(mat.bend);
        planned.push_back({opp[0], opp[1], kb, SpringType::Bend});
        bend_trace += kb * lb * lb;
      }
    }
    // Stretched, the bend springs pull too: the stretch springs give up that share of the sheet's
    // in-plane stiffness (at most half: a mesh so fine that they pull more is stiffer than measured).
    const double give = measured && !mat.stretch_set && !mat.bend_set && stretch_trace > 0
                            ? std::min(bend_trace / stretch_trace, 0.5) : 0.0;
    for (const Planned& sp : planned)
      spring(sp.a, sp.b, float(sp.type == SpringType::Stretch ? sp.k * (1.0 - give) : sp.k), sp.type);
  }
  for (uint32_t i = 0; i < pm.size(); ++i) {
    m.inv_mass.push_back(1.0f / m.mass[base + i]);
    m.damping.push_back(mat.damping);
  }
  p.num_triangles = m.num_triangles() - p.first_triangle;
  m.pieces.push_back(p);
}

}  // namespace raycloth
