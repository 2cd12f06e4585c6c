// CUDA backend: the step of sim/step.h with kernels over device-resident state. The executor below
// turns each loop of the step into a kernel launch on one stream (the lambdas are the shared stage
// functions), casts against the LBVH of collide/bvh.h and keeps the step's counters in device
// memory. Obstacle poses for a whole call are uploaded once at its start; the only transfer per
// step is the small StepCounters read back after it (blow-up detection). docs/gpu.md.
#include <cooperative_groups.h>
#include <cub/block/block_reduce.cuh>

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "collide/bvh.h"
#include "collide/cuda/cuda_check.cuh"
#include "collide/cuda/device_bvh.cuh"
#include "raycloth/error.h"
#include "sim/backend.h"
#include "sim/cuda_obstacles.cuh"
#include "sim/integrate/integrators.h"
#include "sim/state.h"
#include "sim/step.h"

namespace raycloth {

namespace {

template <class F>
__global__ void k_for_each(uint32_t n, F f) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// The phases of sim/stage_time.h in one kernel: each phase a grid-stride loop, then a barrier (the
// block's when the grid is one block, else the grid's: a cooperative launch).
template <class F>
__global__ void k_phases(PhaseSizes sizes, F f) {
  const uint32_t stride = gridDim.x * blockDim.x, first = blockIdx.x * blockDim.x + threadIdx.x;
  for (uint32_t p = 0; p < sizes.count; ++p) {
    for (uint32_t k = first; k < sizes.size[p]; k += stride) f(p, k);
    if (p + 1 == sizes.count) break;
    if (gridDim.x == 1)
      __syncthreads();
    else
      cooperative_groups::this_grid().sync();
  }
}

// One phase of k_phases as a kernel of its own (a GPU without cooperative launches).
template <class F>
__global__ void k_phase(uint32_t p, uint32_t n, F f) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < n) f(p, k);
}

// *slot += sum of f(i): a block sum, then one atomic add per block (integers: order-independent).
template <class F>
__global__ void k_sum(uint32_t n, F f, uint32_t* slot) {
  using Reduce = cub::BlockReduce<uint32_t, kBlock>;
  __shared__ typename Reduce::TempStorage temp;
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  const uint32_t value = i < n ? f(i) : 0u;
  const uint32_t total = Reduce(temp).Sum(value);
  if (threadIdx.x == 0 && total) atomicAdd(slot, total);
}

// *slot = min(*slot, smallest i with f(i) false).
template <class F>
__global__ void k_first(uint32_t n, F f, uint32_t* slot) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n && !f(i)) atomicMin(slot, i);
}

__global__ void k_trace(BvhScene scene, const Ray* rays, RawHit* hits, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) hits[i] = trace_collision(scene, rays[i]);
}

__global__ void k_reset_counters(StepCounters* c) { *c = StepCounters(); }

__global__ void k_probe() {}

class CudaBackend final : public Backend {
 public:
  explicit CudaBackend(const BackendInput& in)
      : in_(in), scene_(*in.scene), model_(*in.model), obstacles_(*in.obstacles), skinning_(*in.obstacles) {
    // A blocking stream: it waits for the setup copies (cudaMemcpy on the legacy default stream).
    CUDA_CHECK(cudaStreamCreate(&stream_));
    CUDA_CHECK(cudaMallocHost(reinterpret_cast<void**>(&counters_host_), sizeof(StepCounters)));
    clock_.settings = in.step();
    upload();
  }

  ~CudaBackend() override {
    // Nothing here may throw: errors are ignored while tearing down.
    if (stream_) cudaStreamSynchronize(stream_);
    for (cudaEvent_t e : events_) cudaEventDestroy(e);
    if (counters_host_) cudaFreeHost(counters_host_);
    if (stream_) cudaStreamDestroy(stream_);
  }

  std::string name() const override { return "cuda"; }

