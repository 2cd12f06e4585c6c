// Sweeps: one base scene and lists of values for some of its fields, expanded to numbered cases that
// run into their own folders (`raycloth batch`, docs/batch.md).
//
// A sweep file:
//   { "scene": "../moving_sphere.json",                 // relative to the sweep file
//     "set":  { "/time/duration": 0.5 },                // optional: fixed edits of every case
//     "vary": { "/materials/0/stretch": [100, 200],     // JSON pointers into the scene -> values
//               "/obstacles/0/motion/velocity": [[0.1, 0, 0], [0.25, 0, 0]] } }
// Cases are the cartesian product of the lists, numbered from 0 with the last field of `vary`
// changing fastest (nested loops in the file's order).
//
// The output folder: OUT/cases/NNNNN/ holds what `raycloth run` writes for case NNNNN plus
// result.json (written atomically when the case ends: the case is finished); OUT/claims/NNNNN is the
// claim of a running case (created with O_EXCL: "pid host unix-time"); OUT/results.jsonl gets one line
// per finished case, appended with one write under a lock (OUT/.lock); OUT/batch.json names the sweep
// (another sweep in the same folder is refused).
#pragma once
#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "raycloth/scene.h"

namespace raycloth {

struct Sweep {
  std::string file;                          // the sweep file as given (names it in errors)
  std::filesystem::path scene_file;          // the base scene, resolved against the sweep's folder
  nlohmann::json base;                       // the base scene's JSON
  std::vector<std::pair<std::string, nlohmann::json>> set;    // fixed edits, in the file's order
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> vary;  // in the file's order
  uint64_t fingerprint = 0;                  // the sweep's text and the base scene's text
  size_t cases() const;
};

// Reads and checks a sweep: the file, the base scene (parsed as `raycloth run` would), every field
// named in `set` and `vary`. Throws InputError (FILE: FIELD: REASON).
Sweep load_sweep(const std::string& path);

// Case i's values, as an object of the varied fields in the sweep's order.
nlohmann::ordered_json case_values(const Sweep& sweep, size_t i);
// Case i's scene JSON (the base with `set` and the case's values applied).
nlohmann::json case_scene_json(const Sweep& sweep, size_t i);
// Case i's scene; errors name "SWEEP (case i)" and the scene field.
SceneDef case_scene(const Sweep& sweep, size_t i);
// "00042" (at least five digits).
std::string case_id(size_t i);

struct BatchOptions {
  std::filesystem::path out;
  std::string device = "cpu";
  bool check = true;
  int checkpoint_every = 5;
  // A claim whose file has not been touched for this many seconds is taken over (0: never). A running
  // case touches its claim at every frame. Claims of dead processes on this host are taken over always.
  double stale_after = 0;
  // Called between steps of the case (tests stop a run halfway with it).
  std::function<void()> between_steps;
};

enum class CaseOutcome {
  ran,       // this call ran the case (to its end, or to an error recorded in result.json)
  finished,  // already finished: skipped
  claimed,   // another live process holds it: skipped
};

// Prepares OUT (folders, batch.json); throws InputError when OUT belongs to another sweep.
void prepare_batch_folder(const Sweep& sweep, const std::filesystem::path& out);
// Claims case i, runs it (resuming from its checkpoint when one is there), writes its result.json and
// appends its line to results.jsonl, then drops the claim. `result` gets the line's object.
CaseOutcome run_case(const Sweep& sweep, size_t i, const BatchOptions& options, nlohmann::ordered_json* result = nullptr);

// Case i's result.json, when it is finished.
std::optional<nlohmann::ordered_json> read_case_result(const std::filesystem::path& out, size_t i);
// The results of every finished case as CSV (in case order), one column per varied field.
std::string results_csv(const Sweep& sweep, const std::filesystem::path& out);

// The cases a process runs: --index I, --shard I/N, or Slurm's array variables; all cases otherwise.
// Throws InputError naming the option (or the variable) when it does not fit the sweep.
std::vector<size_t> select_cases(size_t count, std::optional<long> index, const std::string& shard,
                                 const std::function<const char*(const char*)>& getenv_fn);

}  // namespace raycloth
