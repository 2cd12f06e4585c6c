// Where a body passes into itself (his upper arm into his torso at the armpit), a surface of one part
// lies inside another: the obstacle stage's push out of the nearest face can land inside the body,
// and the vertex goes to the nearest point in front of a face that is outside every part instead
// (sim/obstacle_query.h: inside_parts, overlap_exit). Checked exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fixtures.h"
#include "raycloth/simulator.h"

namespace raycloth {
namespace {

// Two boxes 4 cm deep and tall overlapping by 5 mm along x: A from x = 0 to 0.1, B from 0.095 to
// 0.195 (y and z from 0 to 0.04). A 10 cm cloth square of four vertices: vertex 0, free, at
// (0.0985, 0.02, 0.02), inside both; the other three pinned at the square's rest shape (place). A's face at x = 0.1, 1.5 mm
// away, is the nearest; the thickness (3 mm) in front of it is x = 0.103, inside B.
struct OverlapSetup {
  SceneDef scene;
  std::vector<Vec3> x;
};

// The square stood up in the plane x = x[0].x at its rest shape (no spring pulls): vertex 0 at x[0],
// 1 above it, 2 beside it (+z, clear of the boxes), 3 above 2; 1 to 3 pinned.
void place(OverlapSetup& o) {
  const Vec3 p = o.x[0];
  o.x = {p, p + make_vec3(0, 0.1f, 0), p + make_vec3(0, 0, 0.1f), p + make_vec3(0, 0.1f, 0.1f)};
}

OverlapSetup overlap_setup() {
  OverlapSetup o;
  o.scene = test::panel_scene(2, 0.1f, 0.5f);
  o.scene.collision.thickness = 0.003f;
  ObstacleDef a = test::box_obstacle({0.1f, 0.04f, 0.04f}, {0.05f, 0.02f, 0.02f});
  a.name = "a";
  ObstacleDef b = test::box_obstacle({0.1f, 0.04f, 0.04f}, {0.145f, 0.02f, 0.02f});
  b.name = "b";
  o.scene.obstacles = {a, b};
  o.x = {make_vec3(0.0985f, 0.02f, 0.02f)};
  place(o);
  return o;
}

bool inside_box(Vec3 p, float x0, float x1) {
  return p.x > x0 && p.x < x1 && p.y > 0.0f && p.y < 0.04f && p.z > 0.0f && p.z < 0.04f;
}

// Pushed the thickness out of A's face it would be inside B (5 mm of overlap); the nearest point
// outside both is the thickness above (or below, or beside) the boxes' shared 4 cm section, 2.3 cm
// away. After one step the vertex is outside both and the exact check is clean. Without the exit the
// vertex ends at x = 0.103, inside B, and the check finds it there.
TEST(Overlap, VertexPushedOutOfAFaceLyingInsideAnotherPartGoesOutOfBoth) {
  OverlapSetup o = overlap_setup();
  Simulator sim(o.scene);
  sim.set_state(o.x, std::vector<Vec3>(o.x.size(), make_vec3(0, 0, 0)));
  sim.pin({1, 2, 3});
  sim.step();
  const Vec3 p = sim.positions()[0];
  EXPECT_FALSE(inside_box(p, 0.0f, 0.1f)) << p.x << " " << p.y << " " << p.z;
  EXPECT_FALSE(inside_box(p, 0.095f, 0.195f)) << p.x << " " << p.y << " " << p.z;
  // The thickness off the nearest outside face, at the same x: 2.3 cm from where it was.
  EXPECT_NEAR(length(p - o.x[0]), 0.023, 2e-4);
  EXPECT_NEAR(p.x, 0.0985, 2e-4);
  const CheckReport r = test::exact_check(sim);
  EXPECT_TRUE(r.clean()) << describe(r);
  EXPECT_EQ(sim.totals().overlap_exits, 1u);
}

// Where the push out of the nearest face is already outside every part, nothing changes: a vertex
// 1.5 mm inside A's far face (x = 0, no other part there) goes to the thickness in front of it.
TEST(Overlap, PushOutsideEveryPartIsLeftAsItIs) {
  OverlapSetup o = overlap_setup();
  o.x[0] = make_vec3(0.0015f, 0.02f, 0.02f);
  place(o);
  Simulator sim(o.scene);
  sim.set_state(o.x, std::vector<Vec3>(o.x.size(), make_vec3(0, 0, 0)));
  sim.pin({1, 2, 3});
  sim.step();
  const Vec3 p = sim.positions()[0];
  EXPECT_NEAR(p.x, -0.003, 1e-5);
  EXPECT_NEAR(p.y, 0.02, 1e-4);
  EXPECT_NEAR(p.z, 0.02, 1e-5);
  EXPECT_EQ(sim.totals().overlap_exits, 0u);
}

// An open floor (a plane obstacle: one sheet, no inside) under a ball: cloth draped over the ball
// is pushed out of its lower half along directions that point down through the floor, where a ray
// crosses the floor alone (a winding of -1). The two other rays point up, so the pushes are outside by
// two of three and nothing takes a way out. With the third ray pointing down (the first version) 636
// pushes over 1.5 s went to the ball's side instead (397 in the first 0.8 s: this test fails so).
TEST(Overlap, ClothOverABallAboveAnOpenFloorTakesNoWayOut) {
  SceneDef s = test::panel_scene(31, 1.0f, 0.62f, 1.0f);
  s.time.duration = 0.8;
  s.obstacles = {test::sphere_obstacle(0.25f, {0, 0.35f, 0}), test::plane_obstacle(3.0f, {0, 0, 0})};
  Simulator sim(s);
  sim.step(2000);
  EXPECT_GT(sim.totals().pushed, 0u);
  EXPECT_EQ(sim.totals().overlap_exits, 0u);
  const CheckReport r = test::exact_check(sim);
  EXPECT_TRUE(r.clean()) << describe(r);
}

// A GarmentCodeData top (rand_1H61FM17LX, 648 cloth vertices) put on the walking man by the one-line
// garment of scenes/garment_on_man.json: going into the walk his upper arm passes into his torso, and
// from 1.33 s the push out of the nearest face (his sleeve's underside, inside his torso) left a
// vertex at his armpit inside him (10 of the first 49 frames, 1 to 4 vertices). Checked exactly at
// every frame's step through 1.6 s: clean.
TEST(Overlap, TopOnTheWalkingManStaysOutOfHimWhereHisArmPassesIntoHisTorso) {
  const std::string source = std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/garment_on_man.json";
  std::ifstream in(source);
  std::stringstream text;
  text << in.rdbuf();
  std::string json = text.str();
  const std::string from = "../assets/garmentcode/shirt_mean_specification.json";
  const size_t at = json.find(from);
  ASSERT_NE(at, std::string::npos);
  json.replace(at, from.size(), "../assets/garmentcodedata/rand_1H61FM17LX_specification.json");
  SceneDef s = parse_scene(json, source);
  Simulator sim(s);
  const int frames = 48, steps_per_frame = int(std::lround(1.0 / (s.time.fps * sim.scene().time.dt)));
  ASSERT_EQ(steps_per_frame, 133);
  EXPECT_EQ(test::step_checked(sim, frames * steps_per_frame, steps_per_frame), "");
  EXPECT_GT(sim.totals().overlap_exits, 0u);
}

}  // namespace
}  // namespace raycloth
