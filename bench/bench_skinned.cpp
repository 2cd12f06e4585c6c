// Posing the walking man: what ObstacleSet::pose_at costs per step for a skinned body (joint matrices
// at t and 0.5 ms either side, then every vertex skinned twice: its position and, with the joint
// matrices' rate of change, its surface velocity), against one whole step of the scene.
#include <benchmark/benchmark.h>

#include "raycloth/scene.h"
#include "raycloth/simulator.h"
#include "sim/model.h"

namespace {

raycloth::SceneDef walking() {
  return raycloth::load_scene_file(std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/walking_body.json");
}

void BM_WalkingManPoseAt(benchmark::State& state) {
  const raycloth::ObstacleSet set = raycloth::build_obstacles(walking());
  std::vector<raycloth::Vec3> x, v;
  double t = 1.0;
  for (auto _ : state) {
    set.pose_at(t, x, v);
    benchmark::DoNotOptimize(x.data());
    t += 4e-4;
  }
}
BENCHMARK(BM_WalkingManPoseAt)->Unit(benchmark::kMicrosecond);

void BM_WalkingBodyStep(benchmark::State& state) {
  raycloth::Simulator sim(walking());
  sim.step(2500);  // 1 s: the cloth is on him and he walks
  for (auto _ : state) sim.step(1);
}
BENCHMARK(BM_WalkingBodyStep)->Unit(benchmark::kMicrosecond);

}  // namespace
