#include "sim/model_check.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "raycloth/error.h"

namespace raycloth {

CheckMesh cloth_check_mesh(const ClothModel& model, const std::vector<Vec3>& positions) {
  CheckMesh m;
  m.vertices = positions;
  m.triangles = model.collision_triangles;
  for (const Piece& p : model.pieces) {
    m.group_names.push_back(p.name);
    m.group_first_triangle.push_back(p.first_triangle);
  }
  return m;
}

CheckMesh obstacle_check_mesh(const ObstacleSet& obstacles, const std::vector<Vec3>& world) {
  CheckMesh m;
  m.vertices = world;
  m.triangles = obstacles.world.indices;
  m.group_names = obstacles.names;
  m.group_first_triangle = obstacles.first_triangle;
  return m;
}

void refuse_crossing_start(const ClothModel& model, const std::string& scene_file) {
  CheckReport r;
  check_cloth_crossings(cloth_check_mesh(model, model.initial_positions), r);
  if (r.crossings == 0) return;
  const CrossingRecord& c = r.first_crossings.front();
  const std::string which = c.edge_group == c.triangle_group
                                ? fmt::format("panel '{}' crosses itself", c.edge_group)
                                : fmt::format("panels '{}' and '{}' cross", c.edge_group, c.triangle_group);
  throw InputError(scene_file, "/panels",
                   fmt::format("{} in the starting state ({} cloth edges through cloth triangles); move or "
                               "rotate the panels apart",
                               which, r.crossings));
}

namespace {

// A length for a message: 3 significant digits, 0.1 mm resolution, no "-0".
std::string metres(double v) {
  v = std::round(v * 1e4) / 1e4;
  return fmt::format("{:.3g}", v == 0 ? 0.0 : v);
}

}  // namespace

void refuse_inside_start(const ClothModel& model, const ObstacleSet& obstacles, const SceneDef& scene) {
  if (obstacles.world.num_triangles() == 0) return;
  std::vector<Vec3> posed, velocities;
  obstacles.pose_at(0.0, posed, velocities);
  const CheckMesh cloth = cloth_check_mesh(model, model.initial_positions);
  const std::vector<VertexInside> inside = find_vertices_inside(cloth, obstacle_check_mesh(obstacles, posed));
  if (inside.empty()) return;
  // A panel's vertices are those its triangles use (a welded seam vertex belongs to both sides).
  std::vector<char> in_panel(cloth.vertices.size());
  for (size_t pi = 0; pi < model.pieces.size(); ++pi) {
    const Piece& piece = model.pieces[pi];
    std::fill(in_panel.begin(), in_panel.end(), 0);
    for (uint32_t t = piece.first_triangle; t < piece.first_triangle + piece.num_triangles; ++t)
      for (int k = 0; k < 3; ++k) in_panel[cloth.triangles[3 * t + k]] = 1;
    for (size_t oi = 0; oi < obstacles.names.size(); ++oi) {
      size_t count = 0;
      const VertexInside* deepest = nullptr;
      for (const VertexInside& v : inside)
        if (v.obstacle == oi && in_panel[v.vertex]) {
          ++count;
          if (!deepest || v.depth > deepest->depth) deepest = &v;
        }
      if (count == 0) continue;
      // The deepest vertex's way out to the surface, and the thickness beyond it.
      const DPoint p{double(cloth.vertices[deepest->vertex].x), double(cloth.vertices[deepest->vertex].y),
                     double(cloth.vertices[deepest->vertex].z)};
      DPoint out{deepest->nearest[0] - p[0], deepest->nearest[1] - p[1], deepest->nearest[2] - p[2]};
      const double scale = deepest->depth > 0 ? (deepest->depth + double(scene.collision.thickness)) / deepest->depth : 0;
      for (int d = 0; d < 3; ++d)
        out[d] = deepest->depth > 0 ? out[d] * scale : deepest->normal[d] * double(scene.collision.thickness);
      const std::string how_deep =
          count == 1 ? fmt::format("{} m below its surface", metres(deepest->depth))
                     : fmt::format("the deepest {} m below its surface", metres(deepest->depth));
      throw InputError(scene.source, "/panels/" + std::to_string(pi),
                       fmt::format("panel '{}' starts with {} {} inside obstacle '{}' ({}); move the panel out of "
                                   "it, e.g. by ({}, {}, {})",
                                   piece.name, count, count == 1 ? "vertex" : "vertices", obstacles.names[oi],
                                   how_deep, metres(out[0]), metres(out[1]), metres(out[2])));
    }
  }
}

}  // namespace raycloth
