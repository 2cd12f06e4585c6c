// A run's checkpoints (the file format: io/checkpoint.h): what a checkpoint must agree with to be
// resumed, and the run's part of it: the frame done, the simulator's state, the report so far and
// what each output sink keeps in memory.
#pragma once
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "io/checkpoint.h"
#include "io/run.h"

namespace raycloth {

// The header of this run's checkpoints: the scene (and its meshes), the raycloth version, and every
// setting that changes what the run writes.
CheckpointHeader run_checkpoint_header(const SceneDef& scene, const RunOptions& options, const std::string& device);

// Writes OUT/checkpoint.bin after frame `done`: the state, the report so far and the sinks' own state.
void save_run_checkpoint(const std::filesystem::path& out_dir, const CheckpointHeader& header, int done, Simulator& sim,
                         const RunReport& report, const std::vector<std::shared_ptr<FrameSink>>& sinks);
// Restores the simulator, the report and the sinks (resume() for begin()) from OUT/checkpoint.bin
// and returns the frame it was written after. Throws InputError naming the file when it was
// written for another scene or other settings, or is damaged.
int resume_run_checkpoint(const std::filesystem::path& out_dir, const CheckpointHeader& header, int num_frames,
                          Simulator& sim, RunReport& report, const std::vector<std::shared_ptr<FrameSink>>& sinks);
// Removes OUT/checkpoint.bin and a partly written one, if any.
void remove_run_checkpoint(const std::filesystem::path& out_dir);

}  // namespace raycloth
