#include <spdlog/spdlog.h>

#include <iostream>
#include <vector>

#include "commands.h"
#include "raycloth/error.h"
#include "render/video.h"

namespace raycloth::cli {

int guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << "raycloth: error: " << e.what() << "\n";
    return 2;
  } catch (const SimulationError& e) {
    std::cerr << "raycloth: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "raycloth: error: " << e.what() << "\n";
    return 1;
  }
}

int assemble_video(const std::string& out_dir, int frames, double fps, bool quiet) {
  const VideoResult v = make_video(out_dir, frames, fps);
  if (!v.written) {
    std::cerr << "raycloth: warning: " << v.warning << "\n";
    return 0;
  }
  if (!quiet) std::cout << "wrote " << out_dir << "/video.mp4\n";
  return 0;
}

}  // namespace raycloth::cli

int main(int argc, char** argv) {
  CLI::App app{"raycloth: mass-spring cloth with ray-traced collision detection"};
  app.require_subcommand(1);
  spdlog::set_pattern("[%H:%M:%S] %^%l%$ %v");
  std::vector<std::pair<CLI::App*, raycloth::cli::Action>> actions;
  raycloth::cli::Action run = raycloth::cli::add_run_command(app);
  raycloth::cli::Action resume = raycloth::cli::add_resume_command(app);
  raycloth::cli::Action bench = raycloth::cli::add_bench_command(app);
  raycloth::cli::Action render = raycloth::cli::add_render_command(app);
  raycloth::cli::Action check = raycloth::cli::add_check_command(app);
  raycloth::cli::Action fabric = raycloth::cli::add_fabric_command(app);
  raycloth::cli::Action view = raycloth::cli::add_view_command(app);
  CLI11_PARSE(app, argc, argv);
  for (auto* sub : app.get_subcommands()) {
    if (sub->get_name() == "run") return run();
    if (sub->get_name() == "resume") return resume();
    if (sub->get_name() == "bench") return bench();
    if (sub->get_name() == "render") return render();
    if (sub->get_name() == "check") return check();
    if (sub->get_name() == "fabric-test") return fabric();
    if (sub->get_name() == "view") return view();
  }
  return 1;
}
