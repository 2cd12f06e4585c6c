// The raycloth command-line tool: each subcommand registers itself from its own file.
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

// Runs `body`, turning library errors into a message on stderr and an exit code:
// 2 for bad input, 1 for a simulation or I/O failure.
int guarded(const std::function<int()>& body);

// Makes out_dir/video.mp4 from its images; a missing ffmpeg is a warning on stderr (exit code 0),
// a failing one an error (std::runtime_error).
int assemble_video(const std::string& out_dir, int frames, double fps, bool quiet);

}  // namespace raycloth::cli
