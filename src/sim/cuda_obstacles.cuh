// Obstacles posed on the device for the CUDA backend: rigid motions from a table of poses the host
// computes for a call's steps (RigidPose, sim/cuda_pose.cuh), skinned bodies from their joint
// matrices (DeviceSkinning), each vertex by the same per-vertex code the host's pose_at runs.
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "collide/cuda/cuda_check.cuh"
#include "collide/cuda/device_buffer.cuh"
#include "sim/cuda_pose.cuh"
#include "sim/model.h"

namespace raycloth {

inline constexpr int kBlock = 256;
inline unsigned grid_for(uint32_t n) { return (n + kBlock - 1) / kBlock; }

// Moving obstacle vertices: which world vertex, its local position, which obstacle's pose.
struct PoseView {
  uint32_t num_vertices = 0, num_moving = 0;
  const uint32_t* world_index = nullptr;
  const Vec3* local = nullptr;
  const uint32_t* pose_index = nullptr;
  const RigidPose* table = nullptr;  // num_moving poses for one step
  Vec3* x = nullptr;
  Vec3* v = nullptr;
};

__global__ void k_pose_obstacles(PoseView p) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.num_vertices) return;
  const uint32_t w = p.world_index[i];
  pose_vertex(p.table[p.pose_index[i]], p.local[i], p.x[w], p.v[w]);
}

// Skinned obstacle vertices: which world vertex, where its obstacle's joints start in a step's
// joint tables, and the joint matrices (pose) and their rates for one step.
struct SkinView {
  uint32_t num_vertices = 0;
  const SkinnedVertex* vertices = nullptr;
  const uint32_t* world_index = nullptr;
  const uint32_t* joint_base = nullptr;
  const Affine* pose = nullptr;
  const Affine* rate = nullptr;
  Vec3* x = nullptr;
  Vec3* v = nullptr;
};

__global__ void k_skin_obstacles(SkinView s) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= s.num_vertices) return;
  const uint32_t w = s.world_index[i], b = s.joint_base[i];
  skin_obstacle_vertex(s.pose + b, s.rate + b, s.vertices[i], s.x[w], s.v[w]);
}

// The skinned obstacles of an ObstacleSet on the device: their vertices, uploaded once, and for a
// run of step times the joint matrices and rates the host computes, uploaded at once; the kernel
// poses the vertices of one of those times into the obstacle arrays.
class DeviceSkinning {
 public:
  explicit DeviceSkinning(const ObstacleSet& o) : o_(o) {
    std::vector<SkinnedVertex> vertices;
    std::vector<uint32_t> world_index, joint_base;
    for (size_t oi = 0; oi < o.skinned.size(); ++oi) {
      if (!o.skinned[oi]) continue;
      const SkinnedMesh& m = *o.skinned[oi];
      for (size_t k = 0; k < m.vertices.size(); ++k) {
        vertices.push_back(m.vertices[k]);
        world_index.push_back(o.first_vertex[oi] + uint32_t(k));
        joint_base.push_back(num_joints_);
      }
      obstacles_.push_back(oi);
      num_joints_ += uint32_t(m.joints.size());
    }
    num_vertices_ = uint32_t(vertices.size());
    vertices_ = DeviceBuffer<SkinnedVertex>(vertices);
    world_index_ = DeviceBuffer<uint32_t>(world_index);
    joint_base_ = DeviceBuffer<uint32_t>(joint_base);
  }

  bool empty() const { return obstacles_.empty(); }

  // Joint tables for `times` (each: the pose, then the rate, num_joints_ each).
  void upload(const std::vector<double>& times, cudaStream_t stream) {
    if (empty()) return;
    std::vector<Affine> table(times.size() * 2 * num_joints_);
    std::vector<Affine> pose, rate;
    for (size_t k = 0; k < times.size(); ++k) {
      Affine* out = table.data() + k * 2 * num_joints_;
      for (size_t m = 0, base = 0; m < obstacles_.size(); ++m) {
        o_.skinned_joints(obstacles_[m], times[k], pose, rate);
        std::copy(pose.begin(), pose.end(), out + base);
        std::copy(rate.begin(), rate.end(), out + num_joints_ + base);
        base += pose.size();
      }
    }
    table_.resize(std::max(table_.size(), table.size()));
    CUDA_CHECK(cudaMemcpyAsync(table_.data(), table.data(), table.size() * sizeof(Affine), cudaMemcpyHostToDevice, stream));
    CUDA_CHECK(cudaStreamSynchronize(stream));  // `table` is pageable and goes out of scope
  }

  // Poses the vertices for time k of the last upload into the obstacle arrays x and v.
  void pose(size_t k, Vec3* x, Vec3* v, cudaStream_t stream) const {
    if (empty()) return;
    SkinView s;
    s.num_vertices = num_vertices_;
    s.vertices = vertices_.data();
    s.world_index = world_index_.data();
    s.joint_base = joint_base_.data();
    s.pose = table_.data() + k * 2 * num_joints_;
    s.rate = s.pose + num_joints_;
    s.x = x;
    s.v = v;
    k_skin_obstacles<<<grid_for(num_vertices_), kBlock, 0, stream>>>(s);
    CUDA_CHECK_LAUNCH();
  }

 private:
  const ObstacleSet& o_;
  std::vector<size_t> obstacles_;  // the skinned ones
  uint32_t num_joints_ = 0, num_vertices_ = 0;
  DeviceBuffer<SkinnedVertex> vertices_;
  DeviceBuffer<uint32_t> world_index_, joint_base_;
  DeviceBuffer<Affine> table_;
};

}  // namespace raycloth
