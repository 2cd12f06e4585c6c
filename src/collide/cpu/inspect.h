// Geometric checks of a cloth state, used by tests and written into run.json: does any cloth vertex
// lie inside a closed obstacle, does any cloth edge pass through a cloth triangle.
#pragma once
#include <cstddef>
#include <vector>

#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

struct PenetrationReport {
  size_t vertices_inside_obstacles = 0;  // by ray parity against the closed obstacle meshes
  size_t cloth_edge_crossings = 0;       // cloth edges that cross a cloth triangle not sharing a vertex
  long first_inside_vertex = -1;
  long first_crossing_edge = -1;         // index into the model's springs
  long first_crossed_triangle = -1;
};

PenetrationReport inspect_penetration(const ClothModel& model, const std::vector<Vec3>& cloth,
                                      const TriMesh& obstacles);

}  // namespace raycloth
