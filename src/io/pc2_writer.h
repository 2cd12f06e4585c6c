// PC2 point cache (cloth.pc2) with its rest pose (cloth_rest.obj): what Blender's Mesh Cache
// modifier and 3ds Max's Point Cache read. The file is a 32-byte header ("POINTCACHE2\0",
// version 1, numPoints, startFrame, sampleRate, numSamples) followed by float32 x, y, z for every
// point of every sample.
#pragma once
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "io/run.h"
#include "raycloth/vec3.h"

namespace raycloth {

// Samples go to "<path>.tmp" as they come; finish() writes the sample count into the header and
// renames the file to `path`, so the file under its own name is always whole.
class Pc2File {
 public:
  // start_frame and sample_rate are in frames (sample i is frame start_frame + i * sample_rate).
  Pc2File(std::filesystem::path path, uint32_t num_points, float start_frame = 0.0f, float sample_rate = 1.0f);
  ~Pc2File();  // leaves the temporary file when finish() was not called
  Pc2File(const Pc2File&) = delete;
  Pc2File& operator=(const Pc2File&) = delete;

  // Continues "<path>.tmp" after its first `num_samples` samples (a resumed run): what was written
  // after them is cut off. Throws std::runtime_error when the file is missing or shorter.
  static std::unique_ptr<Pc2File> reopen(std::filesystem::path path, uint32_t num_points, uint32_t num_samples);

  void add_sample(const std::vector<Vec3>& points);
  // Hands what was written so far to the system (before a checkpoint names it).
  void flush();
  void finish();
  uint32_t num_samples() const { return num_samples_; }

 private:
  Pc2File() = default;
  std::filesystem::path path_, tmp_;
  std::ofstream out_;
  uint32_t num_points_ = 0, num_samples_ = 0;
  bool finished_ = false;
};

// cloth.pc2 with a sample per frame, and cloth_rest.obj: frame 0 as one object whose vertex order
// is the point order of the cache.
class Pc2Sink final : public FrameSink {
 public:
  void begin(Simulator& sim, const std::filesystem::path& out_dir) override;
  void frame(Simulator& sim, const FrameRecord& record) override;
  void end(Simulator& sim) override;
  void save(ByteWriter& out) override;
  void resume(Simulator& sim, const std::filesystem::path& out_dir, ByteReader& in) override;

 private:
  std::filesystem::path out_dir_;
  std::unique_ptr<Pc2File> file_;
};

}  // namespace raycloth
