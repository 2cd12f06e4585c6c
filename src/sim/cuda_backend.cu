// CUDA backend: the shared per-vertex stages (sim/stages.h) as kernels over device-resident state,
// rays cast against the LBVH of collide/bvh.h (obstacle tree built once, cloth tree refit every
// step and rebuilt when refitting has degraded it). The kernels of one step are captured into two
// CUDA graphs, one per direction of the x/x_next double buffer, and Backend::step(n) launches them
// n times, alternating; the only transfer per call is the small StepControl read back at the end
// (plus, for scenes with moving obstacles, one upload of the call's obstacle poses). docs/gpu.md.
#include <cub/block/block_reduce.cuh>

#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <string>
#include <vector>

#include "collide/bvh.h"
#include "collide/cuda/cuda_check.cuh"
#include "collide/cuda/device_bvh.cuh"
#include "sim/backend.h"
#include "sim/cuda_pose.cuh"
#include "sim/stages.h"

namespace raycloth {

namespace {

constexpr int kBlock = 256;
constexpr unsigned long long kNoVertex = ~0ull;
inline unsigned grid_for(uint32_t n) { return (n + kBlock - 1) / kBlock; }

// Device-resident bookkeeping of a step(n) call; read back once at its end.
struct StepControl {
  unsigned long long step = 0;        // index of the step running now (from the start of the run)
  unsigned long long call_first = 0;  // first step of this call: row 0 of the pose table
  unsigned long long hits = 0;        // collision-buffer entries in the last step run
  unsigned long long bad_vertex = kNoVertex;
  unsigned long long bad_step = 0;
  unsigned int stopped = 0;  // set after the step that blew up: later steps of the call do nothing
  float cloth_area = 0;        // summed node area of the cloth tree after the last refit
  float cloth_built_area = 0;  // the same right after its last build
};

// Moving obstacle vertices: which world vertex, its local position, which obstacle's pose.
struct PoseView {
  uint32_t num_vertices = 0, num_moving = 0;
  const uint32_t* world_index = nullptr;
  const Vec3* local = nullptr;
  const uint32_t* pose_index = nullptr;
  const RigidPose* table = nullptr;  // num_moving poses per step of the call
  Vec3* x = nullptr;
  Vec3* v = nullptr;
};

__global__ void k_begin_call(StepControl* c, unsigned long long first_step) {
  c->step = first_step;
  c->call_first = first_step;
  c->bad_vertex = kNoVertex;
  c->stopped = 0;
}

__global__ void k_pose_obstacles(PoseView p, const StepControl* c) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (c->stopped || i >= p.num_vertices) return;
  const RigidPose& pose = p.table[(c->step - c->call_first) * p.num_moving + p.pose_index[i]];
  const uint32_t w = p.world_index[i];
  pose_vertex(pose, p.local[i], p.x[w], p.v[w]);
}

__global__ void k_integrate(StepView s, StepControl* c) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (c->stopped) return;
  if (i == 0) c->hits = 0;  // counted again in k_respond_contact, later in this step
  if (i >= s.model.num_vertices) return;
  stage_integrate(s, i);
  stage_velocity_ray(s, i);
}

__global__ void k_trace(BvhScene scene, const Ray* rays, RawHit* hits, uint32_t n, const StepControl* c) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (c->stopped || i >= n) return;
  hits[i] = trace_collision(scene, rays[i]);
}

__global__ void k_respond_velocity(StepView s, const StepControl* c) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (c->stopped || i >= s.model.num_vertices) return;
  stage_respond_velocity(s, i);
}

// The last stage, the hit count (integers: the same total in any order) and the first bad vertex.
__global__ void k_respond_contact(StepView s, StepControl* c) {
  using Reduce = cub::BlockReduce<unsigned long long, kBlock>;
  __shared__ typename Reduce::TempStorage temp;
  if (c->stopped) return;  // uniform: only k_finish_step writes it
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  unsigned long long hit = 0;
  if (i < s.model.num_vertices) {
    if (!stage_respond_contact(s, i)) atomicMin(&c->bad_vertex, (unsigned long long)i);
    hit = s.contacts[i].w >= 0.0f ? 1 : 0;
  }
  const unsigned long long block_hits = Reduce(temp).Sum(hit);
  if (threadIdx.x == 0 && block_hits) atomicAdd(&c->hits, block_hits);
}

