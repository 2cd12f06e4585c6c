// Pinches in the exact check (a cloth vertex inside the body where the body's own surfaces are
// closer than twice the cloth thickness: not clean, not a failure).
#include <gtest/gtest.h>

#include <cmath>

#include "check/state_check.h"
#include "fixtures.h"
#include "sim/model.h"

using namespace raycloth;

namespace {

constexpr double kThickness = 0.002;  // twice it: 4 mm

// Two boxes side by side along x, 0.2 m wide: "left" from x = -0.2 to 0, "right" from x = gap.
ObstacleSet two_boxes(float gap) {
  SceneDef s;
  ObstacleDef left = test::box_obstacle({0.2f, 0.2f, 0.2f}, {-0.1f, 0, 0});
  left.name = "left";
  ObstacleDef right = test::box_obstacle({0.2f, 0.2f, 0.2f}, {gap + 0.1f, 0, 0});
  right.name = "right";
  s.obstacles = {left, right};
  return build_obstacles(s);
}

// One cloth triangle whose first vertex is at p, the other two well above every box.
CheckMesh cloth_with_vertex_at(Vec3 p) {
  CheckMesh m;
  m.vertices = {p, make_vec3(p.x, 0.5f, 0), make_vec3(p.x, 0.5f, 0.1f)};
  m.triangles = {0, 1, 2};
  m.group_names = {"sheet"};
  m.group_first_triangle = {0};
  return m;
}

CheckReport check(const CheckMesh& cloth, const ObstacleSet& set) {
  return check_state(cloth, obstacle_check_mesh(set, set.world.vertices), kThickness);
}

}  // namespace

// A hand against a hip: the boxes are 2 mm apart, a cloth vertex 1 mm inside the left one next to
// the gap cannot be outside both at the thickness. Pinched, with the body's gap of 2 mm.
TEST(Pinch, VertexInsideWhereTheBodyLeavesLessThanTwiceTheThicknessIsPinched) {
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)), two_boxes(0.002f));
  EXPECT_EQ(r.vertices_inside, 0u);
  ASSERT_EQ(r.vertices_pinched, 1u);
  EXPECT_NEAR(r.min_pinch_gap, 0.002, 1e-6);
  ASSERT_EQ(r.first_pinched.size(), 1u);
  EXPECT_EQ(r.first_pinched[0].vertex, 0u);
  EXPECT_EQ(r.first_pinched[0].obstacle, "left");
  EXPECT_NEAR(r.first_pinched[0].gap, 0.002, 1e-6);
  EXPECT_FALSE(r.clean());
  EXPECT_FALSE(r.failed());
  EXPECT_TRUE(r.pinched_only());
  EXPECT_EQ(describe(r),
            "0 crossings, 0 vertices inside, 1 vertices pinched (body gap 2 mm); first pinched: vertex 0 inside 'left' "
            "(body gap 2 mm)");
  // Without the thickness (check_state's default) nothing is a pinch.
  const ObstacleSet set = two_boxes(0.002f);
  const CheckReport plain = check_state(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)),
                                        obstacle_check_mesh(set, set.world.vertices));
  EXPECT_EQ(plain.vertices_inside, 1u);
  EXPECT_EQ(plain.vertices_pinched, 0u);
}

// Touching bodies (gap 0) pinch too: the ray starts a hair behind the surface.
TEST(Pinch, TouchingBodiesPinchWithGapZero) {
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)), two_boxes(0.0f));
  EXPECT_EQ(r.vertices_inside, 0u);
  ASSERT_EQ(r.vertices_pinched, 1u);
  EXPECT_NEAR(r.min_pinch_gap, 0.0, 1e-6);
}

// The same vertex with the boxes 10 cm apart: the body leaves room, so it is a failure.
TEST(Pinch, VertexInsideWhereTheBodyLeavesRoomIsAFailure) {
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)), two_boxes(0.1f));
  EXPECT_EQ(r.vertices_pinched, 0u);
  ASSERT_EQ(r.vertices_inside, 1u);
  EXPECT_NEAR(r.first_inside[0].gap, 0.1, 1e-6);
  EXPECT_TRUE(r.failed());
  EXPECT_FALSE(r.pinched_only());
  EXPECT_EQ(describe(r), "0 crossings, 1 vertices inside; first: vertex 0 inside 'left'");
}

// Clothes over skin: a box inside a box 2 mm larger on every side, both closed with outward normals.
// A vertex 1 mm under the inner surface: the ray from the inner surface leaves the outer layer from
// behind (2 mm away, less than twice the thickness), which is no pinch; both are failures.
TEST(Pinch, VertexUnderAnOuterLayerIsAFailureNotAPinch) {
  SceneDef s;
  ObstacleDef skin = test::box_obstacle({0.2f, 0.2f, 0.2f}, {0, 0, 0});
  skin.name = "skin";
  ObstacleDef coat = test::box_obstacle({0.204f, 0.204f, 0.204f}, {0, 0, 0});
  coat.name = "coat";
  s.obstacles = {skin, coat};
  const ObstacleSet set = build_obstacles(s);
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(0.099f, 0, 0)), set);
  EXPECT_EQ(r.closed_obstacles, 2u);
  EXPECT_EQ(r.vertices_pinched, 0u) << describe(r);
  ASSERT_EQ(r.vertices_inside, 2u);
  EXPECT_EQ(r.first_inside[0].obstacle, "skin");
  EXPECT_EQ(r.first_inside[1].obstacle, "coat");
  EXPECT_TRUE(std::isinf(r.first_inside[0].gap)) << r.first_inside[0].gap;
  EXPECT_TRUE(std::isinf(r.first_inside[1].gap)) << r.first_inside[1].gap;
}
