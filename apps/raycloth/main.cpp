#include <spdlog/spdlog.h>

#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{"raycloth: mass-spring cloth with ray-traced collision detection"};
  app.require_subcommand(1);
  spdlog::set_pattern("[%H:%M:%S] %^%l%$ %v");
  raycloth::cli::Action run = raycloth::cli::add_run_command(app);
  raycloth::cli::Action resume = raycloth::cli::add_resume_command(app);
  raycloth::cli::Action bench = raycloth::cli::add_bench_command(app);
  raycloth::cli::Action render = raycloth::cli::add_render_command(app);
  raycloth::cli::Action check = raycloth::cli::add_check_command(app);
  raycloth::cli::Action fabric = raycloth::cli::add_fabric_command(app);
  raycloth::cli::Action view = raycloth::cli::add_view_command(app);
  raycloth::cli::Action batch = raycloth::cli::add_batch_command(app);
  CLI11_PARSE(app, argc, argv);
  for (auto* sub : app.get_subcommands()) {
    if (sub->get_name() == "run") return run();
    if (sub->get_name() == "resume") return resume();
    if (sub->get_name() == "bench") return bench();
    if (sub->get_name() == "render") return render();
    if (sub->get_name() == "check") return check();
    if (sub->get_name() == "fabric-test") return fabric();
    if (sub->get_name() == "view") return view();
    if (sub->get_name() == "batch") return batch();
  }
  return 1;
}
