#include "sim/model.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <functional>
#include <map>
#include <set>

#include "collide/proximity.h"
#include "collide/rules.h"
#include "raycloth/error.h"
#include "collide/holes.h"
#include "fabric/kes.h"
#include "fabric/measured.h"
#include "scene/pattern.h"
#include "scene/transform.h"

namespace raycloth {

namespace {

const MaterialDef& find_material(const SceneDef& s, const std::string& name, size_t panel) {
  for (const auto& m : s.materials)
    if (m.name == name) return m;
  throw InputError(s.source, "/panels/" + std::to_string(panel) + "/material", "unknown material '" + name + "'");
}

size_t find_panel(const SceneDef& s, const std::string& name, const std::string& field) {
  for (size_t i = 0; i < s.panels.size(); ++i)
    if (s.panels[i].name == name) return i;
  throw InputError(s.source, field, "unknown panel '" + name + "'");
}

// Global vertex ids along a named edge, in increasing u or v.
std::vector<uint32_t> edge_vertices(const Piece& p, const std::string& edge, const std::string& file,
                                    const std::string& field) {
  std::vector<uint32_t> ids;
  const uint32_t nu = p.resolution_u, nv = p.resolution_v;
  auto at = [&](uint32_t u, uint32_t v) { return p.first_vertex + v * nu + u; };
  if (edge == "left" || edge == "right") {
    const uint32_t u = edge == "left" ? 0 : nu - 1;
    for (uint32_t v = 0; v < nv; ++v) ids.push_back(at(u, v));
  } else if (edge == "bottom" || edge == "top") {
    const uint32_t v = edge == "bottom" ? 0 : nv - 1;
    for (uint32_t u = 0; u < nu; ++u) ids.push_back(at(u, v));
  } else {
    throw InputError(file, field, "unknown edge '" + edge + "' (expected left, right, bottom or top)");
  }
  return ids;
}

// Distance from p to the segment ab.
float segment_distance(Vec3 p, Vec3 a, Vec3 b) {
  const Vec3 ab = b - a;
  const float l2 = dot(ab, ab);
  const float t = l2 > 0 ? std::clamp(dot(p - a, ab) / l2, 0.0f, 1.0f) : 0.0f;
  return length(p - (a + ab * t));
}

uint32_t find_root(std::vector<uint32_t>& parent, uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

void weld_seams(ClothModel& m) {
  const uint32_t n = m.num_vertices();
  std::vector<Vec3> sum(n, make_vec3(0, 0, 0));
  std::vector<uint32_t> members(n, 0u);
  for (uint32_t i = 0; i < n; ++i) {
    sum[m.alias[i]] += m.initial_positions[i];
    ++members[m.alias[i]];
  }
  for (uint32_t i = 0; i < n; ++i) m.initial_positions[i] = sum[m.alias[i]] / float(members[m.alias[i]]);
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t r = m.alias[i];
    if (r == i) continue;
    m.mass[r] += m.mass[i];
    if (m.inv_mass[i] == 0.0f) m.inv_mass[r] = 0.0f;
    m.mass[i] = 0.0f;
    m.inv_mass[i] = 0.0f;
  }
  for (uint32_t i = 0; i < n; ++i)
    if (m.alias[i] == i && m.inv_mass[i] != 0.0f) m.inv_mass[i] = 1.0f / m.mass[i];
  std::vector<Spring> springs;
  springs.reserve(m.springs.size());
  for (Spring sp : m.springs) {
    sp.a = m.alias[sp.a];
    sp.b = m.alias[sp.b];
    if (sp.a != sp.b) springs.push_back(sp);
  }
  m.springs = std::move(springs);
  m.collision_triangles.resize(m.triangles.size());
  for (size_t k = 0; k < m.triangles.size(); ++k) m.collision_triangles[k] = m.alias[m.triangles[k]];
  m.tri_alias = m.collision_triangles;
  if (!m.sew_group.empty())  // the rays skip every triangle of their vertex's group
    for (uint32_t& c : m.tri_alias) c = m.sew_group[c];
  std::vector<std::pair<uint32_t, uint32_t>> e;
  e.reserve(m.triangles.size());
  std::set<std::pair<uint32_t, uint32_t>> seen;
  m.tri_edge_owner.assign(m.num_collision_triangles(), 0);
  for (size_t t = 0; t < m.collision_triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.collision_triangles[t + k], b = m.collision_triangles[t + (k + 1) % 3];
      e.emplace_back(std::min(a, b), std::max(a, b));
      if (seen.insert(e.back()).second) m.tri_edge_owner[t / 3] |= uint8_t(1u << k);
    }
  // Corner ownership (bits 3..5): the lowest-numbered triangle holding each vertex.
  std::vector<char> has_owner(m.num_vertices(), 0);
  for (size_t t = 0; t < m.collision_triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      char& owned = has_owner[m.collision_triangles[t + k]];
      if (!owned) owned = 1, m.tri_edge_owner[t / 3] |= uint8_t(1u << (3 + k));
    }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  m.edges.clear();
  m.edges.reserve(2 * e.size());
  double total = 0;
  for (const auto& [a, b] : e) {
    m.edges.insert(m.edges.end(), {a, b});
    total += double(length(m.initial_positions[a] - m.initial_positions[b]));
  }
  m.mean_edge = e.empty() ? 0.0f : float(total / double(e.size()));
}

ModelView ClothModel::view() const {
  ModelView v;
  v.num_vertices = num_vertices();
  v.inv_mass = inv_mass.data();
  v.damping = damping.data();
  v.adj_offset = adj_offset.data();
  v.adj_other = adj_other.data();
  v.adj_rest = adj_rest.data();
  v.adj_k = adj_k.data();
  v.adj_kd = adj_kd.data();
  v.adj_k_stiff = adj_k_stiff.empty() ? nullptr : adj_k_stiff.data();
  v.alias = alias.data();
  v.triangles = collision_triangles.data();
  v.tri_alias = tri_alias.data();
  v.edges = edges.data();
  v.num_edges = num_edges();
  v.num_triangles = num_collision_triangles();
  v.tri_edge_owner = tri_edge_owner.data();
  v.adj_rest_start = adj_rest_start.empty() ? nullptr : adj_rest_start.data();
  v.sew_group = sew_group.empty() ? nullptr : sew_group.data();
  if (!attach_tri.empty()) {
    v.attach_slot = attach_slot.data();
    v.attach_tri = attach_tri.data();
    v.attach_bary = attach_bary.data();
    v.attach_offset = attach_offset.data();
    v.attach_lift = attach_lift.data();
    v.attach_k = attach_k.data();
    v.attach_kd = attach_kd.data();
  }
  v.color_vertices = color_vertices.data();
  v.color_offset = color_offset.data();
  v.num_colors = color_offset.empty() ? 0u : uint32_t(color_offset.size() - 1);
  return v;
}

float ClothModel::min_mass() const {
  float m = INFINITY;
  for (size_t i = 0; i < mass.size(); ++i)
    if (inv_mass[i] > 0) m = std::min(m, mass[i]);
  return m;
}

float ClothModel::max_stiffness() const {
  float k = 0;
  for (const auto& s : springs) k = std::max(k, s.k + std::max(s.k_stiff, 0.0f));
  for (float a : attach_k) k = std::max(k, a);
  return k;
}

double ClothModel::natural_period() const {
  const double k = max_stiffness();
  return k > 0 ? M_PI * std::sqrt(double(min_mass()) / k) : INFINITY;
}

double ClothModel::stability_limit(uint32_t* vertex) const {
  double best = INFINITY;
  for (uint32_t i = 0; i < num_vertices(); ++i) {
    if (inv_mass[i] == 0.0f) continue;
    const double k = stiffness_sum(i);
    if (k <= 0) continue;
    const double limit = 2.0 * std::sqrt(double(mass[i]) / k);
    if (limit < best) {
      best = limit;
      if (vertex) *vertex = i;
    }
  }
  return best;
}

double ClothModel::stiffness_sum(uint32_t i) const {
  double k = 0;
  for (uint32_t e = adj_offset[i]; e < adj_offset[i + 1]; ++e) k += double(adj_k[e]);
  if (!adj_k_stiff.empty())  // a stiffening spring at its stiffest, or twice that tangent at 1/6
    for (uint32_t e = adj_offset[i]; e < adj_offset[i + 1]; ++e) k += std::max(2.0 * double(adj_k_stiff[e]), 0.0);
  if (!attach_slot.empty() && attach_slot[i] != kNoAttachment) k += double(attach_k[attach_slot[i]]);
  return k;
}

const Piece& ClothModel::piece_of(uint32_t i) const {
  for (const Piece& p : pieces)
    if (i >= p.first_vertex && i < p.first_vertex + p.num_vertices()) return p;
  return pieces.front();
}

// Per-vertex adjacency (CSR) so that forces are gathered, never scattered.
void build_adjacency(ClothModel& model) {
  model.spring_counts = {};
  const uint32_t n = model.num_vertices();
  std::vector<uint32_t> degree(n, 0);
  for (const auto& sp : model.springs) {
    ++degree[sp.a];
    ++degree[sp.b];
    ++model.spring_counts[size_t(sp.type)];
  }
  model.adj_offset.assign(n + 1, 0);
  for (uint32_t i = 0; i < n; ++i) model.adj_offset[i + 1] = model.adj_offset[i] + degree[i];
  const size_t e = model.adj_offset[n];
  model.adj_other.resize(e);
  model.adj_rest.resize(e);
  model.adj_k.resize(e);
  model.adj_kd.resize(e);
  if (model.sew_time > 0) model.adj_rest_start.resize(e);
  else model.adj_rest_start.clear();
  const bool stiffens = std::any_of(model.springs.begin(), model.springs.end(), [](const Spring& sp) { return sp.k_stiff != 0; });
  if (stiffens) model.adj_k_stiff.assign(e, 0.0f);
  else model.adj_k_stiff.clear();
  std::vector<uint32_t> fill(model.adj_offset.begin(), model.adj_offset.end() - 1);
  for (const auto& sp : model.springs) {
    for (int side = 0; side < 2; ++side) {
      const uint32_t self = side ? sp.b : sp.a, other = side ? sp.a : sp.b;
      const uint32_t slot = fill[self]++;
      model.adj_other[slot] = other;
      model.adj_rest[slot] = sp.rest;
      model.adj_k[slot] = sp.k;
      model.adj_kd[slot] = sp.damping;
      if (stiffens) model.adj_k_stiff[slot] = sp.k_stiff;
      if (model.sew_time > 0) model.adj_rest_start[slot] = sp.rest_start;
    }
  }
  // The implicit integrator's colouring: greedy in vertex order over the springs (a seam partner
  // takes its representative's place, so only representatives are coloured).
  std::vector<uint32_t> color(n, 0xFFFFFFFFu);
  std::vector<uint32_t> used;
  uint32_t colors = 0;
  for (uint32_t i = 0; i < n; ++i) {
    if (!model.alias.empty() && model.alias[i] != i) continue;
    used.assign(colors + 1, 0u);
    for (uint32_t k = model.adj_offset[i]; k < model.adj_offset[i + 1]; ++k) {
      const uint32_t c = color[model.adj_other[k]];
      if (c != 0xFFFFFFFFu) used[c] = 1u;
    }
    uint32_t c = 0;
    while (used[c]) ++c;
    color[i] = c;
    colors = std::max(colors, c + 1);
  }
  model.color_offset.assign(colors + 1, 0u);
  for (uint32_t i = 0; i < n; ++i)
    if (color[i] != 0xFFFFFFFFu) ++model.color_offset[color[i] + 1];
  for (uint32_t c = 0; c < colors; ++c) model.color_offset[c + 1] += model.color_offset[c];
  model.color_vertices.assign(model.color_offset.back(), 0u);
  std::vector<uint32_t> at(model.color_offset.begin(), model.color_offset.end() - 1);
  for (uint32_t i = 0; i < n; ++i)
    if (color[i] != 0xFFFFFFFFu) model.color_vertices[at[color[i]]++] = i;
}

namespace {

// One panel's mesh while the model is built: its rest shape (what the springs and masses keep),
// its placed start positions, and its triangles, in panel-local vertex numbers. Seams may add
// vertices on its boundary before the springs are made.
struct PanelMesh {
  bool grid = false;
  uint32_t nu = 0, nv = 0;                       // grid only
  std::vector<Vec3> rest, placed;
  std::vector<uint32_t> tris;                    // 3 per triangle, counter-clockwise from the front
  std::vector<std::string> segment_names;        // pattern only
  std::vector<std::vector<uint32_t>> segments;   // pattern only: outline paths, kept up to date
  std::vector<uint32_t> obj_to_local;            // mesh only: OBJ vertex number -> ours (UINT32_MAX: unused)
  uint32_t size() const { return uint32_t(rest.size()); }
};

PanelMesh grid_mesh(const PanelDef& pd) {
  PanelMesh pm;
  pm.grid = true;
  pm.nu = uint32_t(pd.resolution_u);
  pm.nv = uint32_t(pd.resolution_v);
  const Transform xf = make_transform(pd.transform);
  for (uint32_t v = 0; v < pm.nv; ++v)
    for (uint32_t u = 0; u < pm.nu; ++u) {
      const Vec3 local = make_vec3((float(u) / float(pm.nu - 1) - 0.5f) * pd.width, 0.0f,
                                   (float(v) / float(pm.nv - 1) - 0.5f) * pd.height);
      pm.placed.push_back(xf.apply(local));
    }
  pm.rest = pm.placed;
  auto at = [&](uint32_t u, uint32_t v) { return v * pm.nu + u; };
  for (uint32_t v = 0; v + 1 < pm.nv; ++v)
    for (uint32_t u = 0; u + 1 < pm.nu; ++u) {
      const uint32_t a = at(u, v), b = at(u + 1, v), c = at(u + 1, v + 1), d = at(u, v + 1);
      pm.tris.insert(pm.tris.end(), {a, d, c, a, c, b});  // counter-clockwise from +y
    }
  return pm;
}

// Every edge used by more than two triangles, or a triangle repeating a corner, is refused: the
// springs and the collision surface need a manifold sheet.
void check_manifold(const std::vector<uint32_t>& tris, const std::function<void(const std::string&)>& fail) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t t = 0; t < tris.size(); t += 3) {
    const uint32_t a = tris[t], b = tris[t + 1], c = tris[t + 2];
    if (a == b || b == c || a == c)
      fail("face " + std::to_string(t / 3 + 1) + " repeats a vertex (" + std::to_string(a) + ", " +
           std::to_string(b) + ", " + std::to_string(c) + ")");
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = tris[t + k], q = tris[t + (k + 1) % 3];
      if (++uses[{std::min(p, q), std::max(p, q)}] > 2)
        fail("edge between vertices " + std::to_string(std::min(p, q)) + " and " + std::to_string(std::max(p, q)) +
             " is shared by more than two faces; a cloth panel must be a manifold sheet");
    }
  }
}

