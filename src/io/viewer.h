// `raycloth view DIR`: one self-contained HTML page that plays an output folder of `raycloth run`
// in a browser (three.js, inlined; the frames, the run's figures and the per-frame exact check
// embedded), opened from disk with nothing fetched.
#pragma once
#include <cstddef>
#include <filesystem>

namespace raycloth {

struct ViewSummary {
  std::filesystem::path page;  // DIR/view.html
  size_t frames = 0, cloth_vertices = 0, bad_frames = 0, bytes = 0;
  bool checked = false;        // the exact check ran (the folder has what it needs)
};

// Reads DIR/frames/cloth_NNNN.obj (and frames/obstacles_NNNN.obj or obstacles.obj, run.json,
// timing.json where present), runs the exact check of every frame unless check is false, and writes
// DIR/view.html atomically. Throws InputError naming the folder or file and the reason.
ViewSummary write_view(const std::filesystem::path& dir, bool check = true);

}  // namespace raycloth
