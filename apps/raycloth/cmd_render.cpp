// `raycloth render DIR`: images (and a video) of an existing output folder of `raycloth run`.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <iostream>
#include <memory>
#include <optional>

#include "camera_options.h"
#include "commands.h"
#include "common.h"
#include "render/image_frames.h"

namespace raycloth::cli {

namespace {
struct RenderArgs {
  std::string dir;
  bool video = false;
  bool quiet = false;
  int threads = 0;
  CameraArgs camera;
};
}  // namespace

Action add_render_command(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* render = app.add_subcommand("render", "Render DIR/images/frame_NNNN.png for an output folder of `run`");
  render->add_option("dir", args->dir, "Output folder of raycloth run")->required();
  render->add_flag("--video", args->video, "Also assemble DIR/video.mp4 (needs ffmpeg)");
  render->add_option("--threads", args->threads, "Worker threads (default: all cores)");
  render->add_flag("-q,--quiet", args->quiet, "No progress output");
  add_camera_options(render, args->camera);
  return [render, args] {
    if (!render->parsed()) return 0;
    return guarded([&] {
      std::optional<tbb::global_control> threads;
      if (args->threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(args->threads));
      const OutputFolder folder = read_output_folder(args->dir);
      OutputDef output;
      output.camera = folder.camera;
      apply_camera_options(args->camera, output);
      render_output_folder(folder, output.camera, [&](int done, int total) {
        if (!args->quiet && (done * 10 / total != (done - 1) * 10 / total || done == total))
          spdlog::info("rendered frame {}/{}", done, total);
      });
      if (!args->quiet)
        std::cout << fmt::format("wrote {}/images/frame_*.png ({} frames)\n", args->dir, folder.frames.size());
      if (args->video) return assemble_video(args->dir, int(folder.frames.size()), folder.fps, args->quiet);
      return 0;
    });
  };
}

}  // namespace raycloth::cli
