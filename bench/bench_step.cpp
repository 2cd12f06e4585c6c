// Google Benchmark: one simulation step of the default scene and of square cloths on the sphere.
#include <benchmark/benchmark.h>

#include "raycloth/simulator.h"

static void BM_DefaultSceneStep(benchmark::State& state) {
  raycloth::Simulator sim(raycloth::default_scene());
  sim.step(200);
  for (auto _ : state) sim.step(1);
  state.counters["steps/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DefaultSceneStep)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
