#include "sim/garment_fit.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "check/exact_check.h"
#include "collide/proximity.h"
#include "raycloth/error.h"
#include "sim/model.h"
#include "sim/model_check.h"

namespace raycloth {

namespace {

const Vec3 kUp = make_vec3(0, 1, 0);

// Where a horizontal plane cuts a body: the extent of the cut across (side) and along (front).
struct Section {
  double side_lo = INFINITY, side_hi = -INFINITY, front_lo = INFINITY, front_hi = -INFINITY;
  bool empty() const { return !(side_hi >= side_lo); }
};

struct Body {
  const std::vector<Vec3>* x = nullptr;
  std::vector<uint32_t> tris;  // 3 per triangle, into *x
};

// Obstacle oi's triangles over the posed vertices.
Body obstacle_body(const ObstacleSet& obstacles, size_t oi, const std::vector<Vec3>& posed) {
  Body b;
  b.x = &posed;
  b.tris.assign(obstacles.world.indices.begin() + 3 * obstacles.first_triangle[oi],
                obstacles.world.indices.begin() + 3 * obstacles.end_triangle(oi));
  return b;
}

Section section(const Body& b, double h, const BodyFrame& f) {
  Section s;
  const std::vector<Vec3>& x = *b.x;
  for (size_t t = 0; t < b.tris.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = x[b.tris[t + k]], q = x[b.tris[t + (k + 1) % 3]];
      if ((double(p.y) - h) * (double(q.y) - h) > 0 || p.y == q.y) continue;
      const float u = float((h - double(p.y)) / (double(q.y) - double(p.y)));
      const Vec3 c = p + (q - p) * u;
      const double side = double(dot(c, f.side)), front = double(dot(c, f.front));
      s.side_lo = std::min(s.side_lo, side), s.side_hi = std::max(s.side_hi, side);
      s.front_lo = std::min(s.front_lo, front), s.front_hi = std::max(s.front_hi, front);
    }
  return s;
}

// A uniform grid of the body's triangles (each in every cell its box, grown by `margin`, touches).
class TriangleGrid {
 public:
  TriangleGrid(const Body& b, float cell, float margin) : cell_(cell) {
    const std::vector<Vec3>& x = *b.x;
    for (uint32_t t = 0; t < b.tris.size() / 3; ++t) {
      Vec3 lo = x[b.tris[3 * t]], hi = lo;
      for (int k = 1; k < 3; ++k) lo = vmin(lo, x[b.tris[3 * t + k]]), hi = vmax(hi, x[b.tris[3 * t + k]]);
      const auto a = key3(lo - make_vec3(margin, margin, margin)), z = key3(hi + make_vec3(margin, margin, margin));
      for (int64_t i = a[0]; i <= z[0]; ++i)
        for (int64_t j = a[1]; j <= z[1]; ++j)
          for (int64_t k = a[2]; k <= z[2]; ++k) cells_[hash(i, j, k)].push_back(t);
    }
  }
  // Triangles in p's cell (those within `margin` of p among them).
  const std::vector<uint32_t>* near(Vec3 p) const {
    const auto k = key3(p);
    const auto it = cells_.find(hash(k[0], k[1], k[2]));
    return it == cells_.end() ? nullptr : &it->second;
  }
  // Triangles in any cell that the box [lo, hi] touches (with repeats).
  void in_box(Vec3 lo, Vec3 hi, std::vector<uint32_t>& out) const {
    const auto a = key3(lo), z = key3(hi);
    for (int64_t i = a[0]; i <= z[0]; ++i)
      for (int64_t j = a[1]; j <= z[1]; ++j)
        for (int64_t k = a[2]; k <= z[2]; ++k)
          if (auto it = cells_.find(hash(i, j, k)); it != cells_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
  }

 private:
  std::array<int64_t, 3> key3(Vec3 p) const {
    return {int64_t(std::floor(p.x / cell_)), int64_t(std::floor(p.y / cell_)), int64_t(std::floor(p.z / cell_))};
  }
  static uint64_t hash(int64_t i, int64_t j, int64_t k) {
    return (uint64_t(i + (1 << 20)) << 42) ^ (uint64_t(j + (1 << 20)) << 21) ^ uint64_t(k + (1 << 20));
  }
  float cell_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
};

DPoint dpoint(Vec3 v) { return {double(v.x), double(v.y), double(v.z)}; }

// Whether a panel (vertices `ids` moved by `move`, triangles `tris` over model vertex numbers) is
// clear of the body: no vertex inside or within `clearance` of its surface, no body edge through one
// of its triangles.
bool panel_clear(const ClothModel& m, const std::vector<uint32_t>& ids, const std::vector<uint32_t>& tris, Vec3 move,
                 const Body& body, const TriangleGrid& grid, const CheckMesh& body_mesh, float clearance) {
  const std::vector<Vec3>& bx = *body.x;
  std::unordered_map<uint32_t, uint32_t> local;
  CheckMesh panel;
  for (uint32_t i : ids) {
    local[i] = uint32_t(panel.vertices.size());
    panel.vertices.push_back(m.initial_positions[i] + move);
  }
  const double c2 = double(clearance) * double(clearance);
  for (const Vec3& p : panel.vertices)
    if (const auto* near = grid.near(p))
      for (uint32_t t : *near) {
        const TrianglePoint q =
            closest_on_triangle(dvec(p), dvec(bx[body.tris[3 * t]]), dvec(bx[body.tris[3 * t + 1]]), dvec(bx[body.tris[3 * t + 2]]));
        if (q.dist2 < c2) return false;
      }
  for (uint32_t v : tris) panel.triangles.push_back(local.at(v));
  if (!find_vertices_inside(panel, body_mesh).empty()) return false;
  std::vector<uint32_t> cand;
  for (size_t t = 0; t < panel.triangles.size(); t += 3) {
    const Vec3 a = panel.vertices[panel.triangles[t]], b = panel.vertices[panel.triangles[t + 1]],
               c = panel.vertices[panel.triangles[t + 2]];
    cand.clear();
    grid.in_box(vmin(a, vmin(b, c)), vmax(a, vmax(b, c)), cand);
    std::sort(cand.begin(), cand.end());
    cand.erase(std::unique(cand.begin(), cand.end()), cand.end());
    for (uint32_t bt : cand)
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = bx[body.tris[3 * bt + k]], q = bx[body.tris[3 * bt + (k + 1) % 3]];
        if (classify_edge_triangle(dpoint(p), dpoint(q), dpoint(a), dpoint(b), dpoint(c)) != EdgeTriangle::Apart) return false;
      }
  }
  return true;
}

// A panel's vertices and triangles (model vertex numbers) and its mean normal.
Vec3 panel_geometry(const ClothModel& m, const Piece& piece, std::vector<uint32_t>& pv, std::vector<uint32_t>& pt) {
  pv.clear(), pt.clear();
  for (uint32_t i = 0; i < piece.vertex_count; ++i) pv.push_back(piece.first_vertex + i);
  Vec3 normal = make_vec3(0, 0, 0);
  for (uint32_t t = piece.first_triangle; t < piece.first_triangle + piece.num_triangles; ++t) {
    const uint32_t a = m.triangles[3 * t], b = m.triangles[3 * t + 1], c = m.triangles[3 * t + 2];
    pt.insert(pt.end(), {a, b, c});
    normal += cross(m.initial_positions[b] - m.initial_positions[a], m.initial_positions[c] - m.initial_positions[a]);
  }
  return length(normal) > 0 ? normal / length(normal) : kUp;
}

// Whether panels a and b (their collision triangles at positions x) cross each other or themselves.
bool panels_cross(const ClothModel& m, const std::vector<Vec3>& x, uint32_t a, uint32_t b) {
  CheckMesh mesh;
  mesh.vertices = x;
  for (uint32_t p : {std::min(a, b), std::max(a, b)}) {
    const Piece& piece = m.pieces[p];
    mesh.group_names.push_back(piece.name);
    mesh.group_first_triangle.push_back(uint32_t(mesh.num_triangles()));
    mesh.triangles.insert(mesh.triangles.end(), m.collision_triangles.begin() + 3 * piece.first_triangle,
                          m.collision_triangles.begin() + 3 * (piece.first_triangle + piece.num_triangles));
  }
  CheckReport r;
  check_cloth_crossings(mesh, r);
  return r.crossings > 0;
}

// Panels of one garment that cross each other once each is clear of the body (a hood over a
// sleeve, both moved out of the shoulder): the panel whose edge goes through moves on away from the
// body's axis along its normal, 5 mm at a time while it stays clear of the body, up to
// kMaxClearMove in all; failing that the other panel does. Pair by pair until none crosses or a pair
// cannot be parted (then the start is refused as crossing, naming the two).
template <class Clear>
void separate_panels(ClothModel& m, const GarmentFitDef& g, std::vector<PanelFit>& fits, size_t first_fit, Vec3 axis,
                     Clear&& clear) {
  auto panel_index = [&](const std::string& name) {
    for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p)
      if (m.pieces[p].name == name) return int(p);
    return -1;
  };
  for (uint32_t round = 0; round < 2 * g.num_panels; ++round) {
    CheckReport r;
    check_cloth_crossings(cloth_check_mesh(m, m.initial_positions), r);
    if (r.crossings == 0) return;
    const CrossingRecord& c = r.first_crossings.front();
    const int pa = panel_index(c.edge_group), pb = panel_index(c.triangle_group);
    if (pa < 0 || pb < 0 || pa == pb) return;
    bool parted = false;
    for (int p : {pa, pb}) {
      std::vector<uint32_t> pv, pt;
      Vec3 normal = panel_geometry(m, m.pieces[p], pv, pt);
      Vec3 centre = make_vec3(0, 0, 0);
      for (uint32_t i : pv) centre += m.initial_positions[i];
      centre = centre / float(pv.size());
      Vec3 out = centre - axis;
      out.y = 0;
      const float sign = dot(normal, out) < 0 ? -1.0f : 1.0f;  // away from the body's axis
      PanelFit& fit = fits[first_fit + size_t(p - int(g.first_panel))];
      const float step = 0.005f;
      for (float d = step; std::fabs(fit.moved) + d <= float(kMaxClearMove) + 1e-6f; d += step) {
        const Vec3 move = normal * (sign * d);
        if (!clear(pv, pt, move)) continue;
        std::vector<Vec3> x = m.initial_positions;
        for (uint32_t i : pv) x[i] += move;
        if (panels_cross(m, x, uint32_t(pa), uint32_t(pb))) continue;
        m.initial_positions = x;
        fit.moved += sign * d;
        parted = true;
        break;
      }
      if (parted) break;
    }
    if (!parted) return;
  }
}

}  // namespace

