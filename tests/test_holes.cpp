// Openings of obstacle meshes closed for the step (collide/holes.h), and what that does: cloth kept
// out of an open body part that the face nearest to it does not show as inside.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "collide/holes.h"
#include "fixtures.h"
#include "raycloth/scene.h"
#include "sim/model.h"

namespace raycloth {
namespace {

constexpr float kPi = 3.14159265f;

// An open cylinder about the y axis from y0 to y1 (n segments), outward normals; `bottom` closes
// its lower end with a fan around a centre vertex.
void add_tube(std::vector<Vec3>& v, std::vector<uint32_t>& f, float r, float y0, float y1, int n, bool bottom,
              Vec3 at = make_vec3(0, 0, 0)) {
  const uint32_t base = uint32_t(v.size());
  for (int k = 0; k < n; ++k) {
    const float a = 2 * kPi * float(k) / float(n);
    v.push_back(at + make_vec3(r * std::cos(a), y0, r * std::sin(a)));
    v.push_back(at + make_vec3(r * std::cos(a), y1, r * std::sin(a)));
  }
  for (int k = 0; k < n; ++k) {
    const uint32_t a0 = base + 2 * k, a1 = a0 + 1, b0 = base + 2 * ((k + 1) % n), b1 = b0 + 1;
    f.insert(f.end(), {a0, a1, b1, a0, b1, b0});  // seen from outside: counter-clockwise
  }
  if (bottom) {
    const uint32_t c = uint32_t(v.size());
    v.push_back(at + make_vec3(0, y0, 0));
    for (int k = 0; k < n; ++k) f.insert(f.end(), {c, base + 2 * k, base + 2 * ((k + 1) % n)});
  }
}

// Every edge of the mesh plus caps used by exactly two triangles, once in each direction: closed
// and consistently oriented.
::testing::AssertionResult closed_and_oriented(const std::vector<uint32_t>& f) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < f.size() / 3; ++t)
    for (int k = 0; k < 3; ++k) ++directed[{f[3 * t + k], f[3 * t + (k + 1) % 3]}];
  for (const auto& [e, n] : directed) {
    if (n != 1) return ::testing::AssertionFailure() << "edge " << e.first << "-" << e.second << " used " << n << " times one way";
    if (!directed.count({e.second, e.first}))
      return ::testing::AssertionFailure() << "edge " << e.first << "-" << e.second << " is open";
  }
  return ::testing::AssertionSuccess();
}

double signed_volume(const std::vector<Vec3>& v, const std::vector<uint32_t>& f) {
  double vol = 0;
  for (size_t t = 0; t < f.size() / 3; ++t)
    vol += double(dot(v[f[3 * t]], cross(v[f[3 * t + 1]], v[f[3 * t + 2]]))) / 6.0;
  return vol;
}

// A sleeve (open tube, r 6 cm, 40 cm) with an arm (a closed tube, r 4 cm) through it: both of the
// sleeve's openings have the arm along their rims, so both are capped, and the caps close it with
// the mesh's orientation (its volume that of the cylinder, to the polygon's area).
TEST(Holes, SleeveOverAnArmIsClosedAtBothEnds) {
  std::vector<Vec3> v;
  std::vector<uint32_t> f;
  add_tube(v, f, 0.06f, 0.0f, 0.4f, 24, false);
  const size_t sleeve_triangles = f.size();
  add_tube(v, f, 0.04f, -0.1f, 0.5f, 24, true);
  const HoleCaps caps = cap_holes(v, f, kHoleMaxShare);
  EXPECT_EQ(caps.loops, 3u);   // the sleeve's two openings and the arm's top
  EXPECT_EQ(caps.capped, 2u);  // the arm's top is nowhere near another piece, and not tiny
  std::vector<uint32_t> sleeve(f.begin(), f.begin() + long(sleeve_triangles));
  sleeve.insert(sleeve.end(), caps.indices.begin(), caps.indices.end());
  ASSERT_EQ(caps.indices.size(), 2u * 3u * 22u);  // a 24-gon takes 22 triangles, no new vertices
  EXPECT_TRUE(closed_and_oriented(sleeve));
  const double polygon = 0.5 * 24 * 0.06 * 0.06 * std::sin(2 * kPi / 24);
  EXPECT_NEAR(signed_volume(v, sleeve), polygon * 0.4, 1e-6);
}

