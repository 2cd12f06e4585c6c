// One panel's vertices, masses, triangles and springs: the paper's grid (Fig. 1) for a rectangle,
// a stretch spring per edge and a bend spring per hinge for a triangle mesh; a fabric's measurements
// (src/fabric/kes.h) give the density and each spring's stiffness from the mesh around it. A measured
// fabric (src/fabric/measured.h) carries warp and weft apart: on a grid with stretch springs that
// stiffen, on a triangle mesh with a membrane on each triangle (sim/membrane.h), and bends by hinges
// (sim/hinges.h) unless its material asks for bend springs.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>

#include "fabric/kes.h"
#include "fabric/measured.h"
#include "raycloth/error.h"
#include "sim/hinges.h"
#include "sim/model_build.h"

namespace raycloth {

namespace {

// Membrane triangles (sim/membrane.h) for a panel's rest triangles (corners numbered from `base`),
// the warp laid into each triangle's plane; the fabric's law (fabric::membrane_law) added to the model once.
void add_membranes(ClothModel& m, const fabric::MeasuredData& d, const std::vector<Vec3>& rest, const std::vector<uint32_t>& tris,
                   uint32_t base, Vec3 warp) {
  const std::array<float, kMembraneLaw> law = fabric::membrane_law(d).p;
  uint32_t fabric = uint32_t(m.membrane_law.size() / kMembraneLaw);
  for (uint32_t f = 0; f * kMembraneLaw < m.membrane_law.size(); ++f)
    if (std::equal(law.begin(), law.end(), m.membrane_law.begin() + f * kMembraneLaw)) fabric = f;
  if (fabric * kMembraneLaw == m.membrane_law.size()) m.membrane_law.insert(m.membrane_law.end(), law.begin(), law.end());
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    const DVec3 p0 = dvec(rest[tris[t]]), e1 = dvec(rest[tris[t + 1]]) - p0, e2 = dvec(rest[tris[t + 2]]) - p0;
    DVec3 n = dcross(e1, e2);
    const double twice_area = std::sqrt(ddot(n, n));
    if (!(twice_area > 0)) continue;
    n = n * (1.0 / twice_area);
    // The warp laid into the plane (as fabric::angle_from_warp lays it), and the weft beside it.
    const double angle1 = fabric::angle_from_warp(make_vec3(float(e1.x), float(e1.y), float(e1.z)),
                                                  make_vec3(float(n.x), float(n.y), float(n.z)), warp);
    const double angle2 = fabric::angle_from_warp(make_vec3(float(e2.x), float(e2.y), float(e2.z)),
                                                  make_vec3(float(n.x), float(n.y), float(n.z)), warp);
    const double l1 = std::sqrt(ddot(e1, e1)), l2 = std::sqrt(ddot(e2, e2));
    const double s1 = l1 * std::cos(angle1), t1 = l1 * std::sin(angle1), s2 = l2 * std::cos(angle2), t2 = l2 * std::sin(angle2);
    const double det = s1 * t2 - s2 * t1;
    if (!(std::fabs(det) > 0)) continue;
    for (int k = 0; k < 3; ++k) m.membrane_vertex.push_back(base + tris[t + size_t(k)]);
    m.membrane_shape.insert(m.membrane_shape.end(), {float(t2 / det), float(-s2 / det), float(-t1 / det), float(s1 / det)});
    m.membrane_area.push_back(float(0.5 * twice_area));
    m.membrane_fabric.push_back(fabric);
  }
}

}  // namespace

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
  auto spring = [&](uint32_t a, uint32_t b, float k, SpringType t, float k_stiff = 0.0f) {
    const float rest = length(pm.rest[b] - pm.rest[a]);
    m.springs.push_back({base + a, base + b, rest, k, mat.spring_damping, t, 0.0f, k_stiff});
  };
  // A fabric's measurements (src/fabric/kes.h) give the density and, for each spring, a stiffness
  // from the mesh around it; the fields given explicitly keep their value.
  const std::optional<fabric::Continuum> measured =
      mat.fabric ? std::optional<fabric::Continuum>(fabric::to_continuum(*mat.fabric)) : std::nullopt;
  // A measured fabric (src/fabric/measured.h): the same, warp and weft apart, stretch springs stiffening.
  const fabric::MeasuredFabric* data = mat.measured.empty() ? nullptr : fabric::find_measured(mat.measured);
  const float density = data && !mat.density_set ? float(data->data.density)
                        : measured && !mat.density_set ? float(measured->density) : mat.density;
  const double warp = double(pd.warp) * M_PI / 180.0;
  // Hinges instead of bend springs (MaterialDef::bends_by_hinges): a measured fabric's rigidity
  // across each interior edge, the curvature's direction taken from the warp laid into the plane.
  const bool hinges = data && mat.bends_by_hinges();
  auto add_hinges = [&](Vec3 warp_dir, const std::vector<uint32_t>& tris, double share) {
    const std::vector<Hinge> h = build_hinges(pm.rest, tris, base, [&](Vec3 across, Vec3 normal) {
      return share * fabric::measured_bending(data->data, fabric::angle_from_warp(across, normal, warp_dir));
    });
    m.hinges.insert(m.hinges.end(), h.begin(), h.end());
  };
  if (pm.grid) {
    // The paper's grid (Fig. 1): equal masses, stretch, shear and bend springs.
    const uint32_t nu = pm.nu, nv = pm.nv;
    const float vertex_mass = density * pd.width * pd.height / float(nu * nv);
    auto at = [&](uint32_t u, uint32_t v) { return v * nu + u; };
    // A fabric's grid carries each vertex's own share of the area (half on an edge, a quarter at a
    // corner), and the springs along an edge half the width of those inside: the sheet's moduli
    // hold up to its edges.
    auto edge_share = [](uint32_t i, uint32_t n) { return i == 0 || i + 1 == n ? 0.5f : 1.0f; };
    if (measured || data) {
      const float cell = density * pd.width * pd.height / float((nu - 1) * (nv - 1));
      for (uint32_t v = 0; v < nv; ++v)
        for (uint32_t u = 0; u < nu; ++u) m.mass.push_back(cell * edge_share(u, nu) * edge_share(v, nv));
    } else {
      m.mass.insert(m.mass.end(), pm.size(), vertex_mass);
    }
    float stretch_u = mat.stretch, stretch_v = mat.stretch, shear = mat.shear, bend_u = mat.bend, bend_v = mat.bend;
    std::optional<float> shear_b;  // measured fabrics: the other diagonal apart
    float stiff_u = 0, stiff_v = 0, stiff_a = 0, stiff_b = 0;
    if (data) {
      const double hx = length(pm.rest[at(1, 0)] - pm.rest[at(0, 0)]), hy = length(pm.rest[at(0, 1)] - pm.rest[at(0, 0)]);
      const fabric::MeasuredGrid g = fabric::measured_grid(data->data, density, hx, hy, warp, !hinges);
      if (!mat.stretch_set) stretch_u = float(g.stretch_u), stretch_v = float(g.stretch_v), stiff_u = float(g.stiff_u), stiff_v = float(g.stiff_v);
      if (!mat.shear_set) shear = float(g.diag_a), shear_b = float(g.diag_b), stiff_a = float(g.stiff_a), stiff_b = float(g.stiff_b);
      if (!mat.bend_set) bend_u = float(g.bend_u), bend_v = float(g.bend_v);
    }
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
        const bool ms = (measured || data) && !mat.stretch_set, mb = (measured || data) && !mat.bend_set;
        const float row = edge_share(v, nv), column = edge_share(u, nu);
        if (u + 1 < nu) spring(at(u, v), at(u + 1, v), ms ? stretch_u * row : stretch_u, SpringType::Stretch, stiff_u * row);
        if (v + 1 < nv) spring(at(u, v), at(u, v + 1), ms ? stretch_v * column : stretch_v, SpringType::Stretch, stiff_v * column);
        if (u + 1 < nu && v + 1 < nv) {
          spring(at(u, v), at(u + 1, v + 1), shear, SpringType::Shear, stiff_a);
          spring(at(u + 1, v), at(u, v + 1), shear_b.value_or(shear), SpringType::Shear, stiff_b);
        }
        if (hinges) continue;
        if (u + 2 < nu) spring(at(u, v), at(u + 2, v), mb ? bend_u * row : bend_u, SpringType::Bend);
        if (v + 2 < nv) spring(at(u, v), at(u, v + 2), mb ? bend_v * column : bend_v, SpringType::Bend);
      }
    if (hinges) {
      // The warp runs at `warp` from u towards v.
      const Vec3 u_dir = pm.rest[at(1, 0)] - pm.rest[at(0, 0)], v_dir = pm.rest[at(0, 1)] - pm.rest[at(0, 0)];
      const Vec3 warp_dir = u_dir / length(u_dir) * float(std::cos(warp)) + v_dir / length(v_dir) * float(std::sin(warp));
      // Each cell split along both diagonals, half the rigidity on each: one split alone lets the
      // grid shear a little as it bends and halves the moment (a cantilever strip bent with B / 2).
      std::vector<uint32_t> split_a, split_b;
      for (uint32_t v = 0; v + 1 < nv; ++v)
        for (uint32_t u = 0; u + 1 < nu; ++u) {
          const uint32_t a = at(u, v), b = at(u + 1, v), c = at(u + 1, v + 1), d = at(u, v + 1);
          split_a.insert(split_a.end(), {a, b, c, a, c, d});
          split_b.insert(split_b.end(), {a, b, d, b, c, d});
        }
      add_hinges(warp_dir, split_a, 0.5);
      add_hinges(warp_dir, split_b, 0.5);
    }
  } else {
    // A triangle mesh: a third of each triangle's rest area to each corner; a stretch spring on
    // every edge (a measured fabric: a membrane on every triangle instead); a bend spring across
    // every interior edge, between the two opposite corners (a measured fabric: a hinge).
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
    // Where a measured fabric's warp runs in the panel's rest shape.
    const Vec3 warp_dir = pd.shape == PanelShape::Mesh ? make_vec3(float(std::cos(warp)), 0.0f, float(-std::sin(warp)))
                                                       : make_vec3(float(std::cos(warp)), float(std::sin(warp)), 0.0f);
    // A measured fabric's in-plane model on the triangles themselves (sim/membrane.h): no stretch springs.
    const bool membranes = data && !mat.stretch_set;
    if (membranes) add_membranes(m, data->data, pm.rest, pm.tris, base, warp_dir);
    std::vector<Planned> planned;
    double stretch_trace = 0, bend_trace = 0;  // sum of k l^2 over each kind: their in-plane stiffness
    for (const auto& [e, opp] : opposite) {
      const double area = edge_area[e];
      const double l = length(pm.rest[e.second] - pm.rest[e.first]);
      const double ks = measured && !mat.stretch_set ? fabric::edge_stretch(c, area, l) : double(mat.stretch);
      if (!membranes) {
        planned.push_back({e.first, e.second, ks, SpringType::Stretch});
        stretch_trace += ks * l * l;
      }
      if (opp.size() == 2 && opp[0] != opp[1] && !hinges) {
        const double lb = length(pm.rest[opp[1]] - pm.rest[opp[0]]);
        const Vec3 across = pm.rest[opp[1]] - pm.rest[opp[0]], hinge = pm.rest[e.second] - pm.rest[e.first];
        const double kb = data && !mat.bend_set ? fabric::measured_hinge_bend(data->data, density, area, lb,
                                                                              fabric::angle_from_warp(across, cross(hinge, across), warp_dir))
                          : measured && !mat.bend_set ? fabric::hinge_bend(c, area, lb) : double(mat.bend);
        planned.push_back({opp[0], opp[1], kb, SpringType::Bend});
        bend_trace += kb * lb * lb;
      }
    }
    // Stretched, the bend springs pull too: the stretch springs give up that share of the sheet's
    // in-plane stiffness (at most half: a mesh so fine that they pull more is stiffer than measured).
    const double give = (measured || data) && !mat.stretch_set && !mat.bend_set && stretch_trace > 0
                            ? std::min(bend_trace / stretch_trace, 0.5) : 0.0;
    if (hinges) add_hinges(warp_dir, pm.tris, 1.0);
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