PanelMesh obj_mesh(const SceneDef& s, const PanelDef& pd, const std::string& field) {
  auto fail = [&](const std::string& reason) { throw InputError(s.source, field + "/mesh", "OBJ file '" + pd.mesh_file + "' " + reason); };
  ObjTriangles obj = read_obj_triangles(pd.mesh_file, fail);
  if (obj.indices.empty()) fail("is malformed: it has no faces");
  check_manifold(obj.indices, fail);
  // Vertices no face uses are dropped (an OBJ may carry them); the rest keep their order.
  std::vector<uint32_t> remap(obj.vertices.size(), UINT32_MAX);
  PanelMesh pm;
  const Transform xf = make_transform(pd.transform);
  for (uint32_t i : obj.indices)
    if (remap[i] == UINT32_MAX) remap[i] = 0;
  uint32_t next = 0;
  for (size_t i = 0; i < obj.vertices.size(); ++i)
    if (remap[i] == 0) {
      remap[i] = next++;
      pm.placed.push_back(xf.apply(obj.vertices[i]));
    }
  pm.rest = pm.placed;
  for (uint32_t i : obj.indices) pm.tris.push_back(remap[i]);
  pm.obj_to_local = std::move(remap);  // paths name OBJ vertex numbers
  return pm;
}

