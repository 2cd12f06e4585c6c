// The exact check (check/exact_check.h) applied to the cloth model and the obstacles: the meshes
// it sees, and the starting states the simulator refuses.
#pragma once
#include <string>
#include <vector>

#include "check/exact_check.h"
#include "sim/model.h"

namespace raycloth {

// The cloth as the check sees it: the welded triangles (seam partners are one vertex), one group
// per panel.
CheckMesh cloth_check_mesh(const ClothModel& model, const std::vector<Vec3>& positions);
// All obstacles in world space, one group per obstacle.
CheckMesh obstacle_check_mesh(const ObstacleSet& obstacles, const std::vector<Vec3>& world_vertices);

// Throws InputError(scene file, "/panels", ...) naming the panels when the cloth's starting state
// already has an edge through a triangle.
void refuse_crossing_start(const ClothModel& model, const std::string& scene_file);

// Throws InputError(scene file, "/panels/<index>", ...) when cloth vertices start strictly inside an
// obstacle posed at t = 0 (the check's inside test; within the thickness is not inside): the first
// panel (in the scene's order) with such vertices, the obstacle, their count, the depth of the
// deepest one and a move that takes it out (its way to the surface plus the thickness).
void refuse_inside_start(const ClothModel& model, const ObstacleSet& obstacles, const SceneDef& scene);

}  // namespace raycloth