__global__ void k_finish_step(StepControl* c) {
  if (c->stopped) return;
  if (c->bad_vertex != kNoVertex) {
    c->stopped = 1;
    c->bad_step = c->step;
  }
  ++c->step;
}

__global__ void k_probe() {}

// Events around the stages of one step, for the per-stage profile (RAYCLOTH_CUDA_PROFILE=1).
struct StageEvents {
  cudaEvent_t e[7] = {};
};

class CudaBackend final : public Backend {
 public:
  explicit CudaBackend(const BackendInput& in) : scene_(*in.scene), model_(*in.model), obstacles_(*in.obstacles) {
    const char* profile = std::getenv("RAYCLOTH_CUDA_PROFILE");
    profile_ = profile && *profile && std::string(profile) != "0";
    // A blocking stream: it waits for the setup copies (cudaMemcpy on the legacy default stream).
    CUDA_CHECK(cudaStreamCreate(&stream_));
    CUDA_CHECK(cudaEventCreate(&start_));
    CUDA_CHECK(cudaEventCreate(&stop_));
    for (cudaEvent_t& e : events_.e) CUDA_CHECK(cudaEventCreate(&e));
    CUDA_CHECK(cudaMallocHost(reinterpret_cast<void**>(&control_host_), sizeof(StepControl)));
    upload();
  }

  ~CudaBackend() override {
    // Nothing here may throw: errors are ignored while tearing down.
    if (stream_) cudaStreamSynchronize(stream_);
    for (cudaGraphExec_t& g : graphs_)
      if (g) cudaGraphExecDestroy(g);
    for (cudaEvent_t e : events_.e)
      if (e) cudaEventDestroy(e);
    if (start_) cudaEventDestroy(start_);
    if (stop_) cudaEventDestroy(stop_);
    if (control_host_) cudaFreeHost(control_host_);
    if (stream_) cudaStreamDestroy(stream_);
  }

  std::string name() const override { return "cuda"; }

