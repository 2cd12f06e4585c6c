// PLY output: binary little-endian triangle meshes, one file per frame (frames/cloth_NNNN.ply).
#pragma once
#include <filesystem>
#include <string>
#include <vector>

#include "io/run.h"
#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

// All panels in one file: vertices (x, y, z, nx, ny, nz, panel) and triangles; the header's
// comments name panel i as "panel i NAME".
void write_cloth_ply(const std::filesystem::path& path, const ClothModel& model, const std::vector<Vec3>& positions);
// World-space obstacles: vertices (x, y, z) and triangles.
void write_obstacles_ply(const std::filesystem::path& path, const ObstacleSet& obstacles,
                         const std::vector<Vec3>& world_vertices);

// frames/cloth_NNNN.ply for every frame, and frames/obstacles_NNNN.ply when an obstacle moves.
class PlyFrames final : public FrameSink {
 public:
  void begin(Simulator& sim, const std::filesystem::path& out_dir) override;
  void frame(Simulator& sim, const FrameRecord& record) override;

 private:
  std::filesystem::path dir_;
};

}  // namespace raycloth
