// Wavefront OBJ output: cloth frames (one `o NAME` per panel, with vertex normals) and obstacles.
#pragma once
#include <filesystem>
#include <vector>

#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

// Area-weighted vertex normals of the cloth triangles.
std::vector<Vec3> cloth_vertex_normals(const ClothModel& model, const std::vector<Vec3>& positions);
void write_cloth_obj(const std::filesystem::path& path, const ClothModel& model, const std::vector<Vec3>& positions);
void write_obstacles_obj(const std::filesystem::path& path, const ObstacleSet& obstacles,
                         const std::vector<Vec3>& world_vertices);

}  // namespace raycloth
