// What the raycloth commands share: errors turned into exit codes, and the video of an output
// folder. Commands include this; main.cpp only registers and calls the commands (commands.h).
#pragma once
#include <functional>
#include <string>

namespace raycloth::cli {

// Runs `body`, turning library errors into a message on stderr and an exit code:
// 2 for bad input, 1 for a simulation or I/O failure.
int guarded(const std::function<int()>& body);

// Makes out_dir/video.mp4 from its images; a missing ffmpeg is a warning on stderr (exit code 0),
// a failing one an error (std::runtime_error).
int assemble_video(const std::string& out_dir, int frames, double fps, bool quiet);

}  // namespace raycloth::cli