PanelMesh pattern_mesh(const SceneDef& s, const PanelDef& pd, const std::string& field) {
  const PatternMesh mesh = mesh_pattern(pd.pattern, [&](const std::string& f, const std::string& reason) {
    throw InputError(s.source, field + "/pattern/" + f, reason);
  });
  PanelMesh pm;
  const Transform xf = make_transform(pd.transform);
  for (const auto& p : mesh.points) {
    pm.rest.push_back(make_vec3(float(p[0]), float(p[1]), 0.0f));
    Vec3 local = pm.rest.back();
    if (pd.pattern.wrap_radius) {
      const double r = *pd.pattern.wrap_radius, a = p[0] / r;
      local = make_vec3(float(r * std::sin(a)), float(p[1]), float(r * std::cos(a)));
    }
    pm.placed.push_back(xf.apply(local));
  }
  pm.tris = mesh.triangles;
  for (const auto& seg : pd.pattern.outline) pm.segment_names.push_back(seg.name);
  pm.segments = mesh.segments;
  return pm;
}

// Local vertex numbers along a path of a panel: a rectangle's edge, a pattern segment, or a mesh
// panel's boundary from OBJ vertex `from` to `to`.
std::vector<uint32_t> panel_path(const SceneDef& s, const PanelDef& pd, const PanelMesh& pm, const EdgeRef& ref,
                                 const std::string& field) {
  auto fail = [&](const std::string& f, const std::string& reason) { throw InputError(s.source, field + f, reason); };
  const int kinds = int(!ref.edge.empty()) + int(!ref.segment.empty()) + int(ref.path.has_value());
  if (kinds != 1) fail("", "needs exactly one of edge, segment or path");
  if (!ref.edge.empty()) {
    if (pd.shape != PanelShape::Rectangle)
      fail("/edge", "panel '" + pd.name + "' is not a rectangle; name an outline segment or a path");
    Piece p;
    p.resolution_u = pm.nu;
    p.resolution_v = pm.nv;
    return edge_vertices(p, ref.edge, s.source, field + "/edge");
  }
  if (!ref.segment.empty()) {
    if (pd.shape != PanelShape::Pattern) fail("/segment", "panel '" + pd.name + "' is not a pattern");
    std::string known;
    for (size_t k = 0; k < pm.segment_names.size(); ++k) {
      if (pm.segment_names[k] == ref.segment) return pm.segments[k];
      if (!pm.segment_names[k].empty()) known += (known.empty() ? "" : ", ") + pm.segment_names[k];
    }
    fail("/segment", "panel '" + pd.name + "' has no segment '" + ref.segment + "' (it has " +
                         (known.empty() ? std::string("no named segments") : known) + ")");
  }
  if (pd.shape != PanelShape::Mesh) fail("/path", "panel '" + pd.name + "' is not a mesh panel");
  const auto [from, to] = *ref.path;
  const auto& obj_to_local = pm.obj_to_local;
  auto local = [&](int v) {
    if (v < 0 || size_t(v) >= obj_to_local.size() || obj_to_local[size_t(v)] == UINT32_MAX)
      fail("/path", "vertex " + std::to_string(v) + " is not a vertex of panel '" + pd.name + "' (its faces use " +
                        std::to_string(pm.size()) + " of " + std::to_string(obj_to_local.size()) + " OBJ vertices)");
    return obj_to_local[size_t(v)];
  };
  const uint32_t a = local(from), b = local(to);
  // The boundary: directed edges p -> q of the triangles whose reverse no triangle has.
  std::set<std::pair<uint32_t, uint32_t>> directed;
  for (size_t t = 0; t < pm.tris.size(); t += 3)
    for (int k = 0; k < 3; ++k) directed.insert({pm.tris[t + k], pm.tris[t + (k + 1) % 3]});
  std::map<uint32_t, uint32_t> next;
  for (const auto& [p, q] : directed)
    if (!directed.count({q, p})) next[p] = q;
  if (!next.count(a)) fail("/path", "vertex " + std::to_string(from) + " is not on the boundary of panel '" + pd.name + "'");
  if (!next.count(b)) fail("/path", "vertex " + std::to_string(to) + " is not on the boundary of panel '" + pd.name + "'");
  std::vector<uint32_t> path{a};
  for (uint32_t v = next[a]; path.size() <= next.size(); v = next[v]) {
    path.push_back(v);
    if (v == b) return path;
    if (!next.count(v) || v == a) break;
  }
  fail("/path", "vertices " + std::to_string(from) + " and " + std::to_string(to) + " are not on one boundary loop of panel '" + pd.name + "'");
  return {};
}

