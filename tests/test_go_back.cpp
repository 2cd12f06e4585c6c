// Backend::keep and back: where the implicit integrator's step let cloth into a moving body, the
// Simulator takes it again from the state it started from (Simulator::advance). After back() the
// backend's state is the kept one bit for bit, and steps from it give what they gave the first time.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/simulator.h"
#include "sim/backend.h"
#include "sim/model.h"

namespace raycloth {
namespace {

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

// The sliding sphere under a sheet (scenes/moving_sphere.json), moving from the start, with the
// implicit integrator at 1/240 s: its state after 6 steps kept, 3 steps on, back, the same 3 again.
void expect_steps_again_bit_for_bit(const std::string& device) {
  SceneDef s = load_scene_file(std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/moving_sphere.json");
  s.time.integrator = Integrator::Implicit;
  s.time.dt = 1.0 / 240.0;
  s.time.iterations = 10;
  s.obstacles[0].motion->start = 0.0;
  s.panels[0].transform.position = {0, 0.4025f, 0};  // 0.5 mm beyond the thickness over its top
  const ClothModel model = build_cloth_model(s);
  const ObstacleSet obstacles = build_obstacles(s);
  const BackendInput in{&s, &model, &obstacles, {}};
  auto backend = device == "cuda" ? make_cuda_backend(in) : make_cpu_backend(in);
  ASSERT_TRUE(backend->can_go_back());
  StageTimes times;
  std::vector<Vec3> x0, v0, x1, v1, x, v;
  ASSERT_LT(backend->step(6, 0, times).bad_vertex, 0);
  backend->download(x0, v0);
  backend->keep();
  const StepResult first = backend->step(3, 6, times);
  backend->download(x1, v1);
  ASSERT_FALSE(same_bits(x0, x1));
  EXPECT_GT(first.totals.pushed, 0u) << "the sheet should lie on the moving sphere";
  for (int again = 0; again < 2; ++again) {  // back() may be asked for more than once
    backend->back();
    backend->download(x, v);
    EXPECT_TRUE(same_bits(x, x0) && same_bits(v, v0)) << "back " << again;
    const StepResult r = backend->step(3, 6, times);
    backend->download(x, v);
    EXPECT_TRUE(same_bits(x, x1) && same_bits(v, v1)) << "steps again " << again;
    EXPECT_EQ(r.totals.pushed, first.totals.pushed);
    EXPECT_EQ(r.totals.clamped, first.totals.clamped);
  }
}

TEST(GoBack, StepsTakenAgainFromTheKeptStateGiveTheSameStatesBitForBit) { expect_steps_again_bit_for_bit("cpu"); }

// The same on the GPU (device-to-device copies of the state and the obstacles' pose).
TEST(GoBack, CudaStepsTakenAgainFromTheKeptStateGiveTheSameStatesBitForBit) {
  std::string why;
  if (!cuda_usable(&why)) GTEST_SKIP() << "CUDA backend cannot run: " << why;
  expect_steps_again_bit_for_bit("cuda");
}

}  // namespace
}  // namespace raycloth