// A cup alone (open top, share 0.2) keeps its opening: nothing lies along its rim and the opening
// is not tiny against it. A sheet's edge spans all of it: never a hole.
TEST(Holes, OpenCupAndSheetKeepTheirOpenings) {
  std::vector<Vec3> v;
  std::vector<uint32_t> f;
  add_tube(v, f, 0.05f, 0.0f, 0.1f, 24, true);
  HoleCaps caps = cap_holes(v, f, kHoleMaxShare);
  EXPECT_EQ(caps.loops, 1u);
  EXPECT_EQ(caps.capped, 0u);
  EXPECT_TRUE(caps.indices.empty());
  const TriMesh plane = make_plane(make_vec3(1, 0, 1));
  caps = cap_holes(plane.vertices, plane.indices, kHoleMaxShare);
  EXPECT_EQ(caps.loops, 1u);
  EXPECT_EQ(caps.capped, 0u);
}

// A sphere with one small opening (a triangle taken out near a pole: far below 2 % of its area) is
// closed again whether or not anything lies along the rim.
TEST(Holes, TinyOpeningIsClosed) {
  TriMesh s = make_uv_sphere(0.5f, 24, 25);
  std::vector<uint32_t> f(s.indices.begin() + 3, s.indices.end());
  const HoleCaps caps = cap_holes(s.vertices, f, kHoleMaxShare);
  EXPECT_EQ(caps.loops, 1u);
  ASSERT_EQ(caps.capped, 1u);
  f.insert(f.end(), caps.indices.begin(), caps.indices.end());
  EXPECT_TRUE(closed_and_oriented(f));
}

// The obstacle set: caps go into the step's triangles after the mesh's own, only for mesh and
// skinned obstacles that allow it, and the outputs' triangles stay the mesh's.
TEST(Holes, ObstacleSetCapsTheWalkingManForTheStepAlone) {
  SceneDef s = load_scene_file(std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/walking_skirt.json");
  ObstacleSet set = build_obstacles(s);
  EXPECT_GT(set.holes_capped, 10u);
  EXPECT_GT(set.cap_triangles, 100u);
  EXPECT_EQ(set.num_collision_triangles(), set.world.num_triangles() + set.cap_triangles);
  EXPECT_TRUE(std::equal(set.world.indices.begin(), set.world.indices.end(), set.collision_indices.begin()));
  for (ObstacleDef& od : s.obstacles) od.close_holes = false;
  set = build_obstacles(s);
  EXPECT_EQ(set.cap_triangles, 0u);
  EXPECT_EQ(set.collision_indices, set.world.indices);
}

// A cotton cape attached to the walking man's upper back (tests/scenes/contact/cape_walk.json): his
// arm is a piece open at the shoulder, and the cape's side slipped into it through the opening next
// to his armpit, where the face nearest to the vertex was his torso's, facing it (inside him by the
// winding number, 0.54, on 3 frames). With the openings closed for the step: clean on every frame.
TEST(Holes, CapeDoesNotSlipIntoTheArmThroughItsOpening) {
  const SceneDef s = load_scene_file(std::string(RAYCLOTH_SOURCE_DIR) + "/tests/scenes/contact/cape_walk.json");
  Simulator sim(s);
  EXPECT_EQ(test::step_checked(sim, int(std::lround(1.5 / s.time.dt)), int(std::lround(1.0 / 30.0 / s.time.dt))), "");
}

}  // namespace
}  // namespace raycloth