// Splits the boundary edge a-b at fraction t (from a): a new vertex on the edge, the one triangle
// holding the edge split in two, and every stored outline path through a-b updated.
uint32_t split_boundary_edge(PanelMesh& pm, uint32_t a, uint32_t b, float t) {
  const uint32_t m = pm.size();
  pm.rest.push_back(pm.rest[a] + (pm.rest[b] - pm.rest[a]) * t);
  pm.placed.push_back(pm.placed[a] + (pm.placed[b] - pm.placed[a]) * t);
  for (size_t tri = 0; tri < pm.tris.size(); tri += 3)
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = pm.tris[tri + k], q = pm.tris[tri + (k + 1) % 3], r = pm.tris[tri + (k + 2) % 3];
      if ((p == a && q == b) || (p == b && q == a)) {
        pm.tris[tri + 0] = p, pm.tris[tri + 1] = m, pm.tris[tri + 2] = r;
        pm.tris.insert(pm.tris.end(), {m, q, r});
        goto split;
      }
    }
  throw std::logic_error("split_boundary_edge: no triangle holds the edge");
split:
  for (auto& path : pm.segments) {
      for (size_t i = 0; i + 1 < path.size(); ++i)
        if ((path[i] == a && path[i + 1] == b) || (path[i] == b && path[i + 1] == a)) {
          path.insert(path.begin() + std::ptrdiff_t(i) + 1, m);
          break;
        }
  }
  return m;
}

// Fractions of arc length (rest shape) along a path, 0 at its start and 1 at its end.
std::vector<double> arc_fractions(const PanelMesh& pm, const std::vector<uint32_t>& path) {
  std::vector<double> s(path.size(), 0.0);
  for (size_t i = 1; i < path.size(); ++i) s[i] = s[i - 1] + double(length(pm.rest[path[i]] - pm.rest[path[i - 1]]));
  const double total = s.back();
  for (double& x : s) x = total > 0 ? x / total : 0.0;
  return s;
}

}  // namespace

