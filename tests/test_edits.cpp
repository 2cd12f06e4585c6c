// Edits of a Simulator between steps (sim/simulator_edit.cpp) and the caller's hooks in run_scene
// (on_frame, between_steps): what the Python module is built on.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "fixtures.h"
#include "io/run.h"
#include "raycloth/error.h"
#include "sim/model.h"

namespace raycloth {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("raycloth_edits_" + name);
  fs::remove_all(d);
  return d;
}

TEST(SimulatorEdits, SetStateThenOneStepFallsFreely) {
  // A flat panel at rest lifted 2 m with no velocity: one explicit Euler step gives v = g dt and
  // x += v dt (every vertex has the same height, so no spring changes length).
  Simulator sim(test::panel_scene(8, 0.21f, 0.5f, 1.0f));
  sim.step(10);
  std::vector<Vec3> x = sim.model().initial_positions;
  for (Vec3& p : x) p.y += 2.0f;
  sim.set_state(x, std::vector<Vec3>(x.size(), make_vec3(0, 0, 0)));
  EXPECT_EQ(sim.positions()[5].y, x[5].y);
  sim.step(1);
  const float dt = 4e-4f;
  for (size_t i = 0; i < x.size(); ++i) {
    EXPECT_NEAR(sim.velocities()[i].y, -9.81f * dt, 1e-6f) << i;
    EXPECT_NEAR(sim.velocities()[i].x, 0.0f, 1e-6f) << i;
    EXPECT_NEAR(sim.positions()[i].y, x[i].y - 9.81f * dt * dt, 1e-6f) << i;
  }
  EXPECT_THROW(sim.set_state(std::vector<Vec3>(3), std::vector<Vec3>(3)), InputError);
  x[0].x = NAN;
  try {
    sim.set_state(x, x);
    FAIL() << "a NaN position was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "positions[0]");
  }
}

TEST(SimulatorEdits, PinnedVerticesStayPut) {
  Simulator sim(test::panel_scene(8, 0.21f, 0.5f, 1.0f));
  const std::vector<uint32_t> corners{0, 7, 56, 63};
  sim.pin(corners);
  const std::vector<Vec3> x0 = sim.positions();
  sim.step(100);
  for (uint32_t c : corners) {
    EXPECT_EQ(sim.positions()[c].y, x0[c].y);
    EXPECT_EQ(sim.velocities()[c].y, 0.0f);
  }
  EXPECT_LT(sim.positions()[27].y, x0[27].y - 0.005f);
  EXPECT_THROW(sim.pin({64}), InputError);
}

TEST(SimulatorEdits, AnObstacleMovedByHandMovesOverOneStepThenRests) {
  SceneDef s = test::panel_scene(8, 0.21f, 0.5f, 1.0f);
  s.obstacles.push_back(test::sphere_obstacle(0.2f, {0, 0, 0}));
  Simulator sim(s);
  sim.step(3);
  const std::vector<Vec3> from = sim.obstacle_vertices();
  std::vector<Vec3> to = from;
  for (Vec3& p : to) p.y += 0.001f;
  sim.move_obstacle(0, to);
  EXPECT_EQ(sim.obstacle_vertices()[0].y, from[0].y);  // it moves with the next step
  std::vector<Vec3> x, v;
  const double dt = s.time.dt;
  sim.obstacles().pose_at(4 * dt, x, v);  // the end of the next step, as the backend poses it
  EXPECT_EQ(x[0].y, to[0].y);
  EXPECT_NEAR(v[0].y, 0.001 / dt, 1e-3);
  sim.step(1);
  EXPECT_EQ(sim.obstacle_vertices()[9].y, to[9].y);
  sim.obstacles().pose_at(5 * dt, x, v);
  EXPECT_EQ(x[0].y, to[0].y);
  EXPECT_EQ(v[0].y, 0.0f);
  EXPECT_THROW(sim.move_obstacle(1, to), InputError);
  EXPECT_THROW(sim.move_obstacle(0, std::vector<Vec3>(3)), InputError);
}

RunOptions quiet_options(const fs::path& out) {
  RunOptions opt;
  opt.out_dir = out;
  opt.quiet = true;
  opt.formats = std::vector<std::string>{"obj", "pc2"};
  opt.checkpoint_every = 1;
  return opt;
}

TEST(RunHooks, StepByStepWithACallbackWritesTheSameRun) {
  SceneDef s = test::panel_scene(8, 0.21f, 0.5f, 1.0f);
  s.time.duration = 0.1;
  const fs::path a = fresh_dir("plain"), b = fresh_dir("hooks");
  run_scene(s, quiet_options(a));
  RunOptions opt = quiet_options(b);
  int steps = 0, frames = 0;
  opt.between_steps = [&] { ++steps; };
  opt.on_frame = [&](Simulator& sim, const FrameRecord& r) {
    EXPECT_EQ(r.index, frames++);
    EXPECT_EQ(r.step, sim.steps());
  };
  run_scene(s, opt);
  EXPECT_EQ(steps, 250);
  EXPECT_EQ(frames, 5);  // 0, and 83, 166, 249, 250
  EXPECT_EQ(read_all(a / "run.json"), read_all(b / "run.json"));
  EXPECT_EQ(read_all(a / "cloth.pc2"), read_all(b / "cloth.pc2"));
  EXPECT_EQ(read_all(a / "frames" / "cloth_0004.obj"), read_all(b / "frames" / "cloth_0004.obj"));
}

TEST(RunHooks, ACallbackThatThrowsStopsTheRunCleanly) {
  SceneDef s = test::panel_scene(8, 0.21f, 0.5f, 1.0f);
  s.time.duration = 0.2;
  const fs::path out = fresh_dir("stop");
  RunOptions opt = quiet_options(out);
  opt.on_frame = [](Simulator&, const FrameRecord& r) {
    if (r.index == 2) throw std::logic_error("enough");
  };
  EXPECT_THROW(run_scene(s, opt), std::logic_error);
  const nlohmann::json j = nlohmann::json::parse(read_all(out / "run.json"));
  EXPECT_EQ(j["error"], "stopped by the caller at step 166 (t = 0.0664 s): enough");
  EXPECT_EQ(j["frames"].size(), 3u);
  EXPECT_TRUE(fs::exists(out / "frames" / "cloth_0002.obj"));
  EXPECT_FALSE(fs::exists(out / "frames" / "cloth_0003.obj"));
  EXPECT_FALSE(fs::exists(out / "checkpoint.bin"));
  const std::string pc2 = read_all(out / "cloth.pc2");
  ASSERT_EQ(pc2.size(), 32u + 3 * 64 * 12);
  EXPECT_FALSE(fs::exists(out / "cloth.pc2.tmp"));
  // A throw between steps: the same, at that step.
  const fs::path out2 = fresh_dir("stop_step");
  RunOptions opt2 = quiet_options(out2);
  int calls = 0;
  opt2.between_steps = [&] {
    if (++calls == 100) throw std::runtime_error("interrupted");
  };
  EXPECT_THROW(run_scene(s, opt2), std::runtime_error);
  const nlohmann::json j2 = nlohmann::json::parse(read_all(out2 / "run.json"));
  EXPECT_EQ(j2["error"], "stopped by the caller at step 100 (t = 0.04 s): interrupted");
  EXPECT_EQ(j2["frames"].size(), 2u);
  EXPECT_FALSE(fs::exists(out2 / "checkpoint.bin"));
}

}  // namespace
}  // namespace raycloth
