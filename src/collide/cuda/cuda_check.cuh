// Every CUDA runtime call is checked: a failure throws SimulationError naming the call's file and
// line, the CUDA error name and its description.
#pragma once
#include <cuda_runtime.h>

#include <string>

#include "raycloth/error.h"

namespace raycloth {

inline void cuda_check(cudaError_t e, const char* call, const char* file, int line) {
  if (e == cudaSuccess) return;
  throw SimulationError(std::string("CUDA error at ") + file + ":" + std::to_string(line) + ": " + call + " failed: " +
                        cudaGetErrorName(e) + " (" + cudaGetErrorString(e) + ")");
}

}  // namespace raycloth

#define CUDA_CHECK(call) ::raycloth::cuda_check((call), #call, __FILE__, __LINE__)
// After a kernel launch: launch-configuration errors surface here, faults at the next sync.
#define CUDA_CHECK_LAUNCH() ::raycloth::cuda_check(cudaGetLastError(), "kernel launch", __FILE__, __LINE__)