ClothModel build_cloth_model(const SceneDef& s) {
  ClothModel m;
  if (s.panels.empty()) throw InputError(s.source, "/panels", "the scene has no cloth panels");
  std::vector<PanelMesh> meshes;
  for (size_t pi = 0; pi < s.panels.size(); ++pi) {
    const PanelDef& pd = s.panels[pi];
    const std::string field = "/panels/" + std::to_string(pi);
    find_material(s, pd.material, pi);
    switch (pd.shape) {
      case PanelShape::Rectangle:
        if (pd.resolution_u < 2 || pd.resolution_v < 2)
          throw InputError(s.source, field + "/resolution", "must be at least 2 x 2");
        meshes.push_back(grid_mesh(pd));
        break;
      case PanelShape::Mesh: meshes.push_back(obj_mesh(s, pd, field)); break;
      case PanelShape::Pattern: meshes.push_back(pattern_mesh(s, pd, field)); break;
    }
  }

  // Seams: the two paths matched vertex to vertex (by arc length when their counts differ, adding
  // vertices to pattern and mesh panels); each pair is welded into one vertex below, or stitched.
  std::vector<std::array<std::pair<size_t, uint32_t>, 2>> pairs;  // (panel, local vertex) x 2
  std::vector<uint32_t> pair_seam;                                 // the seam of each pair
  for (size_t si = 0; si < s.seams.size(); ++si) {
    const auto tag = [&] { pair_seam.resize(pairs.size(), uint32_t(si)); };
    const SeamDef& sd = s.seams[si];
    const std::string field = "/seams/" + std::to_string(si);
    const size_t ia = find_panel(s, sd.a.panel, field + "/a/panel"), ib = find_panel(s, sd.b.panel, field + "/b/panel");
    PanelMesh &ma = meshes[ia], &mb = meshes[ib];
    std::vector<uint32_t> ea = panel_path(s, s.panels[ia], ma, sd.a, field + "/a");
    std::vector<uint32_t> eb = panel_path(s, s.panels[ib], mb, sd.b, field + "/b");
    if (sd.reverse) std::reverse(eb.begin(), eb.end());
    auto name = [&](const EdgeRef& r) {
      if (!r.edge.empty()) return "edge '" + r.edge + "' of panel '" + r.panel + "'";
      if (!r.segment.empty()) return "segment '" + r.segment + "' of panel '" + r.panel + "'";
      return "path " + std::to_string((*r.path)[0]) + "-" + std::to_string((*r.path)[1]) + " of panel '" + r.panel + "'";
    };
    if (ea.size() != eb.size() && (ma.grid || mb.grid))
      throw InputError(s.source, field,
                       name(sd.a) + " has " + std::to_string(ea.size()) + " vertices but " + name(sd.b) + " has " +
                           std::to_string(eb.size()) + (ma.grid && mb.grid ? "" : "; a rectangle's edge is not resampled, give both the same count"));
    if (ea.size() == eb.size()) {
      for (size_t k = 0; k < ea.size(); ++k) pairs.push_back({{{ia, ea[k]}, {ib, eb[k]}}});
      tag();
      continue;
    }
    // Walk both paths by arc length: vertices closer than a quarter of the local spacing pair up;
    // any other vertex gets a partner inserted on the other path's edge at the same fraction.
    const std::vector<double> sa = arc_fractions(ma, ea), sb = arc_fractions(mb, eb);
    pairs.push_back({{{ia, ea.front()}, {ib, eb.front()}}});
    size_t i = 1, j = 1;
    uint32_t prev_a = ea.front(), prev_b = eb.front();
    double sprev_a = 0, sprev_b = 0;
    const size_t na = ea.size() - 1, nb = eb.size() - 1;
    while (i < na || j < nb) {
      const double fa = i < na ? sa[i] : 1.0, fb = j < nb ? sb[j] : 1.0;
      auto spacing = [](const std::vector<double>& f, size_t k, size_t last) {
        return std::min(f[k] - f[k - 1], k < last ? f[k + 1] - f[k] : 1.0);
      };
      const double tol = 0.25 * std::min(spacing(sa, i, na), spacing(sb, j, nb));
      if (i < na && j < nb && std::abs(fa - fb) <= tol) {
        pairs.push_back({{{ia, ea[i]}, {ib, eb[j]}}});
        prev_a = ea[i], prev_b = eb[j], sprev_a = fa, sprev_b = fb;
        ++i, ++j;
      } else if (fa < fb) {
        const uint32_t nbv = split_boundary_edge(mb, prev_b, eb[j], float((fa - sprev_b) / (sb[j] - sprev_b)));
        pairs.push_back({{{ia, ea[i]}, {ib, nbv}}});
        prev_a = ea[i], prev_b = nbv, sprev_a = fa, sprev_b = fa;
        ++i;
      } else {
        const uint32_t nav = split_boundary_edge(ma, prev_a, ea[i], float((fb - sprev_a) / (sa[i] - sprev_a)));
        pairs.push_back({{{ia, nav}, {ib, eb[j]}}});
        prev_a = nav, prev_b = eb[j], sprev_a = fb, sprev_b = fb;
        ++j;
      }
    }
    pairs.push_back({{{ia, ea.back()}, {ib, eb.back()}}});
    tag();
  }

  // The panels one after another: vertices, masses, triangles, springs.
  for (size_t pi = 0; pi < s.panels.size(); ++pi) {
    const PanelDef& pd = s.panels[pi];
    const MaterialDef& mat = find_material(s, pd.material, pi);
    const PanelMesh& pm = meshes[pi];
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
        const fabric::MeasuredGrid g = fabric::measured_grid(data->data, density, hx, hy, warp);
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
        double k_stiff = 0;
      };
      // A measured fabric's stretch springs, fitted triangle by triangle to its warp and weft.
      const Vec3 warp_dir = pd.shape == PanelShape::Mesh ? make_vec3(float(std::cos(warp)), 0.0f, float(-std::sin(warp)))
                                                         : make_vec3(float(std::cos(warp)), float(std::sin(warp)), 0.0f);
      std::map<std::pair<uint32_t, uint32_t>, std::array<double, 2>> data_stretch;
      if (data && !mat.stretch_set) data_stretch = fabric::measured_mesh_stretch(data->data, pm.rest, pm.tris, warp_dir);
      std::vector<Planned> planned;
      double stretch_trace = 0, bend_trace = 0;  // sum of k l^2 over each kind: their in-plane stiffness
      for (const auto& [e, opp] : opposite) {
        const double area = edge_area[e];
        const double l = length(pm.rest[e.second] - pm.rest[e.first]);
        const double ks = data && !mat.stretch_set       ? data_stretch[e][0]
                          : measured && !mat.stretch_set ? fabric::edge_stretch(c, area, l) : double(mat.stretch);
        planned.push_back({e.first, e.second, ks, SpringType::Stretch, data && !mat.stretch_set ? data_stretch[e][1] : 0.0});
        stretch_trace += ks * l * l;
        if (opp.size() == 2 && opp[0] != opp[1]) {
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
      for (const Planned& sp : planned)
        spring(sp.a, sp.b, float(sp.type == SpringType::Stretch ? sp.k * (1.0 - give) : sp.k), sp.type, float(sp.k_stiff * (1.0 - give)));
    }
    for (uint32_t i = 0; i < pm.size(); ++i) {
      m.inv_mass.push_back(1.0f / m.mass[base + i]);
      m.damping.push_back(mat.damping);
    }
    p.num_triangles = m.num_triangles() - p.first_triangle;
    m.pieces.push_back(p);
  }

  // Welded seams join their pairs into one vertex (weld_seams below); sewn ones get a stitch, a spring
  // of rest length 0 whose rest length eases from the pair's start distance while the seams close.
  std::vector<uint32_t> parent(m.num_vertices());
  std::iota(parent.begin(), parent.end(), 0u);
  std::set<std::pair<uint32_t, uint32_t>> stitched;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const auto& pr = pairs[k];
    const uint32_t ga = m.pieces[pr[0].first].first_vertex + pr[0].second;
    const uint32_t gb = m.pieces[pr[1].first].first_vertex + pr[1].second;
    const SeamDef& sd = s.seams[pair_seam[k]];
    // A pair that starts closed is welded, as a seam of panels placed edge to edge always was: within
    // the thickness of each other, or each on the other side's path (the two paths lying on each
    // other with their vertices matched a spacing apart: sewn, they would start at distance 0 from
    // the other side's edges, where the displacement bound leaves them no room to move).
    auto placed = [&](const std::pair<size_t, uint32_t>& v) { return meshes[v.first].placed[v.second]; };
    auto near_side = [&](Vec3 p, int side) {
      for (size_t j = k; j < pairs.size() && pair_seam[j] == pair_seam[k]; ++j)
        if (j + 1 < pairs.size() && pair_seam[j + 1] == pair_seam[k] &&
            segment_distance(p, placed(pairs[j][side]), placed(pairs[j + 1][side])) <= s.collision.thickness)
          return true;
      for (size_t j = k; j-- > 0 && pair_seam[j] == pair_seam[k];)
        if (segment_distance(p, placed(pairs[j][side]), placed(pairs[j + 1][side])) <= s.collision.thickness) return true;
      return false;
    };
    const bool closed = length(placed(pr[0]) - placed(pr[1])) <= s.collision.thickness ||
                        (near_side(placed(pr[0]), 1) && near_side(placed(pr[1]), 0));
    if (closed || sd.weld_at_start.value_or(s.sewing.weld_at_start)) {
      const uint32_t ra = find_root(parent, ga), rb = find_root(parent, gb);
      parent[std::max(ra, rb)] = std::min(ra, rb);
    } else if (ga != gb && stitched.insert({std::min(ga, gb), std::max(ga, gb)}).second) {
      const MaterialDef& mat = find_material(s, s.panels[pr[0].first].material, pr[0].first);
      m.springs.push_back({ga, gb, 0.0f, sd.stiffness, mat.spring_damping, SpringType::Seam});
      m.stitches.insert(m.stitches.end(), {ga, gb});
      m.stitch_seam.push_back(pair_seam[k]);
    }
  }
  m.alias.resize(m.num_vertices());
  for (uint32_t i = 0; i < m.num_vertices(); ++i) m.alias[i] = find_root(parent, i);
  // A [first, last] range of a panel's vertices (pins and attachments), as global vertex ids.
  auto range_ids = [&](const Piece& p, std::array<int, 2> range, const std::string& field) {
    const auto [first, last] = range;
    if (first < 0 || last < first || uint32_t(last) >= p.num_vertices())
      throw InputError(s.source, field,
                       "range [" + std::to_string(first) + ", " + std::to_string(last) + "] is outside panel '" + p.name +
                           "' (vertices 0 to " + std::to_string(p.num_vertices() - 1) + ")");
    std::vector<uint32_t> ids;
    for (int i = first; i <= last; ++i) ids.push_back(p.first_vertex + uint32_t(i));
    return ids;
  };
  // Pins.
  for (size_t pi = 0; pi < s.pins.size(); ++pi) {
    const PinDef& pd = s.pins[pi];
    const std::string field = "/pins/" + std::to_string(pi);
    const size_t panel = find_panel(s, pd.panel, field + "/panel");
    const Piece& p = m.pieces[panel];
    std::vector<uint32_t> ids;
    if (!pd.corner.empty()) {
      if (p.resolution_u == 0)
        throw InputError(s.source, field + "/corner", "panel '" + p.name + "' is not a rectangle; pin a segment or a range");
      const uint32_t nu = p.resolution_u, nv = p.resolution_v;
      const std::string& c = pd.corner;
      uint32_t u, v;
      if (c == "bottom_left") u = 0, v = 0;
      else if (c == "bottom_right") u = nu - 1, v = 0;
      else if (c == "top_left") u = 0, v = nv - 1;
      else if (c == "top_right") u = nu - 1, v = nv - 1;
      else
        throw InputError(s.source, field + "/corner",
                         "unknown corner '" + c + "' (expected bottom_left, bottom_right, top_left or top_right)");
      ids.push_back(p.first_vertex + v * nu + u);
    } else if (!pd.edge.empty() || !pd.segment.empty()) {
      EdgeRef ref{pd.panel, pd.edge, pd.segment, std::nullopt};
      for (uint32_t i : panel_path(s, s.panels[panel], meshes[panel], ref, field)) ids.push_back(p.first_vertex + i);
    } else if (pd.range) {
      ids = range_ids(p, *pd.range, field + "/range");
    } else {
      throw InputError(s.source, field, "a pin needs one of corner, edge, segment or range");
    }
    for (uint32_t id : ids) m.inv_mass[id] = 0.0f;
  }
  // What attachments name, kept for resolve_attachments (which needs the obstacles too).
  for (size_t ai = 0; ai < s.attachments.size(); ++ai) {
    const AttachmentDef& ad = s.attachments[ai];
    const std::string field = "/attachments/" + std::to_string(ai);
    const size_t panel = find_panel(s, ad.panel, field + "/panel");
    const Piece& p = m.pieces[panel];
    std::vector<uint32_t> ids;
    if (ad.range) {
      if (!ad.edge.empty() || !ad.segment.empty())
        throw InputError(s.source, field, "needs exactly one of edge, segment or range");
      ids = range_ids(p, *ad.range, field + "/range");
    } else {
      EdgeRef ref{ad.panel, ad.edge, ad.segment, std::nullopt};
      for (uint32_t i : panel_path(s, s.panels[panel], meshes[panel], ref, field)) ids.push_back(p.first_vertex + i);
    }
    m.attachment_vertices.push_back(std::move(ids));
  }

  // Sew groups: welded partners and stitched pairs, each group named by its smallest vertex.
  if (!m.stitches.empty()) {
    std::vector<uint32_t> group(m.num_vertices());
    for (uint32_t i = 0; i < m.num_vertices(); ++i) group[i] = find_root(parent, i);
    for (size_t k = 0; k + 1 < m.stitches.size(); k += 2) {
      const uint32_t ra = find_root(group, m.stitches[k]), rb = find_root(group, m.stitches[k + 1]);
      group[std::max(ra, rb)] = std::min(ra, rb);
    }
    m.sew_group.resize(m.num_vertices());
    for (uint32_t i = 0; i < m.num_vertices(); ++i) m.sew_group[i] = find_root(group, i);
  }
  weld_seams(m);
  for (uint32_t& v : m.stitches) v = m.alias[v];
  // Rest lengths at the placed start (after welding): where the springs start when seams close
  // over time (scene.sewing.close_time).
  if (s.sewing.close_time > 0) {
    for (Spring& sp : m.springs) sp.rest_start = length(m.initial_positions[sp.b] - m.initial_positions[sp.a]);
    m.sew_time = float(s.sewing.close_time);
    m.ease_gravity = s.sewing.ease_gravity.value_or(!m.stitches.empty());
  }
  build_adjacency(m);
  return m;
}

