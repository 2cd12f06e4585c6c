#include "sim/model.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "raycloth/error.h"
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

uint32_t find_root(std::vector<uint32_t>& parent, uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// Makes each seam group one simulated vertex: the group meets at its centroid, its representative
// carries the group's mass (pinned if any member is) and every spring, and the other members follow
// it (inv_mass 0, mass 0, copied at the end of each step). Triangles and edges use representatives.
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

}  // namespace

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
  v.alias = alias.data();
  v.triangles = collision_triangles.data();
  v.tri_alias = tri_alias.data();
  v.edges = edges.data();
  v.num_edges = num_edges();
  v.num_triangles = num_collision_triangles();
  v.tri_edge_owner = tri_edge_owner.data();
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
  for (const auto& s : springs) k = std::max(k, s.k);
  return k;
}

double ClothModel::natural_period() const {
  const double k = max_stiffness();
  return k > 0 ? M_PI * std::sqrt(double(min_mass()) / k) : INFINITY;
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
  std::vector<uint32_t> fill(model.adj_offset.begin(), model.adj_offset.end() - 1);
  for (const auto& sp : model.springs) {
    for (int side = 0; side < 2; ++side) {
      const uint32_t self = side ? sp.b : sp.a, other = side ? sp.a : sp.b;
      const uint32_t slot = fill[self]++;
      model.adj_other[slot] = other;
      model.adj_rest[slot] = sp.rest;
      model.adj_k[slot] = sp.k;
      model.adj_kd[slot] = sp.damping;
    }
  }
}

