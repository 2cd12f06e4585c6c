// Each panel's mesh while the model is built (a rectangle's grid, an OBJ mesh, a pattern meshed in
// 2D), the paths along their edges, and the seams' point pairs matched along those paths.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>

#include "collide/holes.h"
#include "raycloth/error.h"
#include "scene/pattern.h"
#include "scene/transform.h"
#include "sim/model_build.h"

namespace raycloth {

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

namespace {

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

}  // namespace

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

namespace {

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

std::vector<PanelMesh> mesh_panels(const SceneDef& s) {
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
  return meshes;
}

SeamPairs pair_seams(const SceneDef& s, std::vector<PanelMesh>& meshes) {
  SeamPairs out;
  auto& pairs = out.pairs;
  auto& pair_seam = out.seam;
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
    // A pattern segment merged into a point (scene/pattern.h) against a path: the point is sewn to
    // both of its ends.
    if (ea.size() == 1 || eb.size() == 1) {
      const std::vector<uint32_t>& one = ea.size() == 1 ? ea : eb;
      const std::vector<uint32_t>& other = ea.size() == 1 ? eb : ea;
      for (uint32_t v : {other.front(), other.back()}) {
        if (ea.size() == 1) pairs.push_back({{{ia, one[0]}, {ib, v}}});
        else pairs.push_back({{{ia, v}, {ib, one[0]}}});
      }
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
  return out;
}

}  // namespace raycloth
