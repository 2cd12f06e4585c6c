// Small scenes built in code for the tests.
#pragma once
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "sim/model_check.h"
#include "sim/stage_time.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "raycloth/simulator.h"

namespace raycloth::test {

// The executor of sim/step.h in one thread, for running a stage sequence on its own (the bound's
// refresh, the swept bound): counters are read where they are.
struct SerialExec {
  template <class F>
  void for_each(Stage, uint32_t n, F&& f) {
    for (uint32_t i = 0; i < n; ++i) f(i);
  }
  template <class F, class T>
  void sum(Stage, uint32_t n, F&& f, T* slot) {
    for (uint32_t i = 0; i < n; ++i) *slot += f(i);
  }
  uint32_t peek(const uint32_t* slot, uint32_t) const { return *slot; }
};

// f() throws InputError with exactly `message`.
inline void expect_input_error(const std::function<void()>& f, const std::string& message) {
  try {
    f();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), message);
    return;
  }
  ADD_FAILURE() << "no InputError thrown; expected: " << message;
}

inline OutlineSegment seg(const std::string& name, float x, float y) {
  OutlineSegment s;
  s.name = name;
  s.from = {x, y};
  return s;
}

// A w x h rectangle pattern (bottom, right, top, left), meshed at edge length e, standing in the
// x-y plane at `at`.
inline PanelDef rect_pattern(const std::string& name, float w, float h, float e, Float3 at) {
  PanelDef p;
  p.name = name;
  p.material = "test";
  p.shape = PanelShape::Pattern;
  p.pattern.edge_length = e;
  p.pattern.outline = {seg("bottom", -w / 2, 0), seg("right", w / 2, 0), seg("top", w / 2, h), seg("left", -w / 2, h)};
  p.transform.position = at;
  return p;
}

inline MaterialDef test_material(float damping = 0.0f) {
  MaterialDef m;
  m.name = "test";
  m.density = 0.2f;
  m.stretch = 200.0f;
  m.shear = 40.0f;
  m.bend = 4.0f;
  m.damping = damping;
  return m;
}

// One horizontal square panel of n x n vertices and `size` metres at height y, no obstacles.
inline SceneDef panel_scene(int n, float size, float y, float damping = 0.0f) {
  SceneDef s;
  s.name = "test_panel";
  s.time.dt = 4e-4;
  s.time.duration = 0.1;
  s.materials.push_back(test_material(damping));
  PanelDef p;
  p.name = "cloth";
  p.material = "test";
  p.width = p.height = size;
  p.resolution_u = p.resolution_v = n;
  p.transform.position = {0, y, 0};
  s.panels.push_back(p);
  return s;
}

// A press box driven down into a table box squeezes a sheet between them: no response can keep every
// vertex out of both, so frames fail the exact check (a run that must say so).
inline const char* const kSqueezeSceneJson = R"({
    "name": "squeeze", "time": {"dt": 0.0004, "duration": 0.4, "fps": 30},
    "materials": [{"name": "cotton", "density": 0.2, "stretch": 200, "shear": 40, "bend": 4, "damping": 1.0}],
    "panels": [{"name": "cloth", "material": "cotton", "size": [0.6, 0.6], "resolution": [11, 11],
                "position": [0, 0.21, 0]}],
    "obstacles": [{"name": "table", "type": "box", "size": [0.4, 0.2, 0.4], "position": [0, 0.1, 0]},
                  {"name": "press", "type": "box", "size": [0.2, 0.2, 0.2], "position": [0, 0.35, 0],
                   "motion": {"velocity": [0, -0.5, 0]}}]})";

inline ObstacleDef sphere_obstacle(float radius, Float3 at) {
  ObstacleDef o;
  o.name = "sphere";
  o.type = ObstacleType::UvSphere;
  o.radius = radius;
  o.transform.position = at;
  return o;
}

inline ObstacleDef box_obstacle(Float3 size, Float3 at) {
  ObstacleDef o;
  o.name = "box";
  o.type = ObstacleType::Box;
  o.size = size;
  o.transform.position = at;
  return o;
}

inline ObstacleDef plane_obstacle(float size, Float3 at) {
  ObstacleDef o;
  o.name = "plane";
  o.type = ObstacleType::Plane;
  o.size = {size, 1, size};
  o.transform.position = at;
  return o;
}

// The exact check (check/exact_check.h) of the simulator's state now.
inline CheckReport exact_check(Simulator& sim) {
  return check_state(cloth_check_mesh(sim.model(), sim.positions()),
                     obstacle_check_mesh(sim.obstacles(), sim.obstacle_vertices()));
}

// Steps n times and checks exactly after every `every` steps: "" when every check was clean,
// else the step and what the first unclean check found.
inline std::string step_checked(Simulator& sim, int n, int every = 1) {
  for (int k = 0; k < n; k += every) {
    sim.step(std::min(every, n - k));
    const CheckReport r = exact_check(sim);
    if (!r.clean()) return fmt::format("after step {}: {}", sim.steps(), describe(r));
  }
  return "";
}

}  // namespace raycloth::test
