// The raycloth command-line tool: each subcommand registers itself from its own file (cmd_*.cpp);
// main.cpp registers them all and runs the one chosen. What they share is in common.h.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace raycloth::cli {

// Each returns the action to run when its subcommand was chosen; the action returns the exit code.
using Action = std::function<int()>;
Action add_run_command(CLI::App& app);
Action add_resume_command(CLI::App& app);
Action add_bench_command(CLI::App& app);
Action add_render_command(CLI::App& app);
Action add_check_command(CLI::App& app);
Action add_fabric_command(CLI::App& app);
Action add_view_command(CLI::App& app);
Action add_batch_command(CLI::App& app);

}  // namespace raycloth::cli