void resolve_attachments(ClothModel& m, const ObstacleSet& obstacles, const SceneDef& s) {
  m.attach_slot.clear(), m.attach_tri.clear(), m.attach_bary.clear(), m.attach_offset.clear();
  m.attach_lift.clear(), m.attach_k.clear(), m.attach_kd.clear();
  if (s.attachments.empty()) return;
  m.attach_slot.assign(m.num_vertices(), kNoAttachment);
  std::vector<Vec3> ox, ov;
  obstacles.pose_at(0.0, ox, ov);
  const auto& idx = obstacles.world.indices;
  for (size_t ai = 0; ai < s.attachments.size(); ++ai) {
    const AttachmentDef& ad = s.attachments[ai];
    const std::string field = "/attachments/" + std::to_string(ai);
    size_t oi = obstacles.names.size();
    std::string known;
    for (size_t k = 0; k < obstacles.names.size(); ++k) {
      if (obstacles.names[k] == ad.obstacle) oi = k;
      known += (known.empty() ? "" : ", ") + ("'" + obstacles.names[k] + "'");
    }
    if (oi == obstacles.names.size())
      throw InputError(s.source, field + "/obstacle",
                       "unknown obstacle '" + ad.obstacle + "' (the scene has " + (known.empty() ? "none" : known) + ")");
    const uint32_t t0 = obstacles.first_triangle[oi];
    const uint32_t t1 = obstacles.end_triangle(oi);
    const uint32_t v0 = obstacles.first_vertex[oi], nv = uint32_t(obstacles.local[oi].vertices.size());
    const std::vector<uint32_t>& cloth = m.attachment_vertices[ai];
    if (!ad.obstacle_vertices.empty() && ad.obstacle_vertices.size() != cloth.size())
      throw InputError(s.source, field + "/obstacle_vertices",
                       "has " + std::to_string(ad.obstacle_vertices.size()) + " vertices but the attached cloth path has " +
                           std::to_string(cloth.size()));
    for (size_t k = 0; k < cloth.size(); ++k) {
      const uint32_t ci = m.alias[cloth[k]];
      if (m.attach_slot[ci] != kNoAttachment) continue;  // seam partners, or named twice: the first wins
      uint32_t tri = t0;
      Vec3 bary = make_vec3(1, 0, 0);
      if (!ad.obstacle_vertices.empty()) {
        const int bv = ad.obstacle_vertices[k];
        if (bv < 0 || uint32_t(bv) >= nv)
          throw InputError(s.source, field + "/obstacle_vertices/" + std::to_string(k),
                           "vertex " + std::to_string(bv) + " is outside obstacle '" + ad.obstacle + "' (vertices 0 to " +
                               std::to_string(nv - 1) + ")");
        bool found = false;
        for (uint32_t t = t0; t < t1 && !found; ++t)
          for (int c = 0; c < 3 && !found; ++c)
            if (idx[3 * t + c] == v0 + uint32_t(bv)) {
              tri = t, found = true;
              bary = make_vec3(c == 0, c == 1, c == 2);
            }
        if (!found)
          throw InputError(s.source, field + "/obstacle_vertices/" + std::to_string(k),
                           "vertex " + std::to_string(bv) + " of obstacle '" + ad.obstacle + "' is on no triangle");
      } else {
        // The nearest point of the obstacle's surface to the cloth vertex at the start.
        const Vec3 p = m.initial_positions[ci];
        double best = INFINITY;
        for (uint32_t t = t0; t < t1; ++t) {
          const Vec3 a = ox[idx[3 * t]], b = ox[idx[3 * t + 1]], c = ox[idx[3 * t + 2]];
          auto d3 = [](Vec3 v) { return DVec3{double(v.x), double(v.y), double(v.z)}; };
          const TrianglePoint q = closest_on_triangle(d3(p), d3(a), d3(b), d3(c));
          if (q.dist2 < best) best = q.dist2, tri = t, bary = make_vec3(float(q.wa), float(q.wb), float(q.wc));
        }
      }
      // The damping is explicit too: past 2 m / dt it overshoots and grows.
      // (The implicit integrator takes the damping into its solve: stable at any dt.)
      const double damping_limit = 2.0 * double(m.mass[ci]) / s.time.dt;
      if (s.time.integrator == Integrator::Explicit && double(ad.damping) >= damping_limit)
        throw InputError(s.source, field + "/damping",
                         fmt::format("{:g} N s/m is unstable at dt = {:g} s on an attached vertex of {:g} kg; "
                                     "keep it below 2 m / dt = {:g}",
                                     double(ad.damping), s.time.dt, double(m.mass[ci]), damping_limit));
      m.attach_slot[ci] = uint32_t(m.attach_tri.size());
      m.attach_tri.push_back(tri);
      m.attach_bary.push_back(bary);
      {
        const Vec3 a = ox[idx[3 * tri]], b = ox[idx[3 * tri + 1]], c = ox[idx[3 * tri + 2]];
        const Vec3 target = a * bary.x + b * bary.y + c * bary.z + triangle_normal(ox.data(), idx.data(), tri) * ad.lift;
        // With seams closing over time the pull starts where the vertex is and eases onto the body.
        m.attach_offset.push_back(m.sew_time > 0 ? m.initial_positions[ci] - target : make_vec3(0, 0, 0));
      }
      m.attach_lift.push_back(ad.lift);
      m.attach_k.push_back(ad.stiffness);
      m.attach_kd.push_back(ad.damping);
    }
  }
}

