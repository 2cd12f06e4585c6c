// The command-line tool end to end: the default scene (shortened), its output folder, bad input.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "fixtures.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string err;
  std::string out;
};

Result run_cli(const std::string& args, const fs::path& dir) {
  fs::create_directories(dir);
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = std::string(RAYCLOTH_CLI) + " " + args + " > " + (dir / "stdout.txt").string() + " 2> " + err.string();
  const int status = std::system(cmd.c_str());
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  return {WEXITSTATUS(status), slurp(err), slurp(dir / "stdout.txt")};
}

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("raycloth_cli_" + name);
  fs::remove_all(d);
  return d;
}

}  // namespace

TEST(Cli, DefaultSceneShortenedRunsAndEndsPenetrationFree) {
  const fs::path dir = fresh_dir("default");
  const Result r = run_cli("run --quiet --duration 0.4 --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const fs::path out = dir / "out";
  EXPECT_TRUE(fs::exists(out / "frames" / "cloth_0000.obj"));
  EXPECT_TRUE(fs::exists(out / "frames" / "cloth_0012.obj"));
  EXPECT_TRUE(fs::exists(out / "obstacles.obj"));
  for (const auto& e : fs::directory_iterator(out / "frames")) EXPECT_NE(e.path().extension(), ".tmp");
  std::ifstream in(out / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["scene"], "seed_drape");
  EXPECT_EQ(j["vertices"], 4252);
  EXPECT_EQ(j["obstacle_triangles"], 1152);
  EXPECT_EQ(j["steps"], 1000);
  EXPECT_EQ(j["frames"].size(), 14u);  // frame 0 and 13 frames of 83 steps (the last one shorter)
  EXPECT_GT(j["frames"].back()["hits"].get<int>(), 0);
  // The exact check of every frame; 0.4 s reaches the time when the top piece lies on the seamed
  // halves over the sphere.
  EXPECT_EQ(j["check"]["frames_checked"], 14);
  EXPECT_EQ(j["check"]["bad_frames"], 0) << j["check"].dump();
  EXPECT_EQ(j["check"]["closed_obstacles"], 1);
  for (const auto& f : j["frames"]) {
    EXPECT_EQ(f["crossings"], 0) << "frame " << f["index"];
    EXPECT_EQ(f["vertices_inside"], 0) << "frame " << f["index"];
  }
  // `raycloth check` reads the written frames back and finds the same.
  const Result c = run_cli("check --quiet " + out.string(), dir);
  EXPECT_EQ(c.code, 0) << c.out << c.err;
  EXPECT_NE(c.out.find("14 frames, 0 bad: 0 edge-triangle crossings and 0 vertices inside"), std::string::npos) << c.out;

  // Wall-clock figures are in timing.json; run.json holds only what the simulation determines.
  std::ifstream timing_in(out / "timing.json");
  const nlohmann::json timing = nlohmann::json::parse(timing_in);
  for (const char* stage : {"forces_and_integration", "acceleration_structure_update", "ray_casting", "response"})
    EXPECT_GT(timing["stage_ms_per_step"][stage].get<double>(), 0.0) << stage;
  EXPECT_GT(timing["wall_time"].get<double>(), 0.0);
  // Simulated seconds per wall second: the steps per second times dt.
  EXPECT_NEAR(timing["simulated_seconds_per_wall_second"].get<double>(),
              timing["steps_per_second"].get<double>() * 4e-4, 1e-9 * timing["steps_per_second"].get<double>());
  EXPECT_EQ(timing["frames"].size(), 14u);
  for (const char* wall_clock : {"wall_time", "steps_per_second", "stage_ms_per_step"}) EXPECT_FALSE(j.contains(wall_clock));
  EXPECT_FALSE(j["frames"][1].contains("steps_per_second"));
  EXPECT_FALSE(fs::exists(out / "checkpoint.bin"));  // removed when the run is complete
  // One `o NAME` per panel in each frame, with vertex normals.
  std::ifstream obj(out / "frames" / "cloth_0012.obj");
  std::string line;
  int objects = 0, normals = 0;
  while (std::getline(obj, line)) objects += line.rfind("o ", 0) == 0, normals += line.rfind("vn ", 0) == 0;
  EXPECT_EQ(objects, 3);
  // Seam partners are welded into one vertex in the OBJ: 4252 simulated vertices, 51 seam pairs.
  EXPECT_EQ(normals, 4201);
}

// `bench --sizes` takes the comma-separated list the README shows; each size gets a row, and the
// header names simulated seconds per wall second beside steps per second.
TEST(Cli, BenchTakesACommaSeparatedListOfSizes) {
  const fs::path dir = fresh_dir("bench");
  const Result r = run_cli("bench --sizes 8,12 --steps 3", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("sim s/s"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("seed_drape"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("square_8x8"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("square_12x12"), std::string::npos) << r.out;
  // A size that makes no cloth, or a negative step count, is refused before anything runs.
  Result bad = run_cli("bench --sizes 8,1", dir);
  EXPECT_NE(bad.code, 0);
  EXPECT_EQ(bad.err, "--sizes: Value 1 not in range 2 to 2048\nRun with --help for more information.\n");
  EXPECT_EQ(bad.out, "");
  bad = run_cli("bench --steps -3", dir);
  EXPECT_NE(bad.code, 0);
  EXPECT_EQ(bad.err, "--steps: Value -3 not in range 0 to 1000000000\nRun with --help for more information.\n");
}

TEST(Cli, BadSceneFailsWithMessageAndWritesNothing) {
  const fs::path dir = fresh_dir("bad");
  fs::create_directories(dir);
  std::ofstream(dir / "bad.json") << R"({"panels": [{"name": "a", "material": "nope", "size": [1, 1], "resolution": [3, 3]}]})";
  const Result r = run_cli("run " + (dir / "bad.json").string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "bad.json").string() + ": /panels/0/material: unknown material 'nope'\n");
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(Cli, UnstableTimeStepIsRefusedBeforeAnythingIsWritten) {
  const fs::path dir = fresh_dir("unstable");
  fs::create_directories(dir);
  std::ifstream seed(std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/seed_drape.json");
  std::stringstream ss;
  ss << seed.rdbuf();
  std::string text = ss.str();
  text.replace(text.find("\"dt\": 0.0004"), 12, "\"dt\": 0.01");
  std::ofstream(dir / "unstable.json") << text;
  const Result r = run_cli("run " + (dir / "unstable.json").string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("/time/dt: time step 0.01 s is not below the natural period T0"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(Cli, FormatOptionWritesTheChosenFormatsOnly) {
  const fs::path dir = fresh_dir("formats");
  const Result r = run_cli("run --quiet --duration 0.05 --format ply,pc2,glb --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const fs::path out = dir / "out";
  for (const char* f : {"frames/cloth_0000.ply", "frames/cloth_0002.ply", "cloth.pc2", "cloth_rest.obj", "cloth.glb",
                        "obstacles.obj", "run.json", "timing.json", "summary.png"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_FALSE(fs::exists(out / "frames" / "cloth_0000.obj"));
  std::ifstream in(out / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["outputs"], (nlohmann::json{"frames/cloth_*.ply", "cloth.pc2", "cloth_rest.obj", "cloth.glb",
                                          "obstacles.obj", "run.json", "timing.json", "summary.png"}));
}

TEST(Cli, BadFormatIsRefusedWithTheSceneFilesReasonBeforeAnythingIsWritten) {
  const fs::path dir = fresh_dir("bad_format");
  Result r = run_cli("run --format obj,fbx --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: command line: --format: unknown format 'fbx' (expected obj, ply, pc2 or glb)\n");
  r = run_cli("run --format ply,ply --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: command line: --format: format 'ply' is listed twice\n");
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(Cli, CheckFindsACrossingInAFolderAndExitsOne) {
  // A horizontal triangle and a vertical one whose lower edge passes through it, in one cloth frame.
  const fs::path dir = fresh_dir("check_crossing");
  fs::create_directories(dir / "out" / "frames");
  std::ofstream(dir / "out" / "frames" / "cloth_0003.obj") << "o sheet\nv -1 0 -1\nv 1 0 -1\nv 0 0 1\n"
                                                              "o wall\nv -0.2 -0.5 0\nv 0.2 -0.5 0\nv 0 0.5 0\n"
                                                              "f 1 2 3\nf 4 5 6\n";
  const Result r = run_cli("check " + (dir / "out").string(), dir);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("frame 0003: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(": 1 frames, 1 bad: 2 edge-triangle crossings and 0 vertices inside in all"), std::string::npos)
      << r.out;
}

TEST(Cli, CheckOfAFolderWithoutFramesSaysWhy) {
  const fs::path dir = fresh_dir("check_empty");
  fs::create_directories(dir / "out");
  Result r = run_cli("check " + (dir / "out").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "out").string() +
                       ": frames/: no cloth frames (frames/cloth_NNNN.obj) to check; was it run with --format obj?\n");
  r = run_cli("check " + (dir / "missing").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "missing").string() + ": not a folder\n");
  // A name the system refuses (too long) is not a folder either, not a filesystem_error.
  const std::string long_name = (dir / std::string(300, 'a')).string();
  r = run_cli("check " + long_name, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + long_name + ": not a folder\n");
}

TEST(Cli, RunWhosePenetrationCheckFailsExitsOneWithEverythingWritten) {
  // A press box driven down into a table box squeezes the cloth between them: no response can keep
  // every vertex out of both, and the run must say so rather than end as a success.
  const fs::path dir = fresh_dir("squeeze");
  fs::create_directories(dir);
  std::ofstream(dir / "squeeze.json") << raycloth::test::kSqueezeSceneJson;
  const fs::path out = dir / "out";
  const Result r = run_cli("run " + (dir / "squeeze.json").string() + " --quiet --out " + out.string(), dir);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(r.err.rfind("raycloth: error: " + out.string() + ": the exact check found penetration in ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("inside 'press'"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out / "run.json"));
  EXPECT_TRUE(fs::exists(out / "frames" / "cloth_0012.obj"));
  const Result c = run_cli("check --quiet " + out.string(), dir);
  EXPECT_EQ(c.code, 1) << c.out;
}

// Where a body moves, the implicit step is done in substeps, each a solve of its own; the warning of
// unconverged solves counted them against whole steps ("in 60 of 6 steps").
TEST(Cli, UnconvergedImplicitSolvesAreCountedAgainstSolvesWhereABodyMoves) {
  const fs::path dir = fresh_dir("unconverged");
  fs::create_directories(dir);
  std::ofstream(dir / "box.json") << R"({
    "time": {"dt": 0.016666666666666666, "integrator": "implicit", "iterations": 2, "tolerance": 1e-9, "duration": 0.1, "fps": 30},
    "materials": [{"name": "c", "density": 0.2, "stretch": 200, "shear": 40, "bend": 4, "damping": 1.0}],
    "panels": [{"name": "p", "material": "c", "size": [0.3, 0.3], "resolution": [8, 8], "position": [0, 0.3, 0]}],
    "pins": [{"panel": "p", "edge": "top"}],
    "obstacles": [{"name": "box", "type": "box", "size": [0.2, 0.2, 0.2], "position": [0, 0.1, 0],
                   "motion": {"velocity": [0.3, 0, 0]}}]})";
  const Result r = run_cli("run " + (dir / "box.json").string() + " --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(dir / "out" / "run.json");
  const nlohmann::json run = nlohmann::json::parse(in);
  const int steps = run["steps"], substeps = run["integrator"]["substeps"];
  const uint64_t solves = run["integrator"]["solves"];
  const uint64_t unconverged = run["integrator"]["unconverged_steps"];
  ASSERT_GT(substeps, 1);
  EXPECT_GT(solves, uint64_t(steps));
  EXPECT_LE(solves, uint64_t(steps * substeps));
  EXPECT_GT(unconverged, uint64_t(steps)) << "two sweeps seldom reach a tolerance of 1e-9 m: more solves than steps fail";
  EXPECT_LE(unconverged, solves);
  const std::string want = "the implicit integrator did not converge in " + std::to_string(unconverged) + " of " +
                           std::to_string(solves) + " solves (" + std::to_string(steps) + " steps, cut into up to " +
                           std::to_string(substeps) + " substeps)";
  EXPECT_NE(r.out.find(want), std::string::npos) << r.out;
}

// Trying another integrator or step on a scene without editing its file: --integrator, --dt and
// --iterations override the scene's time settings (run.json says what ran), and are checked as the
// file's would be, before anything is written.
TEST(Cli, TimeOptionsOverrideTheScenesAndAreCheckedBeforeAnythingIsWritten) {
  const fs::path dir = fresh_dir("time_options");
  fs::create_directories(dir);
  std::ofstream(dir / "sheet.json") << R"({
    "time": {"dt": 0.0004, "duration": 0.05, "fps": 30},
    "materials": [{"name": "c", "density": 0.2, "stretch": 200, "shear": 40, "bend": 4, "damping": 1.0}],
    "panels": [{"name": "p", "material": "c", "size": [0.3, 0.3], "resolution": [8, 8], "position": [0, 0.3, 0]}],
    "pins": [{"panel": "p", "edge": "top"}]})";
  const std::string scene = (dir / "sheet.json").string(), out = (dir / "out").string();
  Result r = run_cli("run " + scene + " --quiet --integrator implicit --dt 0.01 --iterations 7 --out " + out, dir);
  ASSERT_EQ(r.code, 0) << r.err;
  {
    std::ifstream in(dir / "out" / "run.json");
    const nlohmann::json run = nlohmann::json::parse(in);
    EXPECT_EQ(run["integrator"]["name"], "implicit");
    EXPECT_EQ(run["integrator"]["iterations"], 7);
    EXPECT_EQ(run["dt"], 0.01);
    EXPECT_EQ(run["steps"], 5);
  }
  fs::remove_all(dir / "out");
  const std::pair<std::string, std::string> bad[] = {
      {"--dt 0", "--dt: must be positive (got 0)"},
      {"--dt -0.001", "--dt: must be positive (got -0.001)"},
      {"--iterations 5", "--iterations: applies to the implicit integrator only (add --integrator implicit)"},
      {"--integrator implicit --iterations 0", "--iterations: must be between 1 and 1000 (got 0)"},
      {"--integrator implicit --iterations 1001", "--iterations: must be between 1 and 1000 (got 1001)"}};
  for (const auto& [args, why] : bad) {
    r = run_cli("run " + scene + " " + args + " --out " + out, dir);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(r.err, "raycloth: error: command line: " + why + "\n") << args;
    EXPECT_FALSE(fs::exists(dir / "out")) << args;
  }
  // A step the explicit step cannot take is refused by the same check as the file's, naming the
  // option.
  r = run_cli("run " + scene + " --dt 0.01 --out " + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err.rfind("raycloth: error: command line: --dt: time step 0.01 s is not below the natural period T0", 0), 0u)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  r = run_cli("run " + scene + " --integrator rk4 --out " + out, dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("--integrator: rk4 not in {explicit,implicit}"), std::string::npos) << r.err;
}
