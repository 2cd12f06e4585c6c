// The raycloth command-line tool: each subcommand registers itself from its own file.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace raycloth::cli {

// Each returns the action to run when its subcommand was chosen; the action returns the exit code.
using Action = std::function<int()>;
Action add_run_command(CLI::App& app);
Action add_bench_command(CLI::App& app);

// Runs `body`, turning library errors into a message on stderr and an exit code:
// 2 for bad input, 1 for a simulation or I/O failure.
int guarded(const std::function<int()>& body);

}  // namespace raycloth::cli
