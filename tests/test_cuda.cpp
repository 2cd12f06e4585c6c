// The CUDA backend against the CPU backend. Tests that need a GPU call GTEST_SKIP() with the reason
// when cuda_usable() says there is none (CI, and the machine this was written on); the rest pin
// what can be checked without one: the error without a GPU, the fallback of device "auto", and the
// obstacle poses the device computes (on the host, the same RC_HD code).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "raycloth/simulator.h"
#include "sim/backend.h"
#include "sim/cuda_pose.cuh"
#include "sim/model.h"

using namespace raycloth;

namespace {

#define SKIP_WITHOUT_GPU()                                                  \
  do {                                                                      \
    std::string why_;                                                       \
    if (!cuda_usable(&why_)) GTEST_SKIP() << "CUDA backend cannot run: " << why_; \
  } while (0)

// How far the deepest free cloth vertex is inside the obstacle mesh, taken as one convex body (true
// for the default scene's sphere), 0 when outside:
// the largest signed distance to the face planes is negative inside.
float deepest_penetration(const Simulator& sim, const std::vector<Vec3>& x) {
  const ObstacleSet& o = sim.obstacles();
  const std::vector<Vec3>& v = o.world.vertices;
  const std::vector<uint32_t>& idx = o.world.indices;
  float deepest = 0;
  for (uint32_t i = 0; i < x.size(); ++i) {
    if (sim.model().inv_mass[i] == 0.0f) continue;
    float outside = -INFINITY;
    for (size_t t = 0; t < o.world.num_triangles(); ++t) {
      const Vec3 a = v[idx[3 * t]], b = v[idx[3 * t + 1]], c = v[idx[3 * t + 2]];
      const Vec3 n = normalize_or_zero(cross(b - a, c - a));
      outside = std::max(outside, dot(n, x[i] - a));
    }
    deepest = std::max(deepest, -outside);
  }
  return deepest;
}

struct RunResult {
  std::vector<Vec3> x;
  uint64_t hits = 0;         // in the last step
  uint64_t recent_hits = 0;  // summed over the last `single_steps` steps
  float penetration = 0;
};

// `chunks` calls of step(n), then `single_steps` calls of step(1) to sum the hits of each.
RunResult run(const SceneDef& scene, const std::string& device, const std::vector<int>& chunks,
              int single_steps = 0) {
  SimOptions options;
  options.device = device;
  Simulator sim(scene, options);
  EXPECT_EQ(sim.device(), device);
  for (int n : chunks) sim.step(n);
  RunResult r;
  for (int k = 0; k < single_steps; ++k) {
    sim.step(1);
    r.recent_hits += sim.last_hits();
  }
  r.x = sim.positions();
  r.hits = sim.last_hits();
  r.penetration = deepest_penetration(sim, r.x);
  return r;
}

double max_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, double(length(a[i] - b[i])));
  return worst;
}

const std::vector<int> kNineHundredSteps(9, 100);  // then 100 single steps: 1000 in all

const RunResult& cpu_default_scene() {
  static const RunResult r = run(default_scene(), "cpu", kNineHundredSteps, 100);
  return r;
}

// A box sliding into the drape and turning: the device poses obstacles from the step index.
SceneDef moving_obstacle_scene() {
  SceneDef s = default_scene();
  ObstacleDef box;
  box.name = "pusher";
  box.type = ObstacleType::Box;
  box.size = {0.2f, 0.2f, 0.2f};
  box.transform.position = {-0.9f, 0.45f, 0.0f};
  MotionDef m;
  m.velocity = {1.0f, 0.0f, 0.0f};
  m.angular_velocity = {0.0f, 90.0f, 0.0f};
  m.start = 0.1;
  box.motion = m;
  s.obstacles.push_back(box);
  return s;
}

}  // namespace

TEST(CudaDevice, CudaWithoutAGpuThrowsSayingWhy) {
  std::string why;
  if (cuda_usable(&why)) GTEST_SKIP() << "a GPU is present: nothing to refuse";
  SimOptions options;
  options.device = "cuda";
  try {
    Simulator sim(default_scene(), options);
    FAIL() << "device 'cuda' ran without a usable GPU";
  } catch (const SimulationError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("device 'cuda' cannot run"), std::string::npos) << message;
    EXPECT_TRUE(message.find("no CUDA GPU found") != std::string::npos ||
                message.find("built without the CUDA backend") != std::string::npos)
        << message;
    EXPECT_NE(message.find(why), std::string::npos) << "the message carries cuda_usable's reason: " << message;
  }
}

