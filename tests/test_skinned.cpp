// Skinned glTF bodies: linear blend skinning against hand-computed poses, the animation sampler,
// the loader's error messages, surface velocities, and cloth on the walking man checked exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "fixtures.h"
#include "skinned_gltf.h"
#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "scene/skinned_mesh.h"
#include "sim/backend.h"
#include "sim/cuda_pose.cuh"
#include "sim/model.h"
#include "sim/step_view.h"

namespace raycloth {
namespace {

const std::string kSource = RAYCLOTH_SOURCE_DIR;

Affine translation(float x, float y, float z) {
  Affine a;
  a.m[3] = x, a.m[7] = y, a.m[11] = z;
  return a;
}

TEST(Skinning, OneJointMovesTheVertexRigidly) {
  const Affine joints[1] = {translation(1, 2, 3)};
  const uint16_t j[4] = {0, 0, 0, 0};
  const float w[4] = {1, 0, 0, 0};
  const Vec3 p = skin_vertex(joints, j, w, make_vec3(0.5f, 0, 0));
  EXPECT_FLOAT_EQ(p.x, 1.5f);
  EXPECT_FLOAT_EQ(p.y, 2.0f);
  EXPECT_FLOAT_EQ(p.z, 3.0f);
}

TEST(Skinning, TwoJointsBlendByWeight) {
  // Joint 0 leaves the vertex where it is; joint 1 turns it 90 degrees about z and lifts it by 1.
  Affine turn;
  turn.m[0] = 0, turn.m[1] = -1, turn.m[4] = 1, turn.m[5] = 0, turn.m[7] = 1;
  const Affine joints[2] = {Affine(), turn};
  const uint16_t j[4] = {0, 1, 0, 0};
  const float w[4] = {0.25f, 0.75f, 0, 0};
  // (1, 0, 0): joint 0 gives (1, 0, 0), joint 1 gives (0, 2, 0); 0.25 and 0.75 of each.
  const Vec3 p = skin_vertex(joints, j, w, make_vec3(1, 0, 0));
  EXPECT_FLOAT_EQ(p.x, 0.25f);
  EXPECT_FLOAT_EQ(p.y, 1.5f);
  EXPECT_FLOAT_EQ(p.z, 0.0f);
}

SkinnedMesh one_node_animation(AnimationChannel::Interpolation interp) {
  SkinnedMesh m;
  m.parent = {-1};
  m.rest.resize(1);
  m.joints = {0};
  m.inverse_bind = {Affine()};
  AnimationChannel rot;
  rot.node = 0;
  rot.path = AnimationChannel::Path::Rotation;
  rot.interpolation = interp;
  rot.times = {0.0f, 1.0f};
  const float s = std::sqrt(0.5f);
  rot.values = {0, 0, 0, 1, 0, 0, s, s};  // identity, then 90 degrees about z
  AnimationChannel move;
  move.node = 0;
  move.path = AnimationChannel::Path::Translation;
  move.interpolation = interp;
  move.times = {0.0f, 1.0f};
  move.values = {0, 0, 0, 2, 0, 0};
  m.channels = {rot, move};
  m.start = 0, m.end = 1;
  return m;
}

TEST(AnimationSampler, LinearSlerpsRotationsAndLerpsTranslationsBetweenKeys) {
  const SkinnedMesh m = one_node_animation(AnimationChannel::Interpolation::Linear);
  const NodeTrs at_key = m.sample(1.0f, 1.0f)[0];
  EXPECT_NEAR(at_key.r[2], std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(at_key.t[0], 2.0f, 1e-6f);
  const NodeTrs mid = m.sample(0.5f, 1.0f)[0];
  EXPECT_NEAR(mid.r[2], std::sin(float(M_PI) / 8), 1e-6f);  // 45 degrees about z
  EXPECT_NEAR(mid.r[3], std::cos(float(M_PI) / 8), 1e-6f);
  EXPECT_NEAR(mid.t[0], 1.0f, 1e-6f);
  // Before the first key and after the last, the end keys hold.
  EXPECT_NEAR(m.sample(-1.0f, 1.0f)[0].t[0], 0.0f, 1e-6f);
  EXPECT_NEAR(m.sample(7.0f, 1.0f)[0].t[0], 2.0f, 1e-6f);
  // Half blended from the rest pose (identity) at the last key: 45 degrees, 1 m.
  const NodeTrs half = m.sample(1.0f, 0.5f)[0];
  EXPECT_NEAR(half.r[2], std::sin(float(M_PI) / 8), 1e-6f);
  EXPECT_NEAR(half.t[0], 1.0f, 1e-6f);
  // The joint matrix turns (1, 0, 0) 45 degrees and moves it by 1 m in x.
  std::vector<Vec3> out;
  SkinnedMesh with_vertex = m;
  with_vertex.vertices = {SkinnedVertex{make_vec3(1, 0, 0), {0, 0, 0, 0}, {1, 0, 0, 0}}};
  with_vertex.skin(with_vertex.joint_matrices(with_vertex.sample(0.5f, 1.0f)), out);
  EXPECT_NEAR(out[0].x, 1.0f + std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(out[0].y, std::sqrt(0.5f), 1e-6f);
}

TEST(AnimationSampler, StepHoldsTheEarlierKey) {
  const SkinnedMesh m = one_node_animation(AnimationChannel::Interpolation::Step);
  EXPECT_NEAR(m.sample(0.99f, 1.0f)[0].t[0], 0.0f, 1e-6f);
  EXPECT_NEAR(m.sample(0.99f, 1.0f)[0].r[3], 1.0f, 1e-6f);
  EXPECT_NEAR(m.sample(1.0f, 1.0f)[0].t[0], 2.0f, 1e-6f);
}

TEST(AnimationSampler, LoopingSpreadsTheMismatchOfTheEndsOverTheCycle) {
  // The clip turns 90 degrees and moves 2 m and does not come back: looped, its end is its start.
  const SkinnedMesh m = one_node_animation(AnimationChannel::Interpolation::Linear);
  const NodeTrs first = m.sample(0.0f, 1.0f, true)[0], last = m.sample(1.0f, 1.0f, true)[0];
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(last.t[k], first.t[k], 1e-6f);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(last.r[k], first.r[k], 1e-6f);
  // Half way: the clip's 45 degrees and 1 m, less half of the mismatch (45 degrees, 1 m).
  const NodeTrs mid = m.sample(0.5f, 1.0f, true)[0];
  EXPECT_NEAR(mid.t[0], 0.0f, 1e-6f);
  EXPECT_NEAR(mid.r[3], 1.0f, 1e-6f);
  // Without loop the clip plays as it is.
  EXPECT_NEAR(m.sample(1.0f, 1.0f, false)[0].t[0], 2.0f, 1e-6f);
}

TEST(AnimationSampler, CubicSplineFollowsTheHermiteCurveOfItsTangents) {
  // A glTF with known tangents: the root translates along x through keys 0, 1, 4 at t = 0, 2, 3
  // and turns from identity to 90 degrees about z with zero tangents. The in-tangent of the first
  // key and the out-tangent of the last are never used (99 and -99 here would show if they were).
  test::SkinnedGltf g = test::one_joint_triangle();
  test::GltfChannel move{0, "translation", "CUBICSPLINE", {0, 2, 3},
                         {99, 0, 0, /**/ 0, 0, 0, /**/ 3, 0, 0,      // key 0: value 0, out-tangent 3
                          -1, 0, 0, /**/ 1, 0, 0, /**/ 0.5f, 0, 0,   // key 1: in -1, value 1, out 0.5
                          2, 0, 0, /**/ 4, 0, 0, /**/ -99, 0, 0}};   // key 2: in 2, value 4
  const float s = std::sqrt(0.5f);
  test::GltfChannel turn{0, "rotation", "CUBICSPLINE", {0, 2},
                         {0, 0, 0, 0, /**/ 0, 0, 0, 1, /**/ 0, 0, 0, 0,  //
                          0, 0, 0, 0, /**/ 0, 0, s, s, /**/ 0, 0, 0, 0}};
  g.animations = {test::GltfAnimation{"curve", {move, turn}}};
  const auto path = test::fresh_temp_dir("cubic") / "cubic.gltf";
  test::write_skinned_gltf(path, g);
  const SkinnedMesh m = load_skinned_mesh(path.string(), "curve", [](const std::string& f, const std::string& r) {
    throw InputError("test", f, r);
  });
  ASSERT_EQ(m.channels.size(), 2u);
  EXPECT_EQ(m.channels[0].interpolation, AnimationChannel::Interpolation::CubicSpline);
  EXPECT_FLOAT_EQ(m.start, 0.0f);
  EXPECT_FLOAT_EQ(m.end, 3.0f);
  auto x_at = [&](float t) { return m.sample(t, 1.0f)[0].t[0]; };
  // At the keys: the key values.
  EXPECT_NEAR(x_at(0.0f), 0.0f, 1e-6f);
  EXPECT_NEAR(x_at(2.0f), 1.0f, 1e-6f);
  EXPECT_NEAR(x_at(3.0f), 4.0f, 1e-6f);
  // Between keys 0 and 1 (dt = 2): p(u) = h00 p0 + h10 dt m0 + h01 p1 + h11 dt m1 with m0 = 3, m1 = -1.
  // u = 0.5: 0 + 0.125 * 2 * 3 + 0.5 * 1 - 0.125 * 2 * (-1) = 1.5.
  EXPECT_NEAR(x_at(1.0f), 1.5f, 1e-6f);
  // u = 0.25: h10 = 0.140625, h01 = 0.15625, h11 = -0.046875: 0.84375 + 0.15625 + 0.09375.
  EXPECT_NEAR(x_at(0.5f), 1.09375f, 1e-6f);
  // Between keys 1 and 2 (dt = 1), u = 0.5, m0 = 0.5, m1 = 2: 0.5 + 0.0625 + 2 - 0.25.
  EXPECT_NEAR(x_at(2.5f), 2.3125f, 1e-6f);
  // The rotation with zero tangents at u = 0.25: 0.84375 identity + 0.15625 of the key, normalised.
  const NodeTrs r = m.sample(0.5f, 1.0f)[0];
  const float qz = 0.15625f * s, qw = 0.84375f + 0.15625f * s, len = std::sqrt(qz * qz + qw * qw);
  EXPECT_NEAR(r.r[2], qz / len, 1e-6f);
  EXPECT_NEAR(r.r[3], qw / len, 1e-6f);
  // Skinned at t = 1: 45 degrees about z (the midpoint of the symmetric curve), then x + 1.5.
  std::vector<Vec3> out;
  m.skin(m.joint_matrices(m.sample(1.0f, 1.0f)), out);
  EXPECT_NEAR(out[0].x, 1.5f + s, 1e-6f);
  EXPECT_NEAR(out[0].y, s, 1e-6f);
  EXPECT_NEAR(out[0].z, 0.0f, 1e-6f);
}

TEST(Skinning, TwoJointsOfAFileBlendTheirPosesByWeight) {
  // Two joints in a chain (shoulder at the origin, elbow 1 m along x); the elbow turns 90 degrees
  // about z. A vertex at x = 2 bound half to each: the shoulder leaves it at (2, 0, 0), the elbow
  // takes it to (1, 1, 0); blended (1.5, 0.5, 0). A vertex bound only to the elbow goes to (1, 1, 0).
  test::SkinnedGltf g;
  g.nodes = {test::GltfNode{"shoulder", -1, {0, 0, 0}}, test::GltfNode{"elbow", 0, {1, 0, 0}}};
  g.joints = {0, 1};
  g.positions = {2, 0, 0, 2, 0, 0, 0, 0, 1};
  g.joints0 = {0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0};
  g.weights0 = {0.5f, 0.5f, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  g.indices = {0, 1, 2};
  const float s = std::sqrt(0.5f);
  g.animations = {test::GltfAnimation{"bend", {test::GltfChannel{1, "rotation", "LINEAR", {0, 1}, {0, 0, 0, 1, 0, 0, s, s}}}}};
  const auto path = test::fresh_temp_dir("two_joints") / "arm.gltf";
  test::write_skinned_gltf(path, g);
  const SkinnedMesh m = load_skinned_mesh(path.string(), "", [](const std::string& f, const std::string& r) {
    throw InputError("test", f, r);
  });
  std::vector<Vec3> out;
  m.skin(m.joint_matrices(m.sample(0.0f, 1.0f)), out);  // the first key is the bind pose
  EXPECT_NEAR(out[0].x, 2.0f, 1e-6f);
  EXPECT_NEAR(out[1].x, 2.0f, 1e-6f);
  m.skin(m.joint_matrices(m.sample(1.0f, 1.0f)), out);
  EXPECT_NEAR(out[0].x, 1.5f, 1e-6f);
  EXPECT_NEAR(out[0].y, 0.5f, 1e-6f);
  EXPECT_NEAR(out[1].x, 1.0f, 1e-6f);
  EXPECT_NEAR(out[1].y, 1.0f, 1e-6f);
  EXPECT_NEAR(out[2].z, 1.0f, 1e-6f);  // bound to the shoulder, which does not move
}

std::string load_error(const std::string& file, const std::string& animation) {
  try {
    load_skinned_mesh(file, animation, [](const std::string& field, const std::string& reason) {
      throw InputError("scene.json", "/obstacles/0/" + field, reason);
    });
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SkinnedErrors, EachBadInputSaysWhatIsWrong) {
  const std::string data = kSource + "/tests/data/";
  EXPECT_EQ(load_error(data + "missing.glb", ""),
            "scene.json: /obstacles/0/file: glTF file '" + data + "missing.glb' does not exist");
  EXPECT_EQ(load_error(data + "no_skin.gltf", ""),
            "scene.json: /obstacles/0/file: glTF file '" + data + "no_skin.gltf' has no skin");
  EXPECT_EQ(load_error(data + "skin_bad_weights.gltf", ""),
            "scene.json: /obstacles/0/file: glTF file '" + data +
                "skin_bad_weights.gltf' mesh 'tri': the weights of vertex 0 sum to 0.7, not 1");
  EXPECT_EQ(load_error(data + "triangle.obj", ""),
            "scene.json: /obstacles/0/file: glTF file '" + data +
                "triangle.obj' is malformed: parse error at line 1, column 1: syntax error while parsing value - "
                "invalid literal; last read: '#'");
  const std::string man = kSource + "/assets/walking_man.glb";
  EXPECT_EQ(load_error(man, "run"), "scene.json: /obstacles/0/animation: unknown animation 'run' (glTF file '" + man +
                                        "' has 'walk')");
}

TEST(SkinnedErrors, MoreJointsThanTheFormatAllowsAndUnknownNamesAmongSeveral) {
  const auto dir = test::fresh_temp_dir("skinned_errors");
  // A joint index past the skin's joints.
  test::SkinnedGltf g = test::one_joint_triangle();
  g.joints0[4] = 3;  // vertex 1, its first (and only weighted) joint
  const std::string bad_joint = (dir / "bad_joint.gltf").string();
  test::write_skinned_gltf(bad_joint, g);
  EXPECT_EQ(load_error(bad_joint, ""), "scene.json: /obstacles/0/file: glTF file '" + bad_joint +
                                           "' mesh 'body': vertex 1 uses joint 3 but the skin has 1 joints (0 to 0)");
  // A fifth influence (JOINTS_1, WEIGHTS_1 with a weight) is refused; an unused second set is not.
  g = test::one_joint_triangle();
  g.joints1.assign(12, 0);
  g.weights1.assign(12, 0.0f);
  const std::string unused = (dir / "unused_joints1.gltf").string();
  test::write_skinned_gltf(unused, g);
  EXPECT_EQ(load_error(unused, ""), "no error");
  g.weights0[8] = 0.75f;  // vertex 2: 0.75 + 0.25
  g.weights1[8] = 0.25f;
  const std::string five = (dir / "five_joints.gltf").string();
  test::write_skinned_gltf(five, g);
  EXPECT_EQ(load_error(five, ""), "scene.json: /obstacles/0/file: glTF file '" + five +
                                      "' mesh 'body': vertex 2 has weights in WEIGHTS_1: more than 4 joints per "
                                      "vertex, at most 4 are supported (JOINTS_0, WEIGHTS_0)");
  // Several animations: an unknown name lists them all.
  g = test::one_joint_triangle();
  for (const char* name : {"idle", "wave", "run fast"})
    g.animations.push_back(test::GltfAnimation{name, {test::GltfChannel{0, "translation", "STEP", {0}, {0, 0, 0}}}});
  const std::string named = (dir / "named.gltf").string();
  test::write_skinned_gltf(named, g);
  EXPECT_EQ(load_error(named, "walk"), "scene.json: /obstacles/0/animation: unknown animation 'walk' (glTF file '" +
                                           named + "' has 'idle', 'wave', 'run fast')");
  EXPECT_EQ(load_error(named, "wave"), "no error");
  // No skin at all, written by the same writer.
  g = test::one_joint_triangle();
  g.skinned = false;
  const std::string no_skin = (dir / "no_skin.gltf").string();
  test::write_skinned_gltf(no_skin, g);
  EXPECT_EQ(load_error(no_skin, ""), "scene.json: /obstacles/0/file: glTF file '" + no_skin + "' has no skin");
}

SceneDef walking_scene() { return load_scene_file(kSource + "/scenes/walking_body.json"); }

TEST(SkinnedBody, LoadsEveryPrimitiveAndPosesItsRestPoseFirst) {
  const SceneDef s = walking_scene();
  const ObstacleSet set = build_obstacles(s);
  ASSERT_TRUE(set.skinned[0]);
  EXPECT_EQ(set.world.vertices.size(), 3379u);   // body, t-shirt, jeans, shoes
  EXPECT_EQ(set.world.num_triangles(), 6174u);
  EXPECT_EQ(set.skinned[0]->joints.size(), 77u);
  EXPECT_EQ(set.skinned[0]->animation, "walk");
  EXPECT_TRUE(set.any_moving);
}

TEST(SkinnedBody, SurfaceVelocityIsThePoseChangeOverTime) {
  const ObstacleSet set = build_obstacles(walking_scene());
  const double t = 1.2, dt = 1e-3;
  std::vector<Vec3> x0, v0, x1, v1;
  set.pose_at(t, x0, v0);
  set.pose_at(t + dt, x1, v1);
  float fastest = 0;
  for (size_t i = 0; i < x0.size(); ++i) {
    const Vec3 moved = (x1[i] - x0[i]) * float(1.0 / dt);
    fastest = std::max(fastest, length(moved));
    EXPECT_LT(length(moved - v0[i]), 0.05f + 0.05f * length(moved)) << "vertex " << i;
  }
  EXPECT_GT(fastest, 0.5f);  // hands and feet move at walking speed
}

TEST(SkinnedBody, LoopingWalkDoesNotJumpAtTheWrap) {
  // The shipped walk's last key differs from its first (about 2 degrees at a thigh and a shoulder):
  // played as it is, the body jumped 3.4 cm in one step at each wrap and the surface velocity
  // spiked. Looped, the mismatch is spread over the cycle.
  const SceneDef s = walking_scene();
  const ObstacleSet set = build_obstacles(s);
  const SkinnedMesh& m = *set.skinned[0];
  const double span = double(m.end) - double(m.start);
  ASSERT_GT(span, 0.5);
  ASSERT_TRUE(s.obstacles[0].loop);
  const double wrap = 2 * span / double(s.obstacles[0].speed);  // the second wrap, well after the blend-in
  const double h = 1e-4;
  std::vector<Vec3> before, after, x, v, ignored;
  set.pose_at(wrap - h, before, ignored);
  set.pose_at(wrap + h, after, ignored);
  set.pose_at(wrap, x, v);
  float jump = 0, fastest = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    jump = std::max(jump, length(after[i] - before[i]));
    fastest = std::max(fastest, length(v[i]));
  }
  // Hands and feet move at a few m/s: well under a millimetre in 0.2 ms.
  EXPECT_LT(jump, 1e-3f) << "the body jumps at the loop's wrap";
  EXPECT_LT(fastest, 8.0f) << "the surface velocity spikes at the loop's wrap";
}

TEST(SkinnedBody, CudaDeviceNoLongerRefusesSkinnedBodies) {
  // Skinned bodies are posed on the device now: without a GPU, device "cuda" says only what is
  // missing (it used to refuse the walking man for being skinned).
  std::string why;
  if (cuda_usable(&why)) GTEST_SKIP() << "a GPU is present: SkinnedBody.CudaRunsTheWalkingMan runs instead";
  SimOptions opt;
  opt.device = "cuda";
  try {
    Simulator sim(walking_scene(), opt);
    FAIL() << "accepted without a GPU";
  } catch (const SimulationError& e) {
    EXPECT_EQ(std::string(e.what()), "device 'cuda' cannot run: " + why);
  }
}

TEST(SkinnedBody, ObstacleReachIsTheLargestVertexMoveOfTheStep) {
  // How far the body moves in a step, as both backends measure it (stage_obstacle_move and
  // obstacle_reach, sim/step_view.h): the largest move of any vertex of the posed body, with 1 %
  // and 0.1 um to spare; 0 where no body moves.
  const ObstacleSet set = build_obstacles(walking_scene());
  const double dt = 4e-4;
  for (double t : {0.0, 0.2, 0.65, 1.0 - dt, 1.9, 3.2}) {
    std::vector<Vec3> x0, x1, v;
    set.pose_at(t, x0, v);
    set.pose_at(t + dt, x1, v);
    float moved = 0;
    for (size_t i = 0; i < x0.size(); ++i) moved = std::max(moved, length(x1[i] - x0[i]));
    StepCounters counters;
    StepView s;
    s.counters = &counters;
    s.geom.obstacle_vertices = x1.data();
    s.obstacle_prev = x0.data();
    s.bodies_move = true;
    for (uint32_t i = 0; i < x0.size(); ++i) stage_obstacle_move(s, i);
    EXPECT_EQ(obstacle_reach(s), moved * 1.01f + 1e-7f) << "t = " << t;
    EXPECT_GT(obstacle_reach(s), 0.0f);
    s.bodies_move = false;
    EXPECT_EQ(obstacle_reach(s), 0.0f);
  }
}

TEST(SkinnedBody, CudaPosesTheWalkingManAsTheCpuDoes) {
  std::string why;
  if (!cuda_usable(&why)) GTEST_SKIP() << "CUDA backend cannot run: " << why;
  const ObstacleSet set = build_obstacles(walking_scene());
  for (double t : {0.0, 0.15, 0.7, 1.0, 2.3}) {
    std::vector<Vec3> x, v, dx, dv;
    set.pose_at(t, x, v);
    cuda_pose_obstacles(set, t, dx, dv);
    ASSERT_EQ(dx.size(), x.size());
    for (size_t i = 0; i < x.size(); ++i) {
      // The same code on both; the device may contract multiply-adds.
      ASSERT_LT(length(dx[i] - x[i]), 1e-5f) << "t = " << t << " vertex " << i;
      ASSERT_LT(length(dv[i] - v[i]), 1e-3f + 1e-4f * length(v[i])) << "t = " << t << " vertex " << i;
    }
  }
}

TEST(SkinnedBody, CudaRunsTheWalkingManOutsideAndUncrossed) {
  std::string why;
  if (!cuda_usable(&why)) GTEST_SKIP() << "CUDA backend cannot run: " << why;
  SimOptions opt;
  opt.device = "cuda";
  Simulator sim(walking_scene(), opt);
  ASSERT_EQ(sim.device(), "cuda");
  ASSERT_EQ(test::step_checked(sim, 2250, 10), "");
  EXPECT_GT(sim.totals().pushed, 1000u) << "the body never touched the cloth";
}

TEST(SkinnedBody, ClothOnTheWalkingManStaysOutsideAndUncrossed) {
  // The shipped scene for 0.9 s: the cloth lands on his head at about 0.33 s and is then carried
  // by a walking body; checked exactly every 10 steps (the body is open: winding number). The whole
  // 3.5 s, checked every 10 steps, was clean too (docs/garments.md).
  Simulator sim(walking_scene());
  ASSERT_EQ(test::step_checked(sim, 2250, 10), "");
  EXPECT_GT(sim.totals().pushed, 1000u) << "the body never touched the cloth";
}

TEST(SkinnedBody, ClothStaysOutsideAnArmSwingingFastThroughIt) {
  // A cloth hangs from its top edge (0.6 m square, 16 x 16, in the plane z = 0, 0.7 to 1.3 m high).
  // An arm (tests/skinned_gltf.h: two joints, the elbow bending, weights blended between them) has
  // its shoulder at (-0.65, 1, 0), beside the cloth's left edge. It starts pointing at +z (in front of
  // the cloth), swings 135 degrees about +y, broadside through the cloth's plane, and back: played at
  // speed 0.25 it turns at 225 degrees/s, the tip at 2.4 m/s (1 mm a step, half the thickness), and
  // it carries the cloth 0.3 m back and lets it go. Checked exactly every 5 steps over 1.3 s.
  // At speed 0.5 (tip 4.7 m/s) the check finds a vertex inside the arm where the swing turns back
  // (docs/garments.md).
  const auto path = test::fresh_temp_dir("swinging_arm") / "arm.gltf";
  test::write_skinned_gltf(path, test::swinging_arm(135.0f));
  SceneDef s = test::panel_scene(16, 0.6f, 1.0f);
  s.name = "swinging_arm";
  s.time.duration = 1.3;
  s.panels[0].transform.rotation = {-90, 0, 0};  // local +z (the top edge) up, normal -z
  PinDef top;
  top.panel = "cloth";
  top.edge = "top";
  s.pins.push_back(top);
  ObstacleDef arm;
  arm.name = "arm";
  arm.type = ObstacleType::Skinned;
  arm.file = path.string();
  arm.animation = "swing";
  arm.loop = false;
  arm.speed = 0.25f;
  arm.transform.position = {-0.65f, 1.0f, 0.0f};
  arm.transform.rotation = {0, 90, 0};  // the animation's first pose (along -x) along +z
  s.obstacles.push_back(arm);
  Simulator sim(s);
  const std::vector<Vec3> start = sim.positions();
  float carried_back = 0;
  for (int k = 0; k < 13; ++k) {
    ASSERT_EQ(test::step_checked(sim, 250, 5), "") << "in the 0.1 s from " << 0.1 * k << " s";
    for (size_t i = 0; i < start.size(); ++i) carried_back = std::max(carried_back, start[i].z - sim.positions()[i].z);
  }
  EXPECT_GT(sim.totals().pushed, 1000u) << "the arm never touched the cloth";
  EXPECT_GT(carried_back, 0.2f) << "the arm did not carry the cloth back";
}

}  // namespace
}  // namespace raycloth
