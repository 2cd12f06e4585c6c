// Device build and refit of the LBVH: the per-node RC_HD functions of collide/bvh.h as kernels.
#include "collide/cuda/device_bvh.cuh"

#include <cub/block/block_reduce.cuh>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>

#include <algorithm>

namespace raycloth {

namespace {

constexpr int kBlock = 256;
inline unsigned grid_for(uint32_t n) { return (n + kBlock - 1) / kBlock; }

struct AabbUnion {
  RC_HD Aabb operator()(const Aabb& a, const Aabb& b) const { return aabb_union(a, b); }
};

__global__ void k_centroid_boxes(const Vec3* vertices, const uint32_t* indices, uint32_t n, Aabb* boxes) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const Vec3 c = triangle_centroid(vertices, indices, i);
  boxes[i].lo = c;
  boxes[i].hi = c;
}

__global__ void k_morton(const Vec3* vertices, const uint32_t* indices, uint32_t n, const Aabb* scene_box,
                         uint64_t* codes, uint32_t* ids) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  codes[i] = morton_code(triangle_centroid(vertices, indices, i), *scene_box);
  ids[i] = i;
}

__global__ void k_internal_nodes(BvhView b, const uint64_t* sorted_codes) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i + 1 >= b.num_prims) return;
  build_internal_node(b, sorted_codes, i);
}

__global__ void k_refit(BvhView b, const Vec3* vertices, const uint32_t* indices, const unsigned int* only_if) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= b.num_prims || (only_if && *only_if == 0u)) return;
  refit_from_leaf(b, vertices, indices, k);
}

// One block, in double, in a fixed order: the same sum on every run.
__global__ void k_area(BvhView b, float* out) {
  using Reduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename Reduce::TempStorage temp;
  const uint32_t n = b.num_prims;
  double sum = 0;
  if (n == 1) {
    if (threadIdx.x == 0) sum = aabb_half_area(b.bounds[0]);
  } else {
    for (uint32_t i = threadIdx.x; i + 1 < n; i += blockDim.x) sum += internal_node_area(b, i);
  }
  const double total = Reduce(temp).Sum(sum);
  if (threadIdx.x == 0) *out = float(total);
}

}  // namespace

void DeviceBvh::allocate(uint32_t num_prims) {
  num_prims_ = num_prims;
  const uint32_t n = num_prims;
  if (n == 0) return;
  child_.resize(n > 1 ? 2 * size_t(n - 1) : 1);
  parent_.resize(bvh_num_nodes(n));
  bounds_.resize(bvh_num_nodes(n));
  prim_.resize(n);
  counter_.resize(n > 1 ? n - 1 : 1);
  ids_.resize(n);
  centroid_boxes_.resize(n);
  scene_box_.resize(1);
  codes_.resize(n);
  sorted_codes_.resize(n);
  size_t reduce_bytes = 0, sort_bytes = 0;
  CUDA_CHECK(cub::DeviceReduce::Reduce(nullptr, reduce_bytes, centroid_boxes_.data(), scene_box_.data(), int(n),
                                       AabbUnion(), Aabb()));
  CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, sort_bytes, codes_.data(), sorted_codes_.data(), ids_.data(),
                                             prim_.data(), int(n), 0, 63));
  temp_.resize(std::max<size_t>(std::max(reduce_bytes, sort_bytes), 1));
}

void DeviceBvh::build(const Vec3* vertices, const uint32_t* indices, cudaStream_t stream, float* built_area) {
  const uint32_t n = num_prims_;
  if (n == 0) return;
  k_centroid_boxes<<<grid_for(n), kBlock, 0, stream>>>(vertices, indices, n, centroid_boxes_.data());
  CUDA_CHECK_LAUNCH();
  size_t bytes = temp_.size();
  CUDA_CHECK(cub::DeviceReduce::Reduce(temp_.data(), bytes, centroid_boxes_.data(), scene_box_.data(), int(n),
                                       AabbUnion(), Aabb(), stream));
  k_morton<<<grid_for(n), kBlock, 0, stream>>>(vertices, indices, n, scene_box_.data(), codes_.data(), ids_.data());
  CUDA_CHECK_LAUNCH();
  // Stable, like std::stable_sort on the host: equal codes keep triangle order.
  bytes = temp_.size();
  CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp_.data(), bytes, codes_.data(), sorted_codes_.data(), ids_.data(),
                                             prim_.data(), int(n), 0, 63, stream));
  CUDA_CHECK(cudaMemsetAsync(parent_.data(), 0xFF, sizeof(uint32_t), stream));  // root: kBvhNone
  if (n > 1) {
    k_internal_nodes<<<grid_for(n - 1), kBlock, 0, stream>>>(view(), sorted_codes_.data());
    CUDA_CHECK_LAUNCH();
  }
  refit(vertices, indices, stream);
  if (built_area) area(built_area, stream);
}

void DeviceBvh::refit(const Vec3* vertices, const uint32_t* indices, cudaStream_t stream,
                      const unsigned int* only_if) {
  const uint32_t n = num_prims_;
  if (n == 0) return;
  CUDA_CHECK(cudaMemsetAsync(counter_.data(), 0, counter_.bytes(), stream));
  // The counters are zeroed either way: a skipped refit leaves them zero for the next one.
  k_refit<<<grid_for(n), kBlock, 0, stream>>>(view(), vertices, indices, only_if);
  CUDA_CHECK_LAUNCH();
}

void DeviceBvh::area(float* out, cudaStream_t stream) const {
  if (num_prims_ == 0) {
    CUDA_CHECK(cudaMemsetAsync(out, 0, sizeof(float), stream));
    return;
  }
  k_area<<<1, kBlock, 0, stream>>>(view(), out);
  CUDA_CHECK_LAUNCH();
}

BvhView DeviceBvh::view() const {
  BvhView v;
  v.num_prims = num_prims_;
  v.child = child_.data();
  v.parent = parent_.data();
  v.bounds = bounds_.data();
  v.prim = prim_.data();
  v.counter = counter_.data();
  return v;
}

}  // namespace raycloth
