// Built only when CMake found no CUDA compiler: the CUDA backend reports why it cannot run.
#include "raycloth/error.h"
#include "sim/backend.h"

namespace raycloth {

bool cuda_usable(std::string* why) {
  if (why) *why = "raycloth was built without the CUDA backend (CMake found no nvcc)";
  return false;
}

void cuda_pose_obstacles(const ObstacleSet&, double, std::vector<Vec3>&, std::vector<Vec3>&) {
  std::string why;
  cuda_usable(&why);
  throw SimulationError("device 'cuda' cannot run: " + why);
}

std::unique_ptr<Backend> make_cuda_backend(const BackendInput&) {
  std::string why;
  cuda_usable(&why);
  throw SimulationError("device 'cuda' cannot run: " + why);
}

}  // namespace raycloth