ObstacleSet build_obstacles(const SceneDef& s) {
  ObstacleSet set;
  for (size_t oi = 0; oi < s.obstacles.size(); ++oi) {
    const ObstacleDef& od = s.obstacles[oi];
    const std::string field = "/obstacles/" + std::to_string(oi);
    TriMesh local;
    std::shared_ptr<const SkinnedMesh> skinned;
    switch (od.type) {
      case ObstacleType::UvSphere: local = make_uv_sphere(od.radius, od.slices, od.stacks); break;
      case ObstacleType::Box: local = make_box(to_vec3(od.size)); break;
      case ObstacleType::Plane: local = make_plane(to_vec3(od.size)); break;
      case ObstacleType::Mesh: local = load_obj_mesh(od.file, s.source, field + "/file"); break;
      case ObstacleType::Skinned: {
        auto mesh = std::make_shared<SkinnedMesh>(load_skinned_mesh(
            od.file, od.animation,
            [&](const std::string& f, const std::string& reason) { throw InputError(s.source, field + "/" + f, reason); }));
        local.indices = mesh->indices;
        mesh->skin(mesh->joint_matrices(mesh->sample(0, 0)), local.vertices);  // the rest pose
        skinned = std::move(mesh);
        break;
      }
    }
    const Transform xf = make_transform(od.transform);
    set.names.push_back(od.name);
    set.first_vertex.push_back(uint32_t(set.world.vertices.size()));
    set.first_triangle.push_back(uint32_t(set.world.num_triangles()));
    const uint32_t base = uint32_t(set.world.vertices.size());
    for (const Vec3& v : local.vertices) set.world.vertices.push_back(xf.apply(v));
    for (uint32_t i : local.indices) set.world.indices.push_back(base + i);
    set.local.push_back(std::move(local));
    set.defs.push_back(od);
    if (od.motion || skinned) set.any_moving = true;
    set.skinned.push_back(std::move(skinned));
  }
  set.collision_indices = set.world.indices;
  for (size_t oi = 0; oi < set.defs.size(); ++oi) {
    const ObstacleDef& od = set.defs[oi];
    if (!od.close_holes || !(od.type == ObstacleType::Mesh || od.type == ObstacleType::Skinned)) continue;
    // On the rest pose in world space: the same loops at every pose, since the caps reuse the loops'
    // own vertices.
    const uint32_t base = set.first_vertex[oi];
    const TriMesh& local = set.local[oi];
    const HoleCaps caps = cap_holes(local.vertices, local.indices, kHoleMaxShare);
    for (uint32_t v : caps.indices) set.collision_indices.push_back(base + v);
    set.holes_found += caps.loops;
    set.holes_capped += caps.capped;
  }
  set.cap_triangles = uint32_t(set.collision_indices.size() - set.world.indices.size()) / 3u;
  return set;
}

