// Google Benchmark: one 1280x720 image (4 samples per pixel) of the default scene after 1 s of
// simulated time, the view framed as `raycloth run --duration 1 --render` frames its last image.
#include <benchmark/benchmark.h>

#include "raycloth/simulator.h"
#include "render/renderer.h"

namespace {

struct DrapedFrame {
  raycloth::RenderScene scene;
  raycloth::Bounds seen;
};

const DrapedFrame& draped_frame() {
  static const DrapedFrame frame = [] {
    raycloth::Simulator sim(raycloth::default_scene());
    DrapedFrame f;
    f.seen = raycloth::make_render_scene(sim).bounds();
    sim.step(2500);  // 1 s at dt = 0.4 ms
    f.scene = raycloth::make_render_scene(sim);
    f.seen.add(f.scene.bounds());
    return f;
  }();
  return frame;
}

}  // namespace

static void BM_RenderDefaultScene1280x720(benchmark::State& state) {
  const DrapedFrame& f = draped_frame();
  const raycloth::View view = raycloth::make_view(f.seen, raycloth::CameraDef{});
  raycloth::Renderer renderer;
  for (auto _ : state) benchmark::DoNotOptimize(renderer.render(f.scene, view));
  state.counters["frames/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderDefaultScene1280x720)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Repetitions(5);
