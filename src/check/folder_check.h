// The exact check (check/exact_check.h) applied to an output folder of `raycloth run` (the check
// of a simulator's state is sim/model_check.h).
#pragma once
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "check/exact_check.h"

namespace raycloth {

// An output folder as `raycloth run` writes it: frames/cloth_NNNN.obj, obstacles.obj and, for
// moving obstacles, frames/obstacles_NNNN.obj.
struct FolderFrameCheck {
  int frame = 0;
  CheckReport report;
};
struct FolderCheck {
  std::vector<FolderFrameCheck> frames;
  double thickness = 0;       // the run's cloth thickness (run.json's /thickness; 0 without obstacles)
  size_t bad_frames() const;  // frames with a failure
  size_t pinched_frames() const;  // frames whose only problems are pinches
};
// Throws InputError naming the file when the folder has no frames or a file cannot be read. A
// folder with obstacles needs the run's cloth thickness, from DIR/run.json's /thickness (written by
// `raycloth run`), to tell pinches from failures: without it, InputError naming the file and field.
// on_frame (optional) sees each frame as it is checked.
FolderCheck check_output_folder(const std::filesystem::path& dir,
                                const std::function<void(const FolderFrameCheck&)>& on_frame = {});

}  // namespace raycloth
