// CUDA backend: the shared per-vertex stages (sim/stages.h) as kernels over device-resident state,
// rays cast against the LBVH of collide/bvh.h (obstacle tree built once, cloth tree refit every
// step and rebuilt when refitting has degraded it). The kernels of one step are captured into two
// CUDA graphs, one per direction of the x/x_next double buffer, and Backend::step(n) launches them
// n times, alternating; the only transfer per call is the small StepControl read back at the end
// (plus, for scenes with moving obstacles, one upload of the call's obstacle poses). In cloth-cloth
// scenes each step ends with the crossing guard, a fixed number of rounds inside the graph
// (kGuardRounds). docs/gpu.md.
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
// Crossing-guard rounds per step. CpuBackend::guard loops until a round finds no edge through the
// cloth (at most 32 rounds, freezing every vertex in the 32nd). A graph cannot loop on a device
// result, so the GPU captures a fixed kGuardRounds rounds: once a round is clean the later ones
// return at once (flags in StepControl), and if the kGuardRounds-th round still finds a crossing it
// freezes every vertex, so the step still ends crossing-free. The two backends therefore differ
// only in a step that needs more than kGuardRounds rounds.
constexpr int kGuardRounds = 4;
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
  // Crossing guard (cloth-cloth scenes only).
  unsigned long long frozen = 0;           // vertices frozen in this call's steps
  unsigned long long guard_exhausted = 0;  // steps of this call whose last round froze everything
  unsigned int guard_open = 0;   // this step's guard has not had a clean round yet
  unsigned int guard_found = 0;  // the current round found an edge through the cloth
  // 1 while the cloth tree is not known to be fitted to x: the refit at the start of a step runs
  // only then. A clean guard round leaves the tree fitted to x_next, the next step's x (0).
  unsigned int cloth_stale = 1;
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
  c->frozen = 0;
  c->guard_exhausted = 0;
  c->guard_open = 0;
  c->guard_found = 0;
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

// The third ray's hit: the second response's move stops a thickness short of what it would cross.
__global__ void k_certify(StepView s, const StepControl* c) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (c->stopped || i >= s.model.num_vertices) return;
  stage_certify(s, i);
}

// ---- Crossing guard (CpuBackend::guard), kGuardRounds captured rounds ----------------------------
// Each round: cloth refit at x_next (only while guard_open), k_edge_ray, k_trace_edges against the
// cloth alone, k_edge_mark, k_freeze, k_guard_round_end. Every kernel returns at once when the
// guard is closed (a clean round came earlier in this step, or the step is past a blow-up).

__global__ void k_guard_begin(StepControl* c) {
  if (c->stopped) return;
  c->guard_open = 1;
  c->guard_found = 0;
}

__global__ void k_edge_ray(StepView s, const StepControl* c) {
  const uint32_t e = blockIdx.x * blockDim.x + threadIdx.x;
  if (!c->guard_open || e >= s.model.num_edges) return;
  stage_edge_ray(s, e);
}

// `scene` has an empty obstacle tree and the cloth at x_next, as BvhCollider::cast_cloth.
__global__ void k_trace_edges(BvhScene scene, const Ray* rays, RawHit* hits, uint32_t n, const StepControl* c) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (!c->guard_open || i >= n) return;
  hits[i] = trace_collision(scene, rays[i]);
}

// Plain stores of 1u, to `frozen` and to the round's flag: every writer stores the same value.
__global__ void k_edge_mark(StepView s, StepControl* c) {
  const uint32_t e = blockIdx.x * blockDim.x + threadIdx.x;
  if (!c->guard_open || e >= s.model.num_edges) return;
  if (stage_edge_mark(s, e)) c->guard_found = 1u;
}