namespace {

// The animation time of a skinned obstacle at simulated time t, and how far the pose has blended
// from the rest pose into the animation.
std::pair<float, float> animation_time(const ObstacleDef& od, const SkinnedMesh& m, double t) {
  if (od.hold > 0) {
    if (t < od.hold) return {float(od.offset.value_or(m.start)), 0.0f};  // the rest pose
    t -= od.hold;
  }
  double a = od.offset.value_or(m.start) + double(od.speed) * t;
  const double span = double(m.end) - double(m.start);
  if (od.loop && span > 0) a = m.start + std::fmod(std::fmod(a - m.start, span) + span, span);
  double blend = 1.0;
  if (od.blend_in > 0 && t < od.blend_in) {
    const double u = std::max(0.0, t / od.blend_in);
    blend = u * u * (3 - 2 * u);  // smoothstep: no jolt at either end
  }
  return {float(a), float(blend)};
}

}  // namespace

void ObstacleSet::skinned_joints(size_t oi, double t, std::vector<Affine>& pose, std::vector<Affine>& rate) const {
  const SkinnedMesh& m = *skinned[oi];
  const Transform xf = make_transform(defs[oi].transform);
  Affine world;  // the obstacle's transform: rotation times scale, then translation
  const Vec3 rows[3] = {xf.rotation.r0, xf.rotation.r1, xf.rotation.r2};
  const float scale[3] = {xf.scale.x, xf.scale.y, xf.scale.z}, move[3] = {xf.translation.x, xf.translation.y, xf.translation.z};
  for (int i = 0; i < 3; ++i) {
    const float r[3] = {rows[i].x, rows[i].y, rows[i].z};
    for (int j = 0; j < 3; ++j) world.m[4 * i + j] = r[j] * scale[j];
    world.m[4 * i + 3] = move[i];
  }
  auto joints_at = [&](double time) {
    const auto [a, blend] = animation_time(defs[oi], m, time);
    std::vector<Affine> j = m.joint_matrices(m.sample(a, blend, defs[oi].loop));
    for (Affine& x : j) x = affine_multiply(world, x);
    return j;
  };
  pose = joints_at(t);
  const double h = 5e-4, t0 = std::max(0.0, t - h), t1 = t + h;
  const std::vector<Affine> a = joints_at(t0), b = joints_at(t1);
  const float inv = float(1.0 / (t1 - t0));
  rate.resize(pose.size());
  for (size_t j = 0; j < pose.size(); ++j)
    for (int k = 0; k < 12; ++k) rate[j].m[k] = (b[j].m[k] - a[j].m[k]) * inv;
}

void ObstacleSet::pose_at(double t, std::vector<Vec3>& vertices, std::vector<Vec3>& velocities) const {
  vertices = world.vertices;
  velocities.assign(vertices.size(), make_vec3(0, 0, 0));
  std::vector<Affine> pose, rate;
  for (size_t oi = 0; oi < defs.size(); ++oi) {
    if (skinned[oi]) {
      skinned_joints(oi, t, pose, rate);
      const std::vector<SkinnedVertex>& sv = skinned[oi]->vertices;
      const size_t first = first_vertex[oi];
      for (size_t i = 0; i < sv.size(); ++i)
        skin_obstacle_vertex(pose.data(), rate.data(), sv[i], vertices[first + i], velocities[first + i]);
      continue;
    }
    if (!defs[oi].motion) continue;
    const MotionDef& mo = *defs[oi].motion;
    const bool moving = t >= mo.start;
    const Transform xf = make_transform(transform_at(defs[oi], t));
    const Vec3 omega = to_vec3(mo.angular_velocity) * float(M_PI / 180.0);
    for (size_t i = 0; i < local[oi].vertices.size(); ++i) {
      const size_t gi = first_vertex[oi] + i;
      vertices[gi] = xf.apply(local[oi].vertices[i]);
      if (moving) velocities[gi] = to_vec3(mo.velocity) + cross(omega, vertices[gi] - xf.translation);
    }
  }
  for (size_t oi = 0; oi < scripted.size(); ++oi) {
    const Scripted& s = scripted[oi];
    if (s.to.empty()) continue;
    const bool moving = t > s.t0 && t <= s.t1;  // the velocity of the move, up to its end
    const float u = t >= s.t1 ? 1.0f : t > s.t0 ? float((t - s.t0) / (s.t1 - s.t0)) : 0.0f;
    const float inv_duration = float(1.0 / (s.t1 - s.t0));
    for (size_t i = 0; i < s.to.size(); ++i) {
      const size_t gi = first_vertex[oi] + i;
      const Vec3 d = s.to[i] - s.from[i];
      vertices[gi] = u == 1.0f ? s.to[i] : s.from[i] + d * u;
      velocities[gi] = moving ? d * inv_duration : make_vec3(0, 0, 0);
    }
  }
}

}  // namespace raycloth

namespace raycloth {

double ObstacleSet::max_speed(double duration, double every) const {
  if (!any_moving) return 0.0;
  std::vector<Vec3> x, v;
  double fastest = 0.0;
  const long samples = std::max(1L, long(std::ceil(duration / every)));
  for (long k = 0; k <= samples; ++k) {
    pose_at(std::min(duration, double(k) * every), x, v);
    for (const Vec3& u : v) fastest = std::max(fastest, double(length(u)));
  }
  return fastest;
}

}  // namespace raycloth
