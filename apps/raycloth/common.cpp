#include "common.h"

#include <iostream>

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
