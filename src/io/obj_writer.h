// Wavefront OBJ output: cloth frames (one `o NAME` per panel, with vertex normals) and obstacles.
#pragma once
#include <filesystem>
#include <vector>

#include "io/run.h"
#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

// Area-weighted vertex normals of the cloth triangles.
std::vector<Vec3> cloth_vertex_normals(const ClothModel& model, const std::vector<Vec3>& positions);
void write_cloth_obj(const std::filesystem::path& path, const ClothModel& model, const std::vector<Vec3>& positions);
void write_obstacles_obj(const std::filesystem::path& path, const ObstacleSet& obstacles,
                         const std::vector<Vec3>& world_vertices);

// frames/cloth_NNNN.obj for every frame, and frames/obstacles_NNNN.obj when an obstacle moves.
class ObjFrames final : public FrameSink {
 public:
  void begin(Simulator& sim, const std::filesystem::path& out_dir) override;
  void frame(Simulator& sim, const FrameRecord& record) override;

 private:
  std::filesystem::path dir_;
};

}  // namespace raycloth