  StepResult step(int n, uint64_t first_step, StageTimes& times) override {
    StepResult result;
    if (n <= 0) return result;
    if (obstacles_.any_moving) upload_poses(n, first_step);
    if (!profile_ && !graphs_[0]) capture_graphs();

    k_begin_call<<<1, 1, 0, stream_>>>(control_.data(), first_step);
    CUDA_CHECK_LAUNCH();
    if (profile_) {
      for (int k = 0; k < n; ++k) {
        enqueue_step((parity_ + k) & 1, &events_);
        CUDA_CHECK(cudaEventSynchronize(events_.e[6]));
        times.update += elapsed(events_.e[0], events_.e[1]);
        times.integrate += elapsed(events_.e[1], events_.e[2]);
        times.cast += elapsed(events_.e[2], events_.e[3]) + elapsed(events_.e[4], events_.e[5]);
        times.respond += elapsed(events_.e[3], events_.e[4]) + elapsed(events_.e[5], events_.e[6]);
      }
    } else {
      CUDA_CHECK(cudaEventRecord(start_, stream_));
      for (int k = 0; k < n; ++k) CUDA_CHECK(cudaGraphLaunch(graphs_[(parity_ + k) & 1], stream_));
      CUDA_CHECK(cudaEventRecord(stop_, stream_));
    }
    if (cloth_.num_prims() > 0) cloth_.area(control_field<float>(offsetof(StepControl, cloth_area)), stream_);
    CUDA_CHECK(cudaMemcpyAsync(control_host_, control_.data(), sizeof(StepControl), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaStreamSynchronize(stream_));
    // Without the profile the graph runs all stages at once; its time is reported under integrate.
    if (!profile_) times.integrate += elapsed(start_, stop_);

    const StepControl& c = *control_host_;
    const uint64_t executed = c.stopped ? c.bad_step - first_step + 1 : uint64_t(n);
    parity_ = (parity_ + int(executed & 1)) & 1;
    result.hits = c.hits;
    if (c.stopped) {
      result.bad_vertex = int64_t(c.bad_vertex);
      result.bad_step = c.bad_step;
    }
    // Rebuild the cloth tree for the next call when refitting has degraded it (docs/gpu.md).
    if (cloth_.num_prims() > 0 && bvh_needs_rebuild(c.cloth_area, c.cloth_built_area)) {
      auto t = std::chrono::steady_clock::now();
      cloth_.build(x_[parity_].data(), cloth_indices_.data(), stream_, built_area());
      CUDA_CHECK(cudaStreamSynchronize(stream_));
      times.update += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      ++cloth_rebuilds_;
    }
    return result;
  }

  void download(std::vector<Vec3>& x, std::vector<Vec3>& v) override {
    const size_t n = model_.num_vertices();
    x.resize(n);
    v.resize(n);
    CUDA_CHECK(cudaMemcpyAsync(x.data(), x_[parity_].data(), n * sizeof(Vec3), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(v.data(), v_[parity_].data(), n * sizeof(Vec3), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

 private:
  // Device address of one StepControl field.
  template <class T>
  T* control_field(size_t offset) const {
    return reinterpret_cast<T*>(reinterpret_cast<char*>(control_.data()) + offset);
  }

  float* built_area() const { return control_field<float>(offsetof(StepControl, cloth_built_area)); }

  static double elapsed(cudaEvent_t a, cudaEvent_t b) {
    float ms = 0;
    CUDA_CHECK(cudaEventElapsedTime(&ms, a, b));
    return double(ms) * 1e-3;
  }

  // Model, state and trees to the device, once.
  void upload() {
    const ClothModel& m = model_;
    const uint32_t n = m.num_vertices();
    inv_mass_ = DeviceBuffer<float>(m.inv_mass);
    damping_ = DeviceBuffer<float>(m.damping);
    adj_offset_ = DeviceBuffer<uint32_t>(m.adj_offset);
    adj_other_ = DeviceBuffer<uint32_t>(m.adj_other);
    adj_rest_ = DeviceBuffer<float>(m.adj_rest);
    adj_k_ = DeviceBuffer<float>(m.adj_k);
    adj_kd_ = DeviceBuffer<float>(m.adj_kd);
    alias_ = DeviceBuffer<uint32_t>(m.alias);
    cloth_indices_ = DeviceBuffer<uint32_t>(m.collision_triangles);  // cloth, then seam strips
    tri_alias_ = DeviceBuffer<uint32_t>(m.tri_alias);

    const std::vector<Vec3> zero(n, make_vec3(0, 0, 0));
    for (int b = 0; b < 2; ++b) {
      x_[b] = DeviceBuffer<Vec3>(m.initial_positions);
      v_[b] = DeviceBuffer<Vec3>(zero);
    }
    contact_normal_ = DeviceBuffer<Vec3>(zero);
    rays_.resize(n);
    hits_.resize(n);
    contacts_.resize(n);
    control_ = DeviceBuffer<StepControl>(std::vector<StepControl>(1));

    std::vector<Vec3> ox, ov;
    obstacles_.pose_at(0.0, ox, ov);
    obstacle_x_ = DeviceBuffer<Vec3>(ox);
    obstacle_v_ = DeviceBuffer<Vec3>(ov);
    obstacle_indices_ = DeviceBuffer<uint32_t>(obstacles_.world.indices);
    if (obstacles_.any_moving) upload_moving_vertices();
    // cudaMemcpy from pageable memory may return before the data has arrived: wait for it.
    CUDA_CHECK(cudaDeviceSynchronize());

    obstacle_tree_.allocate(uint32_t(obstacles_.world.num_triangles()));
    obstacle_tree_.build(obstacle_x_.data(), obstacle_indices_.data(), stream_);
    if (scene_.collision.cloth_cloth) {
      cloth_.allocate(m.num_collision_triangles());
      cloth_.build(x_[0].data(), cloth_indices_.data(), stream_, built_area());
    }
    CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

  void upload_moving_vertices() {
    std::vector<uint32_t> world_index, pose_index;
    std::vector<Vec3> local;
    for (size_t oi = 0; oi < obstacles_.defs.size(); ++oi) {
      if (!obstacles_.defs[oi].motion) continue;
      for (size_t k = 0; k < obstacles_.local[oi].vertices.size(); ++k) {
        world_index.push_back(obstacles_.first_vertex[oi] + uint32_t(k));
        local.push_back(obstacles_.local[oi].vertices[k]);
        pose_index.push_back(uint32_t(moving_.size()));
      }
      moving_.push_back(oi);
    }
    moving_world_index_ = DeviceBuffer<uint32_t>(world_index);
    moving_local_ = DeviceBuffer<Vec3>(local);
    moving_pose_index_ = DeviceBuffer<uint32_t>(pose_index);
  }

  // The poses of this call's steps, uploaded once before its graph launches. A larger table than
  // the graphs were captured with means capturing them again.
  void upload_poses(int n, uint64_t first_step) {
    std::vector<RigidPose> table(size_t(n) * moving_.size());
    for (int k = 0; k < n; ++k)
      for (size_t m = 0; m < moving_.size(); ++m)
        table[size_t(k) * moving_.size() + m] =
            rigid_pose_at(obstacles_.defs[moving_[m]], double(first_step + uint64_t(k)) * scene_.time.dt);
    if (table.size() > pose_table_.size()) {
      pose_table_.resize(table.size());
      destroy_graphs();
    }
    CUDA_CHECK(cudaMemcpyAsync(pose_table_.data(), table.data(), table.size() * sizeof(RigidPose),
                               cudaMemcpyHostToDevice, stream_));
  }

  StepView view(int parity) {
    const int cur = parity, next = parity ^ 1;
    StepView s = step_view_for(scene_);
    s.model.num_vertices = model_.num_vertices();
    s.model.inv_mass = inv_mass_.data();
    s.model.damping = damping_.data();
    s.model.adj_offset = adj_offset_.data();
    s.model.adj_other = adj_other_.data();
    s.model.adj_rest = adj_rest_.data();
    s.model.adj_k = adj_k_.data();
    s.model.adj_kd = adj_kd_.data();
    s.model.alias = alias_.data();
    s.model.triangles = cloth_indices_.data();
    s.model.tri_alias = tri_alias_.data();
    s.geom.obstacle_vertices = obstacle_x_.data();
    s.geom.obstacle_velocities = obstacles_.any_moving ? obstacle_v_.data() : nullptr;
    s.geom.obstacle_indices = obstacle_indices_.data();
    s.geom.cloth_positions = x_[cur].data();
    s.geom.cloth_velocities = v_[cur].data();
    s.geom.cloth_indices = cloth_indices_.data();
    s.x = x_[cur].data();
    s.v = v_[cur].data();
    s.x_next = x_[next].data();
    s.v_next = v_[next].data();
    s.rays = rays_.data();
    s.hits = hits_.data();
    s.contacts = contacts_.data();
    s.contact_normal = contact_normal_.data();
    return s;
  }

  BvhScene trace_scene(int parity) {
    BvhScene b;
    b.obstacles = obstacle_tree_.view();
    b.obstacle_vertices = obstacle_x_.data();
    b.obstacle_indices = obstacle_indices_.data();
    b.cloth = cloth_.view();
    b.cloth_positions = x_[parity].data();
    b.cloth_indices = cloth_indices_.data();
    b.tri_alias = tri_alias_.data();
    return b;
  }

  // One step from buffer `parity` into the other, the same sequence as CpuBackend::step; with
  // `ev`, events between the stages.
  void enqueue_step(int parity, StageEvents* ev) {
    const uint32_t n = model_.num_vertices();
    StepControl* c = control_.data();
    const StepView s = view(parity);
    const BvhScene scene = trace_scene(parity);
    auto mark = [&](int k) {
      if (ev) CUDA_CHECK(cudaEventRecord(ev->e[k], stream_));
    };
    mark(0);
    if (obstacles_.any_moving) {
      PoseView p;
      p.num_vertices = uint32_t(moving_local_.size());
      p.num_moving = uint32_t(moving_.size());
      p.world_index = moving_world_index_.data();
      p.local = moving_local_.data();
      p.pose_index = moving_pose_index_.data();
      p.table = pose_table_.data();
      p.x = obstacle_x_.data();
      p.v = obstacle_v_.data();
      k_pose_obstacles<<<grid_for(p.num_vertices), kBlock, 0, stream_>>>(p, c);
      CUDA_CHECK_LAUNCH();
      obstacle_tree_.refit(obstacle_x_.data(), obstacle_indices_.data(), stream_);
    }
    if (cloth_.num_prims() > 0) cloth_.refit(x_[parity].data(), cloth_indices_.data(), stream_);
    mark(1);
    k_integrate<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    mark(2);
    k_trace<<<grid_for(n), kBlock, 0, stream_>>>(scene, rays_.data(), hits_.data(), n, c);
    CUDA_CHECK_LAUNCH();
    mark(3);
    k_respond_velocity<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    mark(4);
    k_trace<<<grid_for(n), kBlock, 0, stream_>>>(scene, rays_.data(), hits_.data(), n, c);
    CUDA_CHECK_LAUNCH();
    mark(5);
    k_respond_contact<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    k_finish_step<<<1, 1, 0, stream_>>>(c);
    CUDA_CHECK_LAUNCH();
    mark(6);
  }

  void capture_graphs() {
    for (int parity = 0; parity < 2; ++parity) {
      cudaGraph_t graph = nullptr;
      CUDA_CHECK(cudaStreamBeginCapture(stream_, cudaStreamCaptureModeThreadLocal));
      try {
        enqueue_step(parity, nullptr);
      } catch (...) {
        cudaStreamEndCapture(stream_, &graph);
        if (graph) cudaGraphDestroy(graph);
        throw;
      }
      CUDA_CHECK(cudaStreamEndCapture(stream_, &graph));
      const cudaError_t e = cudaGraphInstantiate(&graphs_[parity], graph, 0);
      cudaGraphDestroy(graph);
      CUDA_CHECK(e);
    }
  }

  void destroy_graphs() {
    for (cudaGraphExec_t& g : graphs_) {
      if (g) CUDA_CHECK(cudaGraphExecDestroy(g));
      g = nullptr;
    }
  }

  const SceneDef& scene_;
  const ClothModel& model_;
  const ObstacleSet& obstacles_;
  bool profile_ = false;
  cudaStream_t stream_ = nullptr;
  cudaEvent_t start_ = nullptr, stop_ = nullptr;
  StageEvents events_;
  cudaGraphExec_t graphs_[2] = {nullptr, nullptr};
  StepControl* control_host_ = nullptr;  // pinned
  int parity_ = 0;                       // x_[parity_] holds the state at the current time
  uint32_t cloth_rebuilds_ = 0;

  DeviceBuffer<float> inv_mass_, damping_, adj_rest_, adj_k_, adj_kd_;
  DeviceBuffer<uint32_t> adj_offset_, adj_other_, alias_, cloth_indices_, tri_alias_;
  DeviceBuffer<Vec3> x_[2], v_[2], contact_normal_;
  DeviceBuffer<Ray> rays_;
  DeviceBuffer<RawHit> hits_;
  DeviceBuffer<Contact> contacts_;
  DeviceBuffer<StepControl> control_;
  DeviceBuffer<Vec3> obstacle_x_, obstacle_v_;
  DeviceBuffer<uint32_t> obstacle_indices_;
  std::vector<size_t> moving_;  // obstacle index of each moving obstacle
  DeviceBuffer<uint32_t> moving_world_index_, moving_pose_index_;
  DeviceBuffer<Vec3> moving_local_;
  DeviceBuffer<RigidPose> pose_table_;
  DeviceBvh obstacle_tree_, cloth_;
};

}  // namespace

bool cuda_usable(std::string* why) {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess) {
    cudaGetLastError();  // clear it: the CPU path goes on
    if (why) *why = std::string("no CUDA GPU found: ") + cudaGetErrorString(e);
    return false;
  }
  if (count == 0) {
    if (why) *why = "no CUDA GPU found: cudaGetDeviceCount reports 0 devices";
    return false;
  }
  // A GPU whose architecture is not among CMAKE_CUDA_ARCHITECTURES has no kernel image to run.
  cudaFuncAttributes attributes;
  const cudaError_t image = cudaFuncGetAttributes(&attributes, k_probe);
  if (image != cudaSuccess) {
    cudaGetLastError();
    cudaDeviceProp prop{};
    std::string gpu = "the GPU";
    if (cudaGetDeviceProperties(&prop, 0) == cudaSuccess)
      gpu = std::string(prop.name) + " (compute capability " + std::to_string(prop.major) + "." +
            std::to_string(prop.minor) + ")";
    cudaGetLastError();
    if (why)
      *why = gpu + " cannot run this build's kernels: " + cudaGetErrorString(image) +
             "; rebuild with -DCMAKE_CUDA_ARCHITECTURES including it";
    return false;
  }
  if (why) why->clear();
  return true;
}

std::unique_ptr<Backend> make_cuda_backend(const BackendInput& in) {
  std::string why;
  if (!cuda_usable(&why)) throw SimulationError("device 'cuda' cannot run: " + why);
  return std::make_unique<CudaBackend>(in);
}

}  // namespace raycloth
