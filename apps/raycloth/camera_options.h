// Camera options shared by `run` and `render`: --camera-pos, --camera-target, --fov, --resolution,
// --samples. They override the scene's output.camera and are checked like it.
#pragma once
#include <CLI/CLI.hpp>
#include <string>

#include "raycloth/scene.h"

namespace raycloth::cli {

struct CameraArgs {
  std::string position, target, fov, resolution, samples;  // empty: not given
};

void add_camera_options(CLI::App* app, CameraArgs& args);
// Writes the given options into `output.camera`, then validate_output(output, "command line");
// throws InputError naming the output field, e.g. "command line: /output/camera/fov: ...".
void apply_camera_options(const CameraArgs& args, OutputDef& output);

}  // namespace raycloth::cli
