// The cloth model from a scene: the panels meshed and laid one after another, the seams welded or
// stitched, the pins, the attachments (bound to the obstacles by resolve_attachments) and the sew
// groups.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <set>

#include "collide/proximity.h"
#include "raycloth/error.h"
#include "sim/model_build.h"

namespace raycloth {

namespace {

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

// Welded seams join their pairs into one vertex (weld_seams); sewn ones get a stitch, a spring of
// rest length 0 whose rest length eases from the pair's start distance while the seams close.
void join_seams(ClothModel& m, const SceneDef& s, const std::vector<PanelMesh>& meshes, const SeamPairs& seam_pairs) {
  const auto& pairs = seam_pairs.pairs;
  const auto& pair_seam = seam_pairs.seam;
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
}

// A [first, last] range of a panel's vertices (pins and attachments), as global vertex ids.
std::vector<uint32_t> range_ids(const SceneDef& s, const Piece& p, std::array<int, 2> range, const std::string& field) {
  const auto [first, last] = range;
  if (first < 0 || last < first || uint32_t(last) >= p.num_vertices())
    throw InputError(s.source, field,
                     "range [" + std::to_string(first) + ", " + std::to_string(last) + "] is outside panel '" + p.name +
                         "' (vertices 0 to " + std::to_string(p.num_vertices() - 1) + ")");
  std::vector<uint32_t> ids;
  for (int i = first; i <= last; ++i) ids.push_back(p.first_vertex + uint32_t(i));
  return ids;
}

// The global vertex ids along an edge or segment of panel `panel` (pins and attachments).
std::vector<uint32_t> path_ids(const SceneDef& s, const ClothModel& m, const std::vector<PanelMesh>& meshes, size_t panel,
                               const EdgeRef& ref, const std::string& field) {
  std::vector<uint32_t> ids;
  for (uint32_t i : panel_path(s, s.panels[panel], meshes[panel], ref, field)) ids.push_back(m.pieces[panel].first_vertex + i);
  return ids;
}

void add_pins(ClothModel& m, const SceneDef& s, const std::vector<PanelMesh>& meshes) {
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
      ids = path_ids(s, m, meshes, panel, EdgeRef{pd.panel, pd.edge, pd.segment, std::nullopt}, field);
    } else if (pd.range) {
      ids = range_ids(s, p, *pd.range, field + "/range");
    } else {
      throw InputError(s.source, field, "a pin needs one of corner, edge, segment or range");
    }
    for (uint32_t id : ids) m.inv_mass[id] = 0.0f;
  }
}

// What attachments name, kept for resolve_attachments (which needs the obstacles too).
void add_attachment_vertices(ClothModel& m, const SceneDef& s, const std::vector<PanelMesh>& meshes) {
  for (size_t ai = 0; ai < s.attachments.size(); ++ai) {
    const AttachmentDef& ad = s.attachments[ai];
    const std::string field = "/attachments/" + std::to_string(ai);
    const size_t panel = find_panel(s, ad.panel, field + "/panel");
    const Piece& p = m.pieces[panel];
    std::vector<uint32_t> ids;
    if (ad.range) {
      if (!ad.edge.empty() || !ad.segment.empty())
        throw InputError(s.source, field, "needs exactly one of edge, segment or range");
      ids = range_ids(s, p, *ad.range, field + "/range");
    } else {
      ids = path_ids(s, m, meshes, panel, EdgeRef{ad.panel, ad.edge, ad.segment, std::nullopt}, field);
    }
    m.attachment_vertices.push_back(std::move(ids));
  }
}

}  // namespace

ClothModel build_cloth_model(const SceneDef& s) {
  ClothModel m;
  if (s.panels.empty()) throw InputError(s.source, "/panels", "the scene has no cloth panels");
  std::vector<PanelMesh> meshes = mesh_panels(s);
  const SeamPairs pairs = pair_seams(s, meshes);
  for (size_t pi = 0; pi < s.panels.size(); ++pi) add_panel(m, s, pi, meshes[pi]);
  join_seams(m, s, meshes, pairs);
  add_pins(m, s, meshes);
  add_attachment_vertices(m, s, meshes);
  weld_seams(m);
  for (uint32_t& v : m.stitches) v = m.alias[v];
  // Rest lengths at the placed start (after welding): where the springs start when seams close
  // over time (scene.sewing.close_time).
  if (s.sewing.close_time > 0) {
    for (Spring& sp : m.springs) sp.rest_start = length(m.initial_positions[sp.b] - m.initial_positions[sp.a]);
    m.sew_time = float(s.sewing.close_time);
    m.ease_gravity = s.sewing.ease_gravity.value_or(!m.stitches.empty());
    m.gravity_waits = s.sewing.gravity_waits.value_or(!m.stitches.empty());
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

}  // namespace raycloth