TEST(CudaDevice, AutoUsesTheGpuWhenThereIsOneAndTheCpuOtherwise) {
  SimOptions options;
  options.device = "auto";
  Simulator sim(default_scene(), options);
  EXPECT_EQ(sim.device(), cuda_usable(nullptr) ? "cuda" : "cpu");
  sim.step(5);
  EXPECT_EQ(sim.steps(), 5u);
}

// pose_vertex repeats ObstacleSet::pose_at's per-vertex lines for the device; on the host the two
// must agree bit for bit, before the motion starts and during it.
TEST(CudaPose, DevicePoseEqualsObstacleSetPoseAt) {
  const SceneDef scene = moving_obstacle_scene();
  const ObstacleSet set = build_obstacles(scene);
  ASSERT_TRUE(set.any_moving);
  for (double t : {0.0, 0.05, 0.1, 0.1004, 0.37, 2.5}) {
    std::vector<Vec3> x, v;
    set.pose_at(t, x, v);
    for (size_t oi = 0; oi < set.defs.size(); ++oi) {
      if (!set.defs[oi].motion) continue;
      const RigidPose pose = rigid_pose_at(set.defs[oi], t);
      for (size_t k = 0; k < set.local[oi].vertices.size(); ++k) {
        Vec3 px, pv;
        pose_vertex(pose, set.local[oi].vertices[k], px, pv);
        const size_t g = set.first_vertex[oi] + k;
        ASSERT_TRUE(px.x == x[g].x && px.y == x[g].y && px.z == x[g].z) << "t " << t << " vertex " << k;
        ASSERT_TRUE(pv.x == v[g].x && pv.y == v[g].y && pv.z == v[g].z) << "t " << t << " vertex " << k;
      }
    }
  }
}

TEST(CudaParity, CpuReferenceIsPenetrationFree) {
  const RunResult& cpu = cpu_default_scene();
  const float thickness = default_scene().collision.thickness;
  EXPECT_LT(cpu.penetration, 0.5f * thickness);
  EXPECT_GT(cpu.hits, 100u) << "after 0.4 s the cloth should rest on the sphere";
}

// Before the cloth reaches the sphere (first contact near step 393) nothing is chaotic: the two
// backends differ only by rounding (the device contracts multiply-adds).
TEST(CudaParity, DefaultSceneMatchesCpuCloselyBeforeContact) {
  SKIP_WITHOUT_GPU();
  const RunResult cpu = run(default_scene(), "cpu", {50, 300});
  const RunResult gpu = run(default_scene(), "cuda", {50, 300});
  EXPECT_LT(max_distance(cpu.x, gpu.x), 1e-4) << "metres";
  EXPECT_EQ(gpu.hits, 0u);
}

// 1000 steps (0.4 s: the cloth has wrapped the sphere and folded). After contact the drape is
// chaotic: tests/test_bvh.cpp (BvhTrace.DrapeWithTheBvhMatchesEmbreeCastByCastAndStaysWithinChaos)
// shows a one-ulp change of one vertex ending 2-4 cm apart on average and the centroid up to ~1 cm
// apart, with 0.89-1.1 times the hits. The bounds are those of that test; docs/gpu.md.
TEST(CudaParity, DefaultSceneMatchesCpuOver1000Steps) {
  SKIP_WITHOUT_GPU();
  const RunResult& cpu = cpu_default_scene();
  const RunResult gpu = run(default_scene(), "cuda", kNineHundredSteps, 100);
  ASSERT_EQ(gpu.x.size(), cpu.x.size());
  double mean = 0;
  Vec3 cc = make_vec3(0, 0, 0), cg = cc;
  for (size_t i = 0; i < cpu.x.size(); ++i) {
    mean += length(gpu.x[i] - cpu.x[i]);
    cc += cpu.x[i];
    cg += gpu.x[i];
  }
  mean /= double(cpu.x.size());
  EXPECT_LT(mean, 0.08) << "mean distance, metres";
  EXPECT_LT(length(cc - cg) / float(cpu.x.size()), 0.03f) << "distance of the centroids, metres";
  EXPECT_NEAR(double(gpu.recent_hits) / double(cpu.recent_hits), 1.0, 0.25)
      << "hits over the last 100 steps: cpu " << cpu.recent_hits << ", cuda " << gpu.recent_hits;
  const float thickness = default_scene().collision.thickness;
  EXPECT_LT(gpu.penetration, 0.5f * thickness);
}

