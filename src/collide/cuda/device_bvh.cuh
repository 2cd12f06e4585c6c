// The LBVH of collide/bvh.h in device memory: built with CUB (reduce, stable radix sort) and the
// shared per-node functions as kernels, refit by one thread per leaf. Every call only enqueues
// work on the given stream; refit() and area() can be captured into a CUDA graph, build() cannot
// (CUB's temporary storage is sized outside the graph, but keep builds out of the stepping graph).
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "collide/bvh.h"
#include "collide/cuda/device_buffer.cuh"

namespace raycloth {

class DeviceBvh {
 public:
  // Allocates the tree and the build scratch for `num_prims` triangles.
  void allocate(uint32_t num_prims);
  // Full build over the triangles `indices` (3 per triangle) of `vertices`, both device pointers;
  // writes the summed internal-node area of the fresh tree to `built_area` (device) if given.
  void build(const Vec3* vertices, const uint32_t* indices, cudaStream_t stream, float* built_area = nullptr);
  // With `only_if` (a device flag), the refit kernel does nothing while the flag reads 0 when it
  // runs: a graph can then skip refits that the device decides are not needed.
  void refit(const Vec3* vertices, const uint32_t* indices, cudaStream_t stream,
             const unsigned int* only_if = nullptr);
  // Summed half areas of the internal nodes (bvh_area on the host), into `out` (device).
  void area(float* out, cudaStream_t stream) const;
  BvhView view() const;
  uint32_t num_prims() const { return num_prims_; }

 private:
  uint32_t num_prims_ = 0;
  DeviceBuffer<uint32_t> child_, parent_, prim_, counter_, ids_;
  DeviceBuffer<Aabb> bounds_, centroid_boxes_, scene_box_;
  DeviceBuffer<uint64_t> codes_, sorted_codes_;
  DeviceBuffer<unsigned char> temp_;
};

}  // namespace raycloth
