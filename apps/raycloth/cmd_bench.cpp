// `raycloth bench`: steps per second and time per stage for the default scene and for square
// cloths of about 4k, 16k, 64k and 256k vertices dropped on the sphere.
#include <fmt/format.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>

#include "commands.h"
#include "common.h"
#include "raycloth/simulator.h"
#include "sim/model.h"

namespace raycloth::cli {

namespace {

struct BenchArgs {
  std::string device = "cpu";
  std::vector<int> sizes{64, 128, 256, 512};
  int steps = 0;
  int threads = 0;
};

// A square cloth of n x n vertices, 1.5 m wide, just above the default scene's sphere. Stiffness
// and time step follow the spacing so that every size is as stable as the default scene.
SceneDef square_scene(int n) {
  SceneDef s = default_scene();
  s.name = fmt::format("square_{}x{}", n, n);
  const float spacing = 1.5f / float(n - 1), ratio = spacing / 0.03f;
  MaterialDef m = s.materials.front();
  m.stretch *= ratio, m.shear *= ratio, m.bend *= ratio;
  s.materials = {m};
  PanelDef p;
  p.name = "square";
  p.material = m.name;
  p.width = p.height = 1.5f;
  p.resolution_u = p.resolution_v = n;
  p.transform.position = {0, 0.505f, 0};
  s.panels = {p};
  s.seams.clear();
  s.pins.clear();
  s.time.dt = 4e-4 * std::sqrt(double(ratio));
  return s;
}

int run_case(const SceneDef& scene, const std::string& device, int warmup, int steps) {
  SimOptions opt;
  opt.device = device;
  Simulator sim(scene, opt);
  sim.step(warmup);
  const StageTimes before = sim.stage_times();
  const auto t0 = std::chrono::steady_clock::now();
  sim.step(steps);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const StageTimes& t = sim.stage_times();
  auto ms = [&](double a, double b) { return 1e3 * (a - b) / steps; };
  std::cout << fmt::format("{:<16} {:>8} {:>6} {:>10.0f} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f} {:>8}\n",
                           scene.name, sim.model().num_vertices(), steps, steps / wall,
                           steps * scene.time.dt / wall, ms(t.integrate, before.integrate),
                           ms(t.update, before.update), ms(t.cast, before.cast), ms(t.respond, before.respond),
                           ms(t.bound, before.bound), sim.last_hits());
  return 0;
}

}  // namespace

Action add_bench_command(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* bench = app.add_subcommand("bench", "Measure steps per second and time per stage");
  bench->add_option("--device", args->device, "cpu, cuda or auto")->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  bench->add_option("--sizes", args->sizes, "Square cloth resolutions (n for n x n vertices), comma-separated")
      ->delimiter(',')
      ->check(CLI::Range(2, 2048));
  bench->add_option("--steps", args->steps, "Timed steps per case (default: by size)")->check(CLI::Range(0, 1000000000));
  bench->add_option("--threads", args->threads, "Worker threads (default: all cores)");
  return [bench, args] {
    if (!bench->parsed()) return 0;
    return guarded([&] {
      std::optional<tbb::global_control> threads;
      if (args->threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(args->threads));
      std::cout << fmt::format("{:<16} {:>8} {:>6} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}\n", "scene",
                               "vertices", "steps", "steps/s", "sim s/s", "forces", "update", "rays", "respond",
                               "bound", "hits");
      std::cout << fmt::format("{:<16} {:>8} {:>6} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}\n", "", "", "",
                               "", "", "ms/step", "ms/step", "ms/step", "ms/step", "ms/step", "");
      // The default scene is timed while it drapes (after the first contacts at ~0.16 s).
      run_case(default_scene(), args->device, 500, args->steps > 0 ? args->steps : 2000);
      for (int n : args->sizes) {
        const int steps = args->steps > 0 ? args->steps : std::max(10, int(2000 * 4096.0 / (double(n) * n)));
        run_case(square_scene(n), args->device, 50, steps);
      }
      return 0;
    });
  };
}

}  // namespace raycloth::cli
