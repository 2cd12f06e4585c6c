// glTF 2.0 binary (cloth.glb): the whole run in one file that glTF viewers and Blender play.
// One mesh per panel whose morph target k holds frame k (positions and normals as displacements
// from frame 0); a weights animation keyed at the frame times selects one target per frame and
// blends linearly between neighbours. Obstacles are meshes in their local frame under a node with
// their transform; moving ones get translation and rotation keys at the frame times. A skinned body
// is written like the cloth: its posed world-space vertices of frame 0, morph target k holding frame
// k, keyed by the same weights animation.
#pragma once
#include <filesystem>
#include <vector>

#include "io/run.h"
#include "raycloth/vec3.h"

namespace raycloth {

// Keeps every frame's cloth positions in memory and writes OUT/cloth.glb at end() (atomically).
// Size: about frames x vertices x 24 bytes, plus frames x skinned body vertices x 12 bytes, plus
// frames^2 x 4 bytes of weights.
class GlbSink final : public FrameSink {
 public:
  void begin(Simulator& sim, const std::filesystem::path& out_dir) override;
  void frame(Simulator& sim, const FrameRecord& record) override;
  void end(Simulator& sim) override;
  void save(ByteWriter& out) override;
  void resume(Simulator& sim, const std::filesystem::path& out_dir, ByteReader& in) override;

 private:
  std::filesystem::path path_;
  std::vector<double> times_;
  std::vector<std::vector<Vec3>> frames_;
  std::vector<std::vector<Vec3>> obstacle_frames_;  // every obstacle vertex per frame, when a body is skinned
};

}  // namespace raycloth