  StepResult step(int n, uint64_t first_step, StageTimes& times) override {
    StepResult result;
    if (n <= 0) return result;
    if (obstacles_.any_moving) upload_poses(n, first_step);
    call_first_ = first_step;
    times_ = &times;
    return std::visit(
        [&](auto& integrator) {
          integrator.set_iterations(uint32_t(clock_.settings.iterations));
          return run_steps(*this, integrator, n, first_step);
        },
        integrator_);
  }

  void download(std::vector<Vec3>& x, std::vector<Vec3>& v) override {
    const size_t n = model_.num_vertices();
    x.resize(n);
    v.resize(n);
    CUDA_CHECK(cudaMemcpyAsync(x.data(), st_->x[st_->cur].data(), n * sizeof(Vec3), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(v.data(), st_->v[st_->cur].data(), n * sizeof(Vec3), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

  // The balls of the displacement bound: centres and allowances, computed on the host from the
  // device's arrays (as the CPU backend does from its own).
  bool download_balls(std::vector<Vec3>& centre, std::vector<float>& radius,
                      std::vector<std::vector<Vec3>>* planes) override {
    const size_t n = model_.num_vertices();
    std::vector<uint32_t> bound(n);
    std::vector<float> bound_radius(n);
    std::vector<uint32_t> plane_count(n), plane_near(n);
    std::vector<BoundPlanes> plane_dirs(n);
    centre.resize(n);
    radius.resize(n);
    CUDA_CHECK(cudaMemcpyAsync(centre.data(), st_->x_ref.data(), n * sizeof(Vec3), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(bound.data(), st_->bound.data(), n * sizeof(uint32_t), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(bound_radius.data(), st_->bound_radius.data(), n * sizeof(float), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(plane_count.data(), st_->plane_count.data(), n * sizeof(uint32_t), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(plane_near.data(), st_->plane_near.data(), n * sizeof(uint32_t), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaMemcpyAsync(plane_dirs.data(), st_->planes.data(), n * sizeof(BoundPlanes), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaStreamSynchronize(stream_));
    StepView s;
    s.bound = bound.data();
    s.bound_radius = bound_radius.data();
    s.plane_count = plane_count.data();
    s.plane_near = plane_near.data();
    s.planes = plane_dirs.data();
    for (uint32_t i = 0; i < n; ++i) radius[i] = allowance_of(s, i);
    if (planes) planes_by_vertex(s, uint32_t(n), *planes);
    return true;
  }

  // As the CPU backend's: the state and the obstacles' pose, copied on the device (the trees are refit
  // from them in the next begin()).
  bool can_go_back() const override { return true; }
  void keep() override {
    if (!kept_) {
      kept_ = std::make_unique<SimState<DeviceBuffer>>(model_);
      kept_obstacle_x_.resize(obstacle_x_.size());
      kept_obstacle_v_.resize(obstacle_v_.size());
    }
    st_->for_each_array(*kept_, [this](const auto& from, auto& to) { copy_on_device(from, to); });
    kept_->cur = st_->cur;
    copy_on_device(obstacle_x_, kept_obstacle_x_);
    copy_on_device(obstacle_v_, kept_obstacle_v_);
  }
  void back() override {
    kept_->for_each_array(*st_, [this](const auto& from, auto& to) { copy_on_device(from, to); });
    st_->cur = kept_->cur;
    copy_on_device(kept_obstacle_x_, obstacle_x_);
    copy_on_device(kept_obstacle_v_, obstacle_v_);
  }

  // ---- The executor of sim/step.h ----

  StepView begin(uint64_t step) {
    mark(Stage::Update);
    if (obstacles_.any_moving) {
      CUDA_CHECK(cudaMemcpyAsync(obstacle_prev_.data(), obstacle_x_.data(), obstacle_x_.bytes(), cudaMemcpyDeviceToDevice,
                                 stream_));
      PoseView p;
      p.num_vertices = uint32_t(moving_local_.size());
      p.num_moving = uint32_t(moving_.size());
      p.world_index = moving_world_index_.data();
      p.local = moving_local_.data();
      p.pose_index = moving_pose_index_.data();
      p.table = moving_.empty() ? nullptr : pose_table_.data() + (step - call_first_) * moving_.size();
      p.x = obstacle_x_.data();
      p.v = obstacle_v_.data();
      if (p.num_vertices > 0) {
        k_pose_obstacles<<<grid_for(p.num_vertices), kBlock, 0, stream_>>>(p);
        CUDA_CHECK_LAUNCH();
      }
      const size_t k = size_t(step - call_first_);
      skinning_.pose(k, obstacle_x_.data(), obstacle_v_.data(), stream_);
      // A deforming body degrades the refit tree: rebuilt every kRebuildEvery steps, like the cloth's.
      if (!skinning_.empty() && ++obstacle_refits_since_build_ >= kRebuildEvery) {
        obstacle_tree_.build(obstacle_x_.data(), obstacle_indices_.data(), stream_);
        obstacle_refits_since_build_ = 0;
      } else {
        obstacle_tree_.refit(obstacle_x_.data(), obstacle_indices_.data(), stream_);
      }
    }
    refit_cloth_tree();
    k_reset_counters<<<1, 1, 0, stream_>>>(st_->counters.data());
    CUDA_CHECK_LAUNCH();
    return view(step);
  }

  template <class F>
  void for_each(Stage stage, uint32_t n, F f) {
    if (n == 0) return;
    mark(stage);
    k_for_each<<<grid_for(n), kBlock, 0, stream_>>>(n, f);
    CUDA_CHECK_LAUNCH();
  }

  // One kernel for all the phases. Up to kOneBlockPhase elements in the largest phase, one block
  // (a block barrier costs far less than the grid's); else as many blocks as fit on the GPU at once
  // (a grid barrier needs every block resident), each looping over its share; on a GPU that cannot
  // launch cooperatively, a kernel a phase.
  static constexpr uint32_t kOneBlockPhase = 8 * kBlock;

  template <class F>
  void phases(Stage stage, const PhaseSizes& sizes, F f) {
    if (sizes.count == 0) return;
    mark(stage);
    const uint32_t largest = sizes.largest();
    if (largest <= kOneBlockPhase) {
      k_phases<<<1, kBlock, 0, stream_>>>(sizes, f);
      CUDA_CHECK_LAUNCH();
      return;
    }
    static const bool cooperative = [] {
      int device = 0, supported = 0;
      CUDA_CHECK(cudaGetDevice(&device));
      CUDA_CHECK(cudaDeviceGetAttribute(&supported, cudaDevAttrCooperativeLaunch, device));
      return supported != 0;
    }();
    if (!cooperative) {  // a launch a phase, as for_each would
      for (uint32_t p = 0; p < sizes.count; ++p) {
        if (sizes.size[p] == 0) continue;
        k_phase<<<grid_for(sizes.size[p]), kBlock, 0, stream_>>>(p, sizes.size[p], f);
        CUDA_CHECK_LAUNCH();
      }
      return;
    }
    static const unsigned resident = [] {
      int device = 0, sms = 0, per_sm = 0;
      CUDA_CHECK(cudaGetDevice(&device));
      CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
      CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_phases<F>, kBlock, 0));
      return unsigned(sms) * unsigned(per_sm);
    }();
    const unsigned blocks = std::min(grid_for(largest), resident);
    PhaseSizes arg = sizes;
    void* args[] = {&arg, &f};
    CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<const void*>(&k_phases<F>), dim3(blocks), dim3(kBlock), args, 0,
                                           stream_));
  }

  template <class F>
  void sum(Stage stage, uint32_t n, F f, uint32_t* slot) {
    if (n == 0) return;
    mark(stage);
    k_sum<<<grid_for(n), kBlock, 0, stream_>>>(n, f, slot);
    CUDA_CHECK_LAUNCH();
  }

  template <class F>
  void first(Stage stage, uint32_t n, F f, uint32_t* slot) {
    if (n == 0) return;
    mark(stage);
    k_first<<<grid_for(n), kBlock, 0, stream_>>>(n, f, slot);
    CUDA_CHECK_LAUNCH();
  }

  void cast(const Ray* rays, uint32_t n, RawHit* hits) {
    mark(Stage::Cast);
    k_trace<<<grid_for(n), kBlock, 0, stream_>>>(trace_scene(), rays, hits, n);
    CUDA_CHECK_LAUNCH();
  }

  // The cloth tree serves the rays as well as the bound, so it is refit every step anyway: nothing
  // more to do when the bound is recomputed (the flag lives in device memory).
  void refit_cloth(const StepCounters*) {}

  // The counters stay on the device inside a step: every loop runs, and its kernels read them.
  uint32_t peek(const uint32_t*, uint32_t unknown) const { return unknown; }

  // The step's counters, copied back after it (pinned memory): the only transfer per step.
  const StepCounters& counters() {
    mark(Stage::Update, true);  // closes the step's last stage (the copy below is not timed)
    CUDA_CHECK(cudaMemcpyAsync(counters_host_, st_->counters.data(), sizeof(StepCounters), cudaMemcpyDeviceToHost, stream_));
    CUDA_CHECK(cudaStreamSynchronize(stream_));
    book_times();
    return *counters_host_;
  }

  // A further pass of the bound: the tree refit at the pass's start. Run whether or not the pass is
  // active (the flag is on the device); the next step's begin() refits it at x again.
  void refit_cloth_at(const Vec3* x, const StepCounters*) {
    mark(Stage::Update);
    if (cloth_.num_prims() > 0) cloth_.refit(x, cloth_indices_, stream_);
  }

  void end() { st_->flip(); }

 private:
  // Per-stage timing, the same stages as the CPU's: an event is recorded on the stream where the
  // step moves from one stage to another, and once the step's counters have come back (the stream
  // has drained) the GPU time between consecutive events is booked to the stage that began at the
  // first. The events are reused from step to step.
  void mark(Stage stage, bool close = false) {
    if (!close && used_ > 0 && stage == event_stage_[used_ - 1]) return;
    if (used_ == events_.size()) {
      cudaEvent_t e;
      CUDA_CHECK(cudaEventCreate(&e));
      events_.push_back(e);
      event_stage_.push_back(stage);
    }
    event_stage_[used_] = stage;
    CUDA_CHECK(cudaEventRecord(events_[used_], stream_));
    ++used_;
  }

  void book_times() {
    for (size_t k = 0; k + 1 < used_; ++k) {
      float ms = 0.0f;
      CUDA_CHECK(cudaEventElapsedTime(&ms, events_[k], events_[k + 1]));
      add_stage_time(*times_, event_stage_[k], double(ms) * 1e-3);
    }
    used_ = 0;
  }

  // The cloth tree is refit every step and rebuilt every kRebuildEvery steps (the CPU rebuilds on
  // the area trigger; the GPU avoids reading the area back inside a call).
  static constexpr int kRebuildEvery = 256;

  void refit_cloth_tree() {
    if (cloth_.num_prims() == 0) return;
    cloth_.refit(st_->x[st_->cur].data(), cloth_indices_, stream_);
    if (++refits_since_build_ >= kRebuildEvery) {
      cloth_.build(st_->x[st_->cur].data(), cloth_indices_, stream_);
      refits_since_build_ = 0;
    }
  }

  // Model, state and trees to the device, once.
  void upload() {
    const ClothModel& m = model_;
    // Every array of RAYCLOTH_MODEL_ARRAYS copied once; the view points at the copies.
    model_view_ = make_model_view(m, [&](const auto& host) {
      using T = typename std::decay_t<decltype(host)>::value_type;
      auto buffer = std::make_shared<DeviceBuffer<T>>(host);
      model_buffers_.push_back(buffer);
      return static_cast<const T*>(buffer->data());
    });
    cloth_indices_ = model_view_.triangles;
    tri_alias_ = model_view_.tri_alias;
    st_ = std::make_unique<SimState<DeviceBuffer>>(m);
    make_integrator(integrator_, scene_.time, m.num_vertices(), clock_.settings.iterations);

    std::vector<Vec3> ox, ov;
    obstacles_.pose_at(0.0, ox, ov);
    obstacle_x_ = DeviceBuffer<Vec3>(ox);
    obstacle_v_ = DeviceBuffer<Vec3>(ov);
    obstacle_prev_ = DeviceBuffer<Vec3>(ox);
    obstacle_indices_ = DeviceBuffer<uint32_t>(obstacles_.collision_indices);
    if (obstacles_.any_moving) upload_moving_vertices();
    // cudaMemcpy from pageable memory may return before the data has arrived: wait for it.
    CUDA_CHECK(cudaDeviceSynchronize());

    obstacle_tree_.allocate(uint32_t(obstacles_.num_collision_triangles()));
    obstacle_tree_.build(obstacle_x_.data(), obstacle_indices_.data(), stream_);
    // Built mid-run (after a weld): the tree as at t = 0, the obstacles where they are now (see the
    // CPU backend).
    if (in_.time != 0.0) {
      CUDA_CHECK(cudaStreamSynchronize(stream_));
      obstacles_.pose_at(in_.time, ox, ov);
      const size_t bytes = ox.size() * sizeof(Vec3);
      CUDA_CHECK(cudaMemcpy(obstacle_x_.data(), ox.data(), bytes, cudaMemcpyHostToDevice));
      CUDA_CHECK(cudaMemcpy(obstacle_v_.data(), ov.data(), bytes, cudaMemcpyHostToDevice));
      CUDA_CHECK(cudaMemcpy(obstacle_prev_.data(), ox.data(), bytes, cudaMemcpyHostToDevice));
    }
    cloth_.allocate(m.num_collision_triangles());
    cloth_.build(st_->x[st_->cur].data(), cloth_indices_, stream_);
    CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

  template <class T>
  void copy_on_device(const DeviceBuffer<T>& from, DeviceBuffer<T>& to) {
    if (from.bytes() > 0)
      CUDA_CHECK(cudaMemcpyAsync(to.data(), from.data(), from.bytes(), cudaMemcpyDeviceToDevice, stream_));
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

  // The poses at the end of each of this call's steps (t + dt), uploaded once before its steps.
  void upload_poses(int n, uint64_t first_step) {
    std::vector<double> times(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) times[size_t(k)] = clock_.time_at(first_step + uint64_t(k) + 1);
    skinning_.upload(times, stream_);
    if (moving_.empty()) return;
    std::vector<RigidPose> table(size_t(n) * moving_.size());
    for (int k = 0; k < n; ++k)
      for (size_t m = 0; m < moving_.size(); ++m)
        table[size_t(k) * moving_.size() + m] =
            rigid_pose_at(obstacles_.defs[moving_[m]], clock_.time_at(first_step + uint64_t(k) + 1));
    if (table.size() > pose_table_.size()) pose_table_.resize(table.size());
    CUDA_CHECK(cudaMemcpyAsync(pose_table_.data(), table.data(), table.size() * sizeof(RigidPose),
                               cudaMemcpyHostToDevice, stream_));
    CUDA_CHECK(cudaStreamSynchronize(stream_));  // `table` is pageable and goes out of scope
  }

  StepView view(uint64_t step) {
    StepBuffers b;
    b.model = model_view_;
    b.obstacle_x = obstacle_x_.data();
    b.obstacle_v = obstacle_v_.data();
    b.obstacle_prev = obstacle_prev_.data();
    b.obstacle_indices = obstacle_indices_.data();
    b.num_obstacle_vertices = uint32_t(obstacle_x_.size());
    b.bodies_move = obstacles_.any_moving;
    b.obstacle_bvh = obstacle_tree_.view();
    b.cloth_bvh = cloth_.view();
    return make_step_view(in_, clock_, step, b, *st_);
  }

  BvhScene trace_scene() {
    BvhScene b;
    b.obstacles = obstacle_tree_.view();
    b.obstacle_vertices = obstacle_x_.data();
    b.obstacle_indices = obstacle_indices_.data();
    if (scene_.collision.cloth_cloth) b.cloth = cloth_.view();
    b.cloth_positions = st_->x[st_->cur].data();
    b.cloth_indices = cloth_indices_;
    b.tri_alias = tri_alias_;
    return b;
  }

  const BackendInput in_;
  const SceneDef& scene_;
  const ClothModel& model_;
  const ObstacleSet& obstacles_;
  cudaStream_t stream_ = nullptr;
  StepCounters* counters_host_ = nullptr;  // pinned
  int refits_since_build_ = 0;
  uint64_t call_first_ = 0;
  int obstacle_refits_since_build_ = 0;

  ModelView model_view_;                              // over model_buffers_
  std::vector<std::shared_ptr<void>> model_buffers_;  // a DeviceBuffer per model array
  const uint32_t* cloth_indices_ = nullptr;           // model_view_.triangles
  const uint32_t* tri_alias_ = nullptr;
  std::unique_ptr<SimState<DeviceBuffer>> st_;
  std::unique_ptr<SimState<DeviceBuffer>> kept_;  // keep()
  DeviceBuffer<Vec3> kept_obstacle_x_, kept_obstacle_v_;
  AnyIntegrator<DeviceBuffer> integrator_;
  StageTimes* times_ = nullptr;
  std::vector<cudaEvent_t> events_;  // stage boundaries of the step in flight (mark, book_times)
  std::vector<Stage> event_stage_;
  size_t used_ = 0;  // allocated in upload(), once the stream exists
  DeviceBuffer<Vec3> obstacle_x_, obstacle_v_, obstacle_prev_;
  DeviceBuffer<uint32_t> obstacle_indices_;
  std::vector<size_t> moving_;  // obstacle index of each moving obstacle
  DeviceBuffer<uint32_t> moving_world_index_, moving_pose_index_;
  DeviceBuffer<Vec3> moving_local_;
  DeviceBuffer<RigidPose> pose_table_;
  DeviceBvh obstacle_tree_, cloth_;
  DeviceSkinning skinning_;
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

void cuda_pose_obstacles(const ObstacleSet& o, double t, std::vector<Vec3>& x, std::vector<Vec3>& v) {
  std::string why;
  if (!cuda_usable(&why)) throw SimulationError("device 'cuda' cannot run: " + why);
  // Everything but the skinned bodies as pose_at has it; those the device overwrites.
  std::vector<Vec3> hx, hv;
  o.pose_at(t, hx, hv);
  for (size_t oi = 0; oi < o.skinned.size(); ++oi)
    if (o.skinned[oi])
      for (size_t k = 0; k < o.local[oi].vertices.size(); ++k)
        hx[o.first_vertex[oi] + k] = hv[o.first_vertex[oi] + k] = make_vec3(NAN, NAN, NAN);
  DeviceBuffer<Vec3> dx(hx), dv(hv);
  DeviceSkinning skinning(o);
  skinning.upload({t}, nullptr);
  skinning.pose(0, dx.data(), dv.data(), nullptr);
  x.resize(hx.size());
  v.resize(hv.size());
  CUDA_CHECK(cudaMemcpy(x.data(), dx.data(), dx.bytes(), cudaMemcpyDeviceToHost));
  CUDA_CHECK(cudaMemcpy(v.data(), dv.data(), dv.bytes(), cudaMemcpyDeviceToHost));
}

std::unique_ptr<Backend> make_cuda_backend(const BackendInput& in) {
  std::string why;
  if (!cuda_usable(&why)) throw SimulationError("device 'cuda' cannot run: " + why);
  return std::make_unique<CudaBackend>(in);
}

}  // namespace raycloth
