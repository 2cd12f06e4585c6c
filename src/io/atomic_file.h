// Whole-file writes: content goes to a temporary name beside the target and is renamed over it,
// so an interrupted run leaves only complete files.
#pragma once
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>

namespace raycloth {

// Calls `write` with a stream on "<path>.tmp", then renames it to `path`. Throws std::runtime_error
// naming the file when it cannot be written.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

}  // namespace raycloth