BodyFrame body_frame(const ObstacleSet& obstacles, size_t oi, const std::vector<Vec3>& posed, const Float3& front) {
  BodyFrame f;
  const Vec3 fr = make_vec3(front[0], 0, front[2]);
  f.front = fr / length(fr);
  f.side = cross(kUp, f.front);
  const uint32_t v0 = obstacles.first_vertex[oi], nv = uint32_t(obstacles.local[oi].vertices.size());
  double lo = INFINITY, hi = -INFINITY;
  for (uint32_t v = v0; v < v0 + nv; ++v) lo = std::min(lo, double(posed[v].y)), hi = std::max(hi, double(posed[v].y));
  f.floor = lo, f.height = hi - lo;
  const Body b = obstacle_body(obstacles, oi, posed);
  double best = INFINITY;
  f.neck = lo + kGarmentCodeNeck / kGarmentCodeHeight * f.height;  // where no section is found
  for (double h = lo + 0.80 * f.height; h <= lo + 0.92 * f.height; h += 0.0025) {
    const Section s = section(b, h, f);
    if (!s.empty() && s.side_hi - s.side_lo < best) best = s.side_hi - s.side_lo, f.neck = h;
  }
  return f;
}

std::vector<PanelFit> fit_garments(ClothModel& m, const ObstacleSet& obstacles, const SceneDef& scene) {
  std::vector<PanelFit> fits;
  if (scene.garment_fits.empty()) return fits;
  std::vector<Vec3> posed, velocities;
  obstacles.pose_at(0.0, posed, velocities);
  const float clearance = 2.0f * scene.collision.thickness;
  for (const GarmentFitDef& g : scene.garment_fits) {
    size_t oi = 0;
    while (oi < obstacles.names.size() && obstacles.names[oi] != g.body) ++oi;
    if (oi == obstacles.names.size()) throw InputError(scene.source, g.field + "/body", "no obstacle named '" + g.body + "'");
    const BodyFrame f = body_frame(obstacles, oi, posed, obstacles.defs[oi].front);
    const Body body = obstacle_body(obstacles, oi, posed);

    // The garment's vertices, in the pattern's frame.
    std::vector<uint32_t> ids;
    for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p)
      for (uint32_t i = 0; i < m.pieces[p].vertex_count; ++i) ids.push_back(m.pieces[p].first_vertex + i);
    double top = -INFINITY;
    for (uint32_t i : ids) top = std::max(top, double(m.initial_positions[i].y));
    // The older generator's templates are placed around a body whose waist is at y = 0 (their tops
    // reach 0.3 to 0.7 m, trousers' hems -1.05 m): lifted by GarmentCode's waist height first.
    if (top < kOlderFrameTop) {
      for (uint32_t i : ids) m.initial_positions[i].y += float(kGarmentCodeWaist);
      top += kGarmentCodeWaist;
    }
    const bool by_neck = top > 1.30;
    const double scale = f.height / kGarmentCodeHeight;
    const double anchor_gc = by_neck ? kGarmentCodeNeck : kGarmentCodeWaist;
    const double anchor_body = by_neck ? f.neck : f.neck - (kGarmentCodeNeck - kGarmentCodeWaist) * scale;
    // The middles of the garment and of the body over a band of heights below the anchor.
    double gx_lo = INFINITY, gx_hi = -INFINITY, gz_lo = INFINITY, gz_hi = -INFINITY;
    for (uint32_t i : ids) {
      const Vec3 p = m.initial_positions[i];
      if (p.y < anchor_gc - 0.35 || p.y > anchor_gc - 0.05) continue;
      gx_lo = std::min(gx_lo, double(p.x)), gx_hi = std::max(gx_hi, double(p.x));
      gz_lo = std::min(gz_lo, double(p.z)), gz_hi = std::max(gz_hi, double(p.z));
    }
    if (!(gx_hi >= gx_lo)) gx_lo = gx_hi = gz_lo = gz_hi = 0;
    Section band;
    for (double h = anchor_body - 0.35 * scale; h <= anchor_body - 0.05 * scale; h += 0.01) {
      const Section s = section(body, h, f);
      if (s.empty()) continue;
      band.side_lo = std::min(band.side_lo, s.side_lo), band.side_hi = std::max(band.side_hi, s.side_hi);
      band.front_lo = std::min(band.front_lo, s.front_lo), band.front_hi = std::max(band.front_hi, s.front_hi);
    }
    const double side_mid = band.empty() ? 0.0 : 0.5 * (band.side_lo + band.side_hi);
    const double front_mid = band.empty() ? 0.0 : 0.5 * (band.front_lo + band.front_hi);
    const Vec3 garment_mid = make_vec3(float(0.5 * (gx_lo + gx_hi)), float(anchor_gc), float(0.5 * (gz_lo + gz_hi)));
    const Vec3 body_mid = f.side * float(side_mid) + f.front * float(front_mid) + kUp * float(anchor_body);
    // Pattern x, y, z to the body's side, up and front, then the user's turn and move.
    const double turn = double(g.rotation) * M_PI / 180.0;
    const float ct = float(std::cos(turn)), st = float(std::sin(turn));
    const Vec3 side = f.side * ct - f.front * st, front = f.front * ct + f.side * st;
    const Vec3 move = make_vec3(g.position[0], g.position[1], g.position[2]);
    for (uint32_t i : ids) {
      const Vec3 d = m.initial_positions[i] - garment_mid;
      m.initial_positions[i] = body_mid + side * d.x + kUp * d.y + front * d.z + move;
    }
    if (!g.clear) continue;

    // Clearance, panel by panel.
    const TriangleGrid grid(body, 0.03f, clearance);
    CheckMesh body_mesh;
    body_mesh.vertices = posed;
    body_mesh.triangles = body.tris;
    const size_t first_fit = fits.size();
    for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p) {
      const Piece& piece = m.pieces[p];
      std::vector<uint32_t> pv, pt;
      const Vec3 normal = panel_geometry(m, piece, pv, pt);
      const float step = 0.005f;
      float moved = 0;
      bool clear = false;
      for (float d = 0; d <= float(kMaxClearMove) + 1e-6f && !clear; d += step)
        for (float sign : {1.0f, -1.0f}) {
          if (panel_clear(m, pv, pt, normal * (sign * d), body, grid, body_mesh, clearance)) {
            moved = sign * d, clear = true;
            break;
          }
          if (d == 0) break;
        }
      if (!clear) {
        throw InputError(scene.source, g.field,
                         fmt::format("panel '{}' starts inside or through obstacle '{}', and moving it up to {:g} m "
                                     "either way along its normal did not clear it by {:g} m; place the garment "
                                     "with position or the panel with panels.<name>.offset",
                                     piece.name, g.body, kMaxClearMove, double(clearance)));
      }
      for (uint32_t i : pv) m.initial_positions[i] += normal * moved;
      fits.push_back({piece.name, moved});
    }
    separate_panels(m, g, fits, first_fit, body_mid, [&](const std::vector<uint32_t>& pv, const std::vector<uint32_t>& pt, Vec3 move) {
      return panel_clear(m, pv, pt, move, body, grid, body_mesh, clearance);
    });
  }
  // Seam partners follow their representatives; the springs start from the new lengths.
  for (uint32_t i = 0; i < m.num_vertices(); ++i) m.initial_positions[i] = m.initial_positions[m.alias[i]];
  if (m.sew_time > 0) {
    for (Spring& sp : m.springs) sp.rest_start = length(m.initial_positions[sp.b] - m.initial_positions[sp.a]);
    build_adjacency(m);
  }
  return fits;
}

}  // namespace raycloth
