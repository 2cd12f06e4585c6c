// Rendered output: images/frame_NNNN.png for every frame of a run (a FrameSink), and the same
// for an existing output folder (`raycloth render DIR`).
#pragma once
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "io/run.h"
#include "raycloth/scene.h"
#include "render/renderer.h"

namespace raycloth {

// Renders every frame of a run to out/images/frame_NNNN.png (see View for how the view follows).
class ImageFrames final : public FrameSink {
 public:
  explicit ImageFrames(const CameraDef& camera) : camera_(camera) {}
  void begin(Simulator& sim, const std::filesystem::path& out_dir) override;
  void frame(Simulator& sim, const FrameRecord& record) override;
  int frames_written() const { return written_; }
  void save(ByteWriter& out) override;
  void resume(Simulator& sim, const std::filesystem::path& out_dir, ByteReader& in) override;

 private:
  CameraDef camera_;
  std::filesystem::path dir_;
  Bounds seen_;
  Renderer renderer_;
  int written_ = 0;
};

// What `raycloth render` needs from an output folder's run.json.
struct OutputFolder {
  std::filesystem::path dir;
  double fps = 30;
  std::vector<int> frames;  // indices of frames/cloth_NNNN.obj
  CameraDef camera;         // the run's camera settings
};

// Reads DIR/run.json; throws InputError naming the file and the reason.
OutputFolder read_output_folder(const std::filesystem::path& dir);
// Frame `index` of the folder: frames/cloth_NNNN.obj (one object per panel) and the obstacles
// (frames/obstacles_NNNN.obj when they move, obstacles.obj otherwise). Throws InputError.
RenderScene read_output_frame(const OutputFolder& folder, int index);
// Renders every frame of the folder to DIR/images; `progress(done, total)` after each.
void render_output_folder(const OutputFolder& folder, const CameraDef& camera,
                          const std::function<void(int, int)>& progress = {});

}  // namespace raycloth
