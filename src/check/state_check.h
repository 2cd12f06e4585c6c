// The exact check (check/exact_check.h) applied to a simulator's state and to an output folder.
#pragma once
#include <filesystem>
#include <functional>
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
