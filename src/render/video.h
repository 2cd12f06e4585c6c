// video.mp4 from a folder's rendered images, by ffmpeg (H.264, yuv420p).
#pragma once
#include <filesystem>
#include <string>

namespace raycloth {

struct VideoResult {
  bool written = false;
  std::string warning;  // why there is no video when ffmpeg could not be started
};

// The ffmpeg program: $RAYCLOTH_FFMPEG when set, otherwise "ffmpeg" looked up on PATH.
std::string ffmpeg_program();

// Assembles out_dir/video.mp4 from out_dir/images/frame_0000.png .. frame_<frames-1>.png at `fps`
// (odd sizes padded to even), under a temporary name renamed at the end. When ffmpeg cannot be
// started, returns a warning and leaves the images; when ffmpeg fails, throws std::runtime_error
// with the end of its error output.
VideoResult make_video(const std::filesystem::path& out_dir, int frames, double fps);

}  // namespace raycloth