ClothModel build_cloth_model(const SceneDef& s) {
  ClothModel m;
  if (s.panels.empty()) throw InputError(s.source, "/panels", "the scene has no cloth panels");
  // Panels: vertices, masses, triangles and the grid springs of the paper (Fig. 1).
  for (size_t pi = 0; pi < s.panels.size(); ++pi) {
    const PanelDef& pd = s.panels[pi];
    const std::string field = "/panels/" + std::to_string(pi);
    const MaterialDef& mat = find_material(s, pd.material, pi);
    if (pd.resolution_u < 2 || pd.resolution_v < 2)
      throw InputError(s.source, field + "/resolution", "must be at least 2 x 2");
    Piece p;
    p.name = pd.name;
    p.first_vertex = m.num_vertices();
    p.resolution_u = uint32_t(pd.resolution_u);
    p.resolution_v = uint32_t(pd.resolution_v);
    p.first_triangle = m.num_triangles();
    const Transform xf = make_transform(pd.transform);
    const uint32_t nu = p.resolution_u, nv = p.resolution_v;
    const float vertex_mass = mat.density * pd.width * pd.height / float(nu * nv);
    for (uint32_t v = 0; v < nv; ++v)
      for (uint32_t u = 0; u < nu; ++u) {
        const Vec3 local = make_vec3((float(u) / float(nu - 1) - 0.5f) * pd.width, 0.0f,
                                     (float(v) / float(nv - 1) - 0.5f) * pd.height);
        m.initial_positions.push_back(xf.apply(local));
        m.mass.push_back(vertex_mass);
        m.inv_mass.push_back(1.0f / vertex_mass);
        m.damping.push_back(mat.damping);
      }
    auto at = [&](uint32_t u, uint32_t v) { return p.first_vertex + v * nu + u; };
    auto spring = [&](uint32_t a, uint32_t b, float k, SpringType t) {
      const float rest = length(m.initial_positions[b] - m.initial_positions[a]);
      m.springs.push_back({a, b, rest, k, mat.spring_damping, t});
    };
    for (uint32_t v = 0; v < nv; ++v)
      for (uint32_t u = 0; u < nu; ++u) {
        if (u + 1 < nu) spring(at(u, v), at(u + 1, v), mat.stretch, SpringType::Stretch);
        if (v + 1 < nv) spring(at(u, v), at(u, v + 1), mat.stretch, SpringType::Stretch);
        if (u + 1 < nu && v + 1 < nv) {
          spring(at(u, v), at(u + 1, v + 1), mat.shear, SpringType::Shear);
          spring(at(u + 1, v), at(u, v + 1), mat.shear, SpringType::Shear);
        }
        if (u + 2 < nu) spring(at(u, v), at(u + 2, v), mat.bend, SpringType::Bend);
        if (v + 2 < nv) spring(at(u, v), at(u, v + 2), mat.bend, SpringType::Bend);
        if (u + 1 < nu && v + 1 < nv) {
          const uint32_t a = at(u, v), b = at(u + 1, v), c = at(u + 1, v + 1), d = at(u, v + 1);
          m.triangles.insert(m.triangles.end(), {a, d, c, a, c, b});  // counter-clockwise from +y
        }
      }
    p.num_triangles = m.num_triangles() - p.first_triangle;
    m.pieces.push_back(p);
  }

  // Seams: matched boundary vertices are welded into one vertex (the smallest index of each group
  // represents it), so the triangles on both sides share it and no gap or overlap can open there.
  std::vector<uint32_t> parent(m.num_vertices());
  std::iota(parent.begin(), parent.end(), 0u);
  for (size_t si = 0; si < s.seams.size(); ++si) {
    const SeamDef& sd = s.seams[si];
    const std::string field = "/seams/" + std::to_string(si);
    const Piece& pa = m.pieces[find_panel(s, sd.a.panel, field + "/a/panel")];
    const Piece& pb = m.pieces[find_panel(s, sd.b.panel, field + "/b/panel")];
    auto ea = edge_vertices(pa, sd.a.edge, s.source, field + "/a/edge");
    auto eb = edge_vertices(pb, sd.b.edge, s.source, field + "/b/edge");
    if (ea.size() != eb.size())
      throw InputError(s.source, field,
                       "edge '" + sd.a.edge + "' of panel '" + sd.a.panel + "' has " + std::to_string(ea.size()) +
                           " vertices but edge '" + sd.b.edge + "' of panel '" + sd.b.panel + "' has " +
                           std::to_string(eb.size()));
    if (sd.reverse) std::reverse(eb.begin(), eb.end());
    for (size_t k = 0; k < ea.size(); ++k) {
      const uint32_t ra = find_root(parent, ea[k]), rb = find_root(parent, eb[k]);
      parent[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  m.alias.resize(m.num_vertices());
  for (uint32_t i = 0; i < m.num_vertices(); ++i) m.alias[i] = find_root(parent, i);
  // Pins.
  for (size_t pi = 0; pi < s.pins.size(); ++pi) {
    const PinDef& pd = s.pins[pi];
    const std::string field = "/pins/" + std::to_string(pi);
    const Piece& p = m.pieces[find_panel(s, pd.panel, field + "/panel")];
    std::vector<uint32_t> ids;
    if (!pd.corner.empty()) {
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
    } else if (!pd.edge.empty()) {
      ids = edge_vertices(p, pd.edge, s.source, field + "/edge");
    } else if (pd.range) {
      const auto [first, last] = *pd.range;
      if (first < 0 || last < first || uint32_t(last) >= p.num_vertices())
        throw InputError(s.source, field + "/range",
                         "range [" + std::to_string(first) + ", " + std::to_string(last) + "] is outside panel '" +
                             p.name + "' (vertices 0 to " + std::to_string(p.num_vertices() - 1) + ")");
      for (int i = first; i <= last; ++i) ids.push_back(p.first_vertex + uint32_t(i));
    } else {
      throw InputError(s.source, field, "a pin needs one of corner, edge or range");
    }
    for (uint32_t id : ids) m.inv_mass[id] = 0.0f;
  }

  weld_seams(m);
  build_adjacency(m);
  return m;
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
  return set;
}

namespace {

// The animation time of a skinned obstacle at simulated time t, and how far the pose has blended
// from the rest pose into the animation.
std::pair<float, float> animation_time(const ObstacleDef& od, const SkinnedMesh& m, double t) {
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
}

}  // namespace raycloth
