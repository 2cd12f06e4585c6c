// What a run reports from its RunReport (io/run.h): run.json, only what the simulation determines
// (the same bytes for the same scene and settings, resumed or not); timing.json, the wall-clock
// figures, which differ between any two runs; and the warnings at its end.
#pragma once
#include <nlohmann/json.hpp>

#include "io/run.h"
#include "raycloth/scene.h"

namespace raycloth {

// The scene's camera as run.json and a checkpoint's settings hold it (`raycloth render DIR` reads it).
nlohmann::json camera_json(const CameraDef& camera);
// run.json of the run so far: counts, steps, the frames' records, the contact counters, the
// integrator, the exact check, the files written and the error the run stopped on.
nlohmann::json run_json(const RunReport& report, Simulator& sim);
// timing.json: wall time, steps per second, simulated seconds per wall second, milliseconds per stage.
nlohmann::json timing_json(const RunReport& report);

// The implicit integrator says so when its sweeps did not converge (once, at the end).
void warn_unconverged(const SceneDef& scene, Simulator& sim);
// Says so when a seam sewn from apart had not closed by the end of the close time (or is open at the end).
void warn_open_seams(Simulator& sim, const RunReport& report);

}  // namespace raycloth