// How the steps are split into calls changes the graph launches, the read-backs and when the cloth
// tree is rebuilt, never the simulation: every kernel is deterministic and ties between equally
// near triangles go to the lowest id whatever the tree.
TEST(CudaParity, SplittingStepsIntoCallsDoesNotChangeTheResult) {
  SKIP_WITHOUT_GPU();
  const RunResult one = run(default_scene(), "cuda", {600});
  const RunResult many = run(default_scene(), "cuda", {1, 2, 97, 100, 300, 100});
  EXPECT_EQ(max_distance(one.x, many.x), 0.0);
  EXPECT_EQ(one.hits, many.hits);
}

// Moving obstacles: poses come from a per-call table on the device, and a longer call than any
// before captures the graphs again.
TEST(CudaParity, MovingObstacleMatchesCpu) {
  SKIP_WITHOUT_GPU();
  const SceneDef scene = moving_obstacle_scene();
  const std::vector<int> chunks{100, 300, 200};
  const RunResult cpu = run(scene, "cpu", chunks);
  const RunResult gpu = run(scene, "cuda", chunks);
  double sum = 0;
  for (size_t i = 0; i < cpu.x.size(); ++i) sum += length(gpu.x[i] - cpu.x[i]);
  EXPECT_LT(sum / double(cpu.x.size()), 0.08) << "mean distance, metres (chaotic after contact, as above)";
}

// A blow-up is found on the device (first bad vertex by atomicMin) and reported like the CPU does.
TEST(CudaParity, BlowUpIsReportedWithStepAndVertex) {
  SKIP_WITHOUT_GPU();
  SceneDef scene = default_scene();
  scene.time.dt = 0.05;
  SimOptions options;
  options.device = "cuda";
  options.allow_unstable_dt = true;
  Simulator sim(scene, options);
  try {
    sim.step(2000);
    FAIL() << "dt = 0.05 s should blow up";
  } catch (const SimulationError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("blew up at step"), std::string::npos) << message;
    EXPECT_LT(sim.steps(), 2000u) << "stepping stops at the bad step";
  }
}

// The implicit step (vertex block descent, the colours swept in one order on both devices) before
// contact: the two backends differ only by rounding. The GPU runs each call's sweeps as one kernel
// (CudaBackend::phases): on the default scene's 4252 vertices a cooperative grid with a grid barrier
// between colours, on a coarser cloth of at most 2048 vertices one block.
TEST(CudaParity, ImplicitStepMatchesCpuBeforeContact) {
  SKIP_WITHOUT_GPU();
  for (const int coarse : {1, 2}) {
    SceneDef scene = default_scene();
    for (PanelDef& p : scene.panels) {
      p.resolution_u = (p.resolution_u + coarse - 1) / coarse;
      p.resolution_v = (p.resolution_v + coarse - 1) / coarse;
    }
    scene.time.integrator = Integrator::Implicit;
    scene.time.dt = 2e-3;
    const RunResult cpu = run(scene, "cpu", {20, 40});
    const RunResult gpu = run(scene, "cuda", {20, 40});
    SCOPED_TRACE(std::to_string(cpu.x.size()) + " vertices");
    EXPECT_EQ(coarse == 1, cpu.x.size() > 2048);
    EXPECT_LT(max_distance(cpu.x, gpu.x), 1e-4) << "metres";
    EXPECT_EQ(gpu.hits, 0u);
  }
}

// A measured fabric on a triangle mesh (scenes/fabric/drape_denim.json: the Cusick drape): the
// membranes per triangle and the hinges across its edges run in the device's kernels as on the CPU.
TEST(CudaParity, MeasuredFabricMembranesAndHingesMatchCpu) {
  SKIP_WITHOUT_GPU();
  const SceneDef scene = load_scene_file(std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/fabric/drape_denim.json");
  const RunResult cpu = run(scene, "cpu", {200, 300});
  const RunResult gpu = run(scene, "cuda", {200, 300});
  EXPECT_LT(max_distance(cpu.x, gpu.x), 1e-4) << "metres";
}