// Puts the marked vertices back to x (every vertex in the last round) and counts them.
__global__ void k_freeze(StepView s, StepControl* c, bool last_round) {
  using Reduce = cub::BlockReduce<unsigned long long, kBlock>;
  __shared__ typename Reduce::TempStorage temp;
  if (!c->guard_open || !c->guard_found) return;  // uniform: no kernel running now writes them
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  unsigned long long frozen = 0;
  if (i < s.model.num_vertices) {
    if (last_round) s.frozen[i] = 1u;
    frozen = stage_freeze(s, i) ? 1 : 0;
  }
  const unsigned long long block_frozen = Reduce(temp).Sum(frozen);
  if (threadIdx.x == 0 && block_frozen) atomicAdd(&c->frozen, block_frozen);
}

__global__ void k_guard_round_end(StepControl* c, bool last_round) {
  if (!c->guard_open) return;
  if (!c->guard_found) {
    // Clean: the tree was refit at this x_next, which the freezes left unchanged.
    c->guard_open = 0;
    c->cloth_stale = 0;
    return;
  }
  c->guard_found = 0;
  if (last_round) {
    // Everything is back at the crossing-free x, but the tree is fitted to the positions before.
    c->guard_open = 0;
    c->cloth_stale = 1;
    ++c->guard_exhausted;
  }
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

// Events around the stages of one step, for the per-stage profile (RAYCLOTH_CUDA_PROFILE=1):
// e[0] opens the step, and the time from e[k-1] to e[k] goes to the StageTimes field to[k].
using StageField = double StageTimes::*;
struct StageEvents {
  static constexpr int kMax = 10 + 3 * kGuardRounds;
  cudaEvent_t e[kMax] = {};
  StageField to[kMax] = {};
  int count = 0;
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
        CUDA_CHECK(cudaEventSynchronize(events_.e[events_.count - 1]));
        for (int j = 1; j < events_.count; ++j) times.*events_.to[j] += elapsed(events_.e[j - 1], events_.e[j]);
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
    result.frozen = c.frozen;
    guard_exhausted_ += c.guard_exhausted;
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
    edges_ = DeviceBuffer<uint32_t>(m.edges);

    const std::vector<Vec3> zero(n, make_vec3(0, 0, 0));
    for (int b = 0; b < 2; ++b) {
      x_[b] = DeviceBuffer<Vec3>(m.initial_positions);
      v_[b] = DeviceBuffer<Vec3>(zero);
    }
    contact_normal_ = DeviceBuffer<Vec3>(zero);
    rays_.resize(n);
    hits_.resize(n);
    contacts_.resize(n);
    edge_rays_.resize(m.num_edges());
    edge_hits_.resize(m.num_edges());
    frozen_ = DeviceBuffer<uint32_t>(std::vector<uint32_t>(n, 0u));
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
    s.model.edges = edges_.data();
    s.model.num_edges = model_.num_edges();
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
    s.edge_rays = edge_rays_.data();
    s.edge_hits = edge_hits_.data();
    s.frozen = frozen_.data();
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
  // `ev`, events between the stages (each one names the StageTimes field of the span it closes).
  void enqueue_step(int parity, StageEvents* ev) {
    const uint32_t n = model_.num_vertices();
    StepControl* c = control_.data();
    const StepView s = view(parity);
    const BvhScene scene = trace_scene(parity);
    const bool guard = scene_.collision.cloth_cloth && cloth_.num_prims() > 0 && model_.num_edges() > 0;
    if (ev) ev->count = 0;
    auto mark = [&](StageField to) {
      if (!ev) return;
      ev->to[ev->count] = to;
      CUDA_CHECK(cudaEventRecord(ev->e[ev->count++], stream_));
    };
    mark(nullptr);
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
    // With the guard, a step whose guard ended clean left the tree fitted to this x: the refit
    // runs only while StepControl::cloth_stale says otherwise (as CpuBackend's cloth_at_x_).
    if (cloth_.num_prims() > 0) {
      const unsigned int* stale = guard ? control_field<unsigned int>(offsetof(StepControl, cloth_stale)) : nullptr;
      cloth_.refit(x_[parity].data(), cloth_indices_.data(), stream_, stale);
    }
    mark(&StageTimes::update);
    k_integrate<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::integrate);
    k_trace<<<grid_for(n), kBlock, 0, stream_>>>(scene, rays_.data(), hits_.data(), n, c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::cast);
    k_respond_velocity<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::respond);
    k_trace<<<grid_for(n), kBlock, 0, stream_>>>(scene, rays_.data(), hits_.data(), n, c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::cast);
    k_respond_contact<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::respond);
    // Third rays (prepared by stage_respond_contact) against the full scene, then certify.
    k_trace<<<grid_for(n), kBlock, 0, stream_>>>(scene, rays_.data(), hits_.data(), n, c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::cast);
    k_certify<<<grid_for(n), kBlock, 0, stream_>>>(s, c);
    CUDA_CHECK_LAUNCH();
    if (guard) enqueue_guard(parity, s, mark);
    // After the guard, so that the step that blows up still runs certify and the guard, as on the CPU.
    k_finish_step<<<1, 1, 0, stream_>>>(c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::respond);
  }

  // The crossing guard without a host round trip: kGuardRounds rounds captured in the graph (see
  // kGuardRounds for how this differs from CpuBackend::guard's loop).
  template <class Mark>
  void enqueue_guard(int parity, const StepView& s, Mark& mark) {
    const int next = parity ^ 1;
    const uint32_t n = model_.num_vertices(), ne = model_.num_edges();
    StepControl* c = control_.data();
    const unsigned int* open = control_field<unsigned int>(offsetof(StepControl, guard_open));
    // BvhCollider::cast_cloth: the cloth alone, at x_next.
    BvhScene cloth_only = trace_scene(next);
    cloth_only.obstacles = BvhView();
    cloth_only.obstacle_vertices = nullptr;
    cloth_only.obstacle_indices = nullptr;
    k_guard_begin<<<1, 1, 0, stream_>>>(c);
    CUDA_CHECK_LAUNCH();
    mark(&StageTimes::respond);
    for (int round = 0; round < kGuardRounds; ++round) {
      const bool last = round + 1 == kGuardRounds;
      cloth_.refit(x_[next].data(), cloth_indices_.data(), stream_, open);
      mark(&StageTimes::update);
      k_edge_ray<<<grid_for(ne), kBlock, 0, stream_>>>(s, c);
      CUDA_CHECK_LAUNCH();
      k_trace_edges<<<grid_for(ne), kBlock, 0, stream_>>>(cloth_only, edge_rays_.data(), edge_hits_.data(), ne, c);
      CUDA_CHECK_LAUNCH();
      mark(&StageTimes::cast);
      k_edge_mark<<<grid_for(ne), kBlock, 0, stream_>>>(s, c);
      CUDA_CHECK_LAUNCH();
      k_freeze<<<grid_for(n), kBlock, 0, stream_>>>(s, c, last);
      CUDA_CHECK_LAUNCH();
      k_guard_round_end<<<1, 1, 0, stream_>>>(c, last);
      CUDA_CHECK_LAUNCH();
      mark(&StageTimes::respond);
    }
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
  uint64_t guard_exhausted_ = 0;  // steps whose last guard round still found a crossing (all frozen)

  DeviceBuffer<float> inv_mass_, damping_, adj_rest_, adj_k_, adj_kd_;
  DeviceBuffer<uint32_t> adj_offset_, adj_other_, alias_, cloth_indices_, tri_alias_, edges_;
  DeviceBuffer<Vec3> x_[2], v_[2], contact_normal_;
  DeviceBuffer<Ray> rays_;
  DeviceBuffer<RawHit> hits_;
  DeviceBuffer<Contact> contacts_;
  DeviceBuffer<Ray> edge_rays_;        // crossing guard: one per model edge
  DeviceBuffer<RawHit> edge_hits_;
  DeviceBuffer<uint32_t> frozen_;      // crossing guard: per vertex, zero between rounds
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
