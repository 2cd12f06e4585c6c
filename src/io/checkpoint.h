// Checkpoints of a run (OUT/checkpoint.bin): everything a step reads that is not a pure function of
// the scene and the time, the counters and frame records that go into run.json, and what the output
// sinks keep in memory, so that `raycloth run ... --resume` (or `raycloth resume DIR`) continues an
// interrupted run to the same bytes as an uninterrupted one.
//
// The file: a header (magic, format version, raycloth version, a hash of the scene file and of every
// mesh it uses, the run's settings, the command that started it) and the state, as length-prefixed
// little-endian records, then a 64-bit hash of everything before it. It is written atomically.
#pragma once
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/bytes.h"
#include "raycloth/scene.h"

namespace raycloth {

inline constexpr uint32_t kCheckpointFormat = 8;  // 2: FrameRecord::seam_gap; 3: the state as SimState::for_each_kept lists it, RunTotals; 4: welds put off; 5: RunTotals::max_obstacle_move, the bound's planes; 6: the welded model's start positions and masses; 7: StepCounters::pass_moved; 8: RunTotals::entered and retried, the state's inside, the steps-taken-again level
inline constexpr const char* kCheckpointName = "checkpoint.bin";

// raycloth's version (CMake's project version).
std::string raycloth_version();
// The text of the built-in default scene (scenes/seed_drape.json, compiled in).
std::string_view default_scene_text();

// FNV-1a, 64 bits.
uint64_t hash_bytes(std::string_view bytes, uint64_t h = 14695981039346656037ull);

// What identifies the scene: its text (the file's bytes, or the built-in text when `scene_text` is
// empty and the scene has no readable file) and the bytes of every mesh or glTF file it uses.
uint64_t scene_fingerprint(const SceneDef& scene, const std::string& scene_text);

struct CheckpointHeader {
  uint32_t format = 0;
  std::string version;
  uint64_t scene_hash = 0;
  std::string settings;    // JSON: what must match for a resume (formats, duration, device, ...)
  std::string invocation;  // JSON: how the run was started (the CLI's `resume DIR` reads it)
};

// Writes header + state + hash to DIR/checkpoint.bin atomically.
void write_checkpoint(const std::filesystem::path& dir, const CheckpointHeader& header, const std::string& state);
// Reads DIR/checkpoint.bin: checks the magic, the format, the version and the trailing hash, and
// returns the header and the state bytes. Throws InputError naming the file (missing, not a
// checkpoint, damaged, from another format or raycloth version).
struct CheckpointFile {
  CheckpointHeader header;
  std::string state;
};
CheckpointFile read_checkpoint(const std::filesystem::path& dir);

}  // namespace raycloth
