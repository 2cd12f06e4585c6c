// Runs a scene to an output folder: frames, obstacles, run.json, progress. The CLI and the tests
// both come through here; only the CLI decides to exit.
#pragma once
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "check/exact_check.h"
#include "raycloth/simulator.h"

namespace raycloth {

class ByteWriter;
class ByteReader;

struct FrameRecord {
  int index = 0;
  double time = 0;
  uint64_t step = 0;
  uint64_t hits = 0;            // collision-buffer entries in the frame's last step
  uint64_t clamped = 0;         // vertex-steps the displacement bound shortened since the previous frame
  uint64_t pushed = 0;          // vertex-steps an obstacle pushed out since the previous frame
  double kinetic_energy = 0;    // J
  double steps_per_second = 0;  // wall-clock rate over the frame's steps
  // The exact check of this frame (check/exact_check.h); -1 when the run was asked not to check.
  long crossings = -1;          // cloth edges through cloth triangles
  long vertices_inside = -1;    // cloth vertices strictly inside an obstacle (failures: no pinch explains them)
  long pinched = -1;            // cloth vertices strictly inside where the body's own gap is < 2 x thickness
  double pinch_gap = HUGE_VAL;  // metres, the smallest body gap of a pinched vertex (infinite: none)
  double seam_gap = 0;          // metres, the widest stitch of the seams sewn from apart (sim/seams.h)
};

// The exact check over every written frame. A bad frame has a failure (a crossing or a vertex
// inside); a pinched frame has only pinches (vertices inside where the body's own surfaces are
// closer than twice the cloth thickness), which is not clean and not a failure.
struct RunCheck {
  bool enabled = true;
  size_t frames_checked = 0, bad_frames = 0;
  int first_bad_frame = -1;
  size_t max_crossings = 0, max_vertices_inside = 0;
  std::string first_problem;  // describe() of the first bad frame
  size_t closed_obstacles = 0, open_obstacles = 0;
  size_t pinched_frames = 0, max_vertices_pinched = 0;
  double min_pinch_gap = HUGE_VAL;  // metres, over every frame (infinite: no pinch)
  int first_pinched_frame = -1;
  std::string first_pinch;  // describe() of the first pinched frame
};

// The cloth thickness the check uses to tell pinches from failures, as run.json's /thickness holds
// it: the scene's float written in its shortest decimal form (0.002, not 0.0020000000949949026).
double check_thickness(const SceneDef& scene);

// Receives every output frame (frame 0 is the initial state). Writers of further formats and the
// image renderer plug in here. end() comes after the last frame, and also when the run stops on a
// blow-up (then the simulator's state is not a frame: use the frames received).
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual void begin(Simulator& sim, const std::filesystem::path& out_dir) { (void)sim, (void)out_dir; }
  virtual void frame(Simulator& sim, const FrameRecord& record) = 0;
  virtual void end(Simulator& sim) { (void)sim; }
  // Checkpoints: save() writes what the sink keeps between frames (frames on disk are not
  // repeated); resume() stands for begin() when a run continues from a checkpoint, with what save()
  // wrote then. A sink that keeps nothing needs neither.
  virtual void save(ByteWriter& out) { (void)out; }
  virtual void resume(Simulator& sim, const std::filesystem::path& out_dir, ByteReader& in) {
    (void)in;
    begin(sim, out_dir);
  }
};

struct RunOptions {
  std::filesystem::path out_dir = "out";
  SimOptions sim;
  std::optional<double> duration;  // overrides the scene's
  bool quiet = false;
  std::vector<std::shared_ptr<FrameSink>> sinks;  // besides the mesh formats
  // Mesh formats (kOutputFormats): overrides the scene's output.formats.
  std::optional<std::vector<std::string>> formats;
  bool write_obj = true;  // false: no OBJ frames even when the formats name obj
  bool check = true;      // the exact check of every frame (run.json's "check")
  // Checkpoints (io/checkpoint.h): OUT/checkpoint.bin after every `checkpoint_every` frames (0: none),
  // removed when the run ends. `resume` continues from it instead of starting over.
  int checkpoint_every = 5;
  bool resume = false;
  // The scene's own text (identifies the scene in checkpoints; default: the file at scene.source).
  std::string scene_text;
  // Stored in the checkpoint as is (JSON; the CLI keeps its arguments there for `raycloth resume`).
  std::string invocation = "{}";
  // Called with every output frame once the outputs have it (frame 0 included), and between steps
  // (then the run steps one step at a time). One that throws stops the run as a blow-up does (the
  // outputs end with the frames so far, run.json and summary.png name the error, no checkpoint
  // stays) and run_scene rethrows its exception. The Python module's callbacks and Ctrl-C.
  std::function<void(Simulator&, const FrameRecord&)> on_frame;
  std::function<void()> between_steps;
};

struct RunReport {
  std::string scene;
  std::string device;
  uint64_t steps = 0;
  double simulated_time = 0;
  // Wall-clock figures (timing.json, not run.json: they differ between any two runs).
  double wall_time = 0;  // seconds spent stepping (output excluded)
  double steps_per_second = 0;
  StageTimes stages;
  uint64_t bound_refreshes = 0;  // steps that recomputed the displacement bound
  std::vector<FrameRecord> frames;
  RunCheck check;
  std::vector<std::string> outputs;  // files written, relative to the output folder (* for frame numbers)
  std::string error;  // set when the run stopped on a SimulationError
};

// Throws InputError / SimulationError before anything is written when the scene cannot run, and
// InputError ("OUT: cannot write the output folder: ...") when the folder cannot be written; on a
// blow-up during the run, ends the sinks (cloth.pc2 and cloth.glb hold the frames so far), writes
// run.json with the error and summary.png, keeps the frames, and rethrows. A file that cannot be
// written (a full disk) stops the run with std::runtime_error naming it; the frames written before
// stay whole, and the last checkpoint stays for a resume.
// run.json holds only what the simulation determines (the same bytes for the same scene and
// settings, resumed or not); timing.json holds the wall-clock figures.
RunReport run_scene(const SceneDef& scene, const RunOptions& options);

std::string frame_name(const std::string& prefix, int index, const std::string& ext);

}  // namespace raycloth
