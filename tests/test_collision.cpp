// Geometric outcomes of the ray-traced collision handling: no vertex inside an obstacle, no cloth
// crossing cloth, no tunnelling, resting and sliding contact, two-sided cloth, own triangles.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "collide/bvh.h"
#include "collide/cpu/embree_collider.h"
#include "fixtures.h"
#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "sim/model.h"
#include "sim/stages.h"

using namespace raycloth;

using test::exact_check;
using test::step_checked;

TEST(Collision, ClothDroppedOnSphereEndsWithNoVertexInside) {
  SceneDef s = test::panel_scene(21, 0.6f, 0.56f, 1.0f);
  s.obstacles.push_back(test::sphere_obstacle(0.5f, {0, 0, 0}));
  Simulator sim(s);
  ASSERT_EQ(step_checked(sim, 2500), "");
  EXPECT_GT(sim.last_hits(), 0u);
  // It rests on the sphere: the centre vertex is just above the pole.
  const Vec3 centre = sim.positions()[10 * 21 + 10];
  EXPECT_NEAR(centre.y, 0.5f + s.collision.thickness, 2e-3f);
}

TEST(Collision, ClothDroppedOnClothLyingOnBoxStaysOnTop) {
  SceneDef s = test::panel_scene(15, 0.42f, 0.402f, 1.0f);  // lower cloth, resting on the box top
  PanelDef upper = s.panels[0];
  upper.name = "upper";
  upper.width = upper.height = 0.3f;
  upper.resolution_u = upper.resolution_v = 11;
  upper.transform.position = {0.02f, 0.45f, 0.01f};
  upper.transform.rotation = {0, 30, 0};
  s.panels.push_back(upper);
  s.obstacles.push_back(test::box_obstacle({0.6f, 0.4f, 0.6f}, {0, 0.2f, 0}));
  Simulator sim(s);
  const Piece& up = sim.model().pieces[1];
  ASSERT_EQ(step_checked(sim, 2000), "");
  // Every upper vertex over the lower cloth lies above it (the lower cloth lies on the box top at
  // y ~ 0.402); upper corners that reach past it may lie on the box itself.
  size_t over = 0;
  for (uint32_t i = up.first_vertex; i < up.first_vertex + up.num_vertices(); ++i) {
    const Vec3 p = sim.positions()[i];
    if (std::abs(p.x) > 0.19f || std::abs(p.z) > 0.19f) continue;
    ++over;
    EXPECT_GT(p.y, 0.402f + 0.5f * s.collision.thickness) << "vertex " << i;
  }
  EXPECT_GT(over, 100u);
}

// A cloth falling onto the top edge of a pinned cloth wall seen edge-on: few of its vertex rays can
// hit a surface of zero width, so only the crossing guard's edge rays stop its edges from being
// cut through by the wall's top edge. The guard must act, and no edge may end up crossing.
TEST(Collision, ClothFallingOnAnEdgeOnClothWallIsNotCutThrough) {
  SceneDef s = test::panel_scene(21, 0.6f, 0.42f, 1.0f);
  s.panels[0].transform.position = {0.0f, 0.42f, 0.0137f};  // no vertex row in the wall's plane
  PanelDef wall = s.panels[0];
  wall.name = "wall";
  wall.width = 0.8f;
  wall.height = 0.3f;
  wall.resolution_u = 17;
  wall.resolution_v = 7;
  wall.transform.position = {0, 0.25f, 0};
  wall.transform.rotation = {90, 0, 0};  // vertical, in the xy-plane, top edge at y = 0.4
  s.panels.push_back(wall);
  PinDef pin;
  pin.panel = "wall";
  pin.range = std::array<int, 2>{0, 17 * 7 - 1};
  s.pins.push_back(pin);
  Simulator sim(s);
  ASSERT_EQ(step_checked(sim, 750), "");
  // The cloth hangs over the wall's top edge instead of falling past it.
  const Vec3 centre = sim.positions()[10 * 21 + 10];
  EXPECT_GT(centre.y, 0.4f - 0.02f);
}

TEST(Collision, FastVertexDoesNotTunnelThroughThinPlane) {
  SceneDef s = test::panel_scene(3, 0.02f, 1.0f);
  s.gravity = {0, -4000.0f, 0};  // ~280 m/s at the plane: 0.11 m per step, 22x the tolerance
  s.obstacles.push_back(test::plane_obstacle(2.0f, {0, 0, 0}));
  // 9 vertices of 9 mg on 2 cm of cloth: dt is past the mesh's stability limit (0.19 ms); the test
  // is about tunnelling, not about accuracy, so that is allowed.
  SimOptions allow;
  allow.allow_unstable_dt = true;
  Simulator sim(s, allow);
  // The displacement bound lets a vertex move at most 0.4 of its distance to the nearest cloth
  // feature it is not joined to (1 cm here) per step, so it takes longer than 0.11 m per step.
  for (int k = 0; k < 600; ++k) {
    sim.step(1);
    for (const Vec3& p : sim.positions()) ASSERT_GE(p.y, 0.0f) << "tunnelled at step " << sim.steps();
  }
  EXPECT_LT(sim.positions()[0].y, 0.01f);  // it did reach the plane
}

TEST(Collision, ClothRestingOnPlaneStaysOnItForManySteps) {
  SceneDef s = test::panel_scene(11, 0.3f, 0.002f, 0.5f);
  s.obstacles.push_back(test::plane_obstacle(2.0f, {0, 0, 0}));
  Simulator sim(s);
  for (int k = 0; k < 50; ++k) {
    sim.step(100);
    for (const Vec3& p : sim.positions()) {
      ASSERT_GE(p.y, 0.5f * s.collision.thickness) << "step " << sim.steps();
      ASSERT_LE(p.y, 0.01f) << "step " << sim.steps();
    }
  }
}

TEST(Collision, SlidingContactOnTiltedPlaneHolds) {
  // No friction on a 25 degree slope: the cloth slides along the plane, its velocity parallel to
  // it, and must neither sink in nor lift off.
  SceneDef s = test::panel_scene(9, 0.2f, 0.0f, 0.0f);
  const float tilt = 25.0f;
  s.panels[0].transform.rotation = {0, 0, tilt};
  s.panels[0].transform.position = {0, 0.003f, 0};
  s.collision.friction = 0.0f;
  ObstacleDef plane = test::plane_obstacle(6.0f, {0, 0, 0});
  plane.transform.rotation = {0, 0, tilt};
  s.obstacles.push_back(plane);
  Simulator sim(s);
  const Vec3 n = make_vec3(-std::sin(tilt * float(M_PI) / 180), std::cos(tilt * float(M_PI) / 180), 0);
  for (int k = 0; k < 40; ++k) {
    sim.step(50);
    for (const Vec3& p : sim.positions()) {
      const float d = dot(p, n);
      ASSERT_GE(d, 0.5f * s.collision.thickness) << "sank in at step " << sim.steps();
      ASSERT_LE(d, 0.01f) << "lifted off at step " << sim.steps();
    }
  }
  EXPECT_LT(sim.positions()[0].x, -0.1f);  // it slid down the slope
}

// This scene used to start the cloth inside the box and watch it fall onto the inside of the bottom
// face and be pushed out through it. A start with cloth inside an obstacle is refused now
// (refuse_inside_start, tests/test_pinch.cpp): cloth gets inside only when a body moves into it
// (ClothUnderAnOuterLayerLeavesThroughItNotThroughTheNearerInnerOne, SphereMovingThroughCurtainPushesIt).
TEST(Collision, ClothStartingInsideAClosedObstacleIsRefused) {
  SceneDef s = test::panel_scene(7, 0.1f, 0.3f, 1.0f);
  s.obstacles.push_back(test::box_obstacle({0.4f, 0.4f, 0.4f}, {0, 0.2f, 0}));
  try {
    Simulator sim(s);
    FAIL() << "a start with all 49 vertices inside the box was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "/panels/0");
    EXPECT_EQ(e.reason().rfind("panel 'cloth' starts with 49 vertices inside obstacle 'box'", 0), 0u) << e.what();
  }
}

TEST(Collision, ClothIsTwoSided) {
  // A cloth rising (gravity reversed) into a pinned cloth from below stays below it.
  SceneDef s = test::panel_scene(15, 0.42f, 0.5f, 1.0f);
  PinDef pin;
  pin.panel = "cloth";
  pin.range = std::array<int, 2>{0, 15 * 15 - 1};
  s.pins.push_back(pin);
  PanelDef riser = s.panels[0];
  riser.name = "riser";
  riser.width = riser.height = 0.2f;
  riser.resolution_u = riser.resolution_v = 8;
  riser.transform.position = {0.01f, 0.4f, 0.02f};
  riser.transform.rotation = {0, 20, 0};
  s.panels.push_back(riser);
  s.gravity = {0, 9.81f, 0};
  Simulator sim(s);
  const Piece& r = sim.model().pieces[1];
  ASSERT_EQ(step_checked(sim, 2000), "");
  for (uint32_t i = r.first_vertex; i < r.first_vertex + r.num_vertices(); ++i)
    EXPECT_LT(sim.positions()[i].y, 0.5f - 0.5f * s.collision.thickness);
  EXPECT_GT(sim.positions()[r.first_vertex].y, 0.49f);  // it did reach the pinned cloth
}

TEST(Collision, RaysNeverHitTheirOwnVertexTriangles) {
  SceneDef s = test::panel_scene(6, 0.15f, 0.0f);
  s.seams.clear();
  const ClothModel m = build_cloth_model(s);
  auto collider = make_embree_collider();
  collider->set_obstacles(nullptr, 0, nullptr, 0, false);
  collider->set_cloth(m.num_vertices(), m.collision_triangles.data(), m.tri_alias.data(), m.num_collision_triangles(), true);
  collider->update_cloth(m.initial_positions.data());
  // Rays from 1 mm above each vertex, down through the vertex's own triangles.
  std::vector<Ray> rays;
  for (uint32_t i = 0; i < m.num_vertices(); ++i)
    for (Vec3 d : {make_vec3(0, -1, 0), normalize_or_zero(make_vec3(0.3f, -1, 0.2f))}) {
      Ray r;
      r.org = m.initial_positions[i] + make_vec3(0, 0.001f, 0);
      r.dir = d;
      r.tmax = 0.01f;
      r.vertex = m.alias[i];
      rays.push_back(r);
    }
  std::vector<RawHit> hits(rays.size());
  collider->cast(rays.data(), rays.size(), hits.data());
  for (size_t k = 0; k < hits.size(); ++k) EXPECT_EQ(hits[k].kind, kHitNone) << "ray " << k;
  // The same rays cast for another vertex do hit the cloth.
  for (auto& r : rays) r.vertex = 0xFFFFFFFFu;
  collider->cast(rays.data(), rays.size(), hits.data());
  size_t interior = 0, hit = 0;
  for (size_t k = 0; k < hits.size(); ++k) {
    const uint32_t i = uint32_t(k / 2), u = i % 6, v = i / 6;
    if (u == 0 || v == 0 || u == 5 || v == 5) continue;  // rays from the rim may leave the cloth
    ++interior;
    hit += hits[k].kind == kHitCloth;
  }
  EXPECT_EQ(hit, interior);
}

namespace {
SceneDef hanging_panel(Float3 rotation) {
  SceneDef s = test::panel_scene(41, 1.0f, 1.5f, 1.0f);
  s.panels[0].transform.rotation = rotation;
  s.pins.push_back({.panel = "cloth", .corner = "top_left"});
  s.collision.cloth_cloth = true;
  return s;
}
}  // namespace

// A panel that starts upright or tilted hangs from its corner and swings: nothing holds it back
// (before the displacement bound, edge rays grazing its own triangles froze every vertex).
TEST(Collision, UprightAndTiltedPanelsHangAndSwing) {
  for (Float3 rotation : {Float3{-90, 0, 0}, Float3{-30, 20, 0}}) {
    Simulator sim(hanging_panel(rotation));
    const Vec3 corner = sim.positions()[sim.model().num_vertices() - 1];
    ASSERT_EQ(step_checked(sim, 500, 10), "");
    double ke = 0;
    for (uint32_t i = 0; i < sim.model().num_vertices(); ++i)
      ke += 0.5 * sim.model().mass[i] * length_sq(sim.velocities()[i]);
    EXPECT_GT(ke, 0.01) << "rotation " << rotation[0] << ", " << rotation[1];
    EXPECT_GT(length(sim.positions()[sim.model().num_vertices() - 1] - corner), 0.05f);
    EXPECT_EQ(sim.totals().clamped, 0u) << "a lone panel has nothing near enough to bound its moves";
  }
}

// A sphere moving through a curtain pinned along its top pushes it: no cloth vertex ever inside.
TEST(Collision, SphereMovingThroughCurtainPushesIt) {
  for (float speed : {2.0f, 5.0f}) {
    SceneDef s = test::panel_scene(34, 1.0f, 1.0f, 1.0f);
    s.panels[0].transform.rotation = {-90, 0, 0};
    s.pins.push_back({.panel = "cloth", .edge = "top"});
    s.collision.cloth_cloth = true;
    ObstacleDef ball = test::sphere_obstacle(0.2f, {0, 0.9f, -0.5f});
    ball.motion = MotionDef{.velocity = {0, 0, speed}};
    s.obstacles.push_back(ball);
    Simulator sim(s);
    const int steps = int(1.0f / speed / 0.0004f);
    ASSERT_EQ(step_checked(sim, steps), "") << "speed " << speed;
    EXPECT_GT(sim.totals().pushed, 100u) << "the sphere never reached the curtain";
  }
}

// A body of two layers 3 mm apart (clothes over skin), both rising 5 mm in one step under a cloth
// lying 3 mm above the outer one: after the step the cloth is 2 mm inside the outer layer and 1 mm
// outside the inner one, which is the nearer surface. It must leave through the outer layer, not
// settle at the thickness outside the inner one (still inside the outer).
TEST(Collision, ClothUnderAnOuterLayerLeavesThroughItNotThroughTheNearerInnerOne) {
  SceneDef s = test::panel_scene(5, 0.1f, 0.403f);
  s.gravity = {0, 0, 0};
  s.time.dt = 4e-4;
  ObstacleDef outer = test::box_obstacle({0.4f, 0.4f, 0.4f}, {0, 0.2f, 0});
  ObstacleDef inner = test::box_obstacle({0.394f, 0.394f, 0.394f}, {0, 0.2f, 0});
  outer.name = "outer", inner.name = "inner";
  outer.motion = inner.motion = MotionDef{.velocity = {0, 12.5f, 0}};
  s.obstacles = {outer, inner};
  Simulator sim(s);
  ASSERT_EQ(test::exact_check(sim).vertices_inside, 0u);
  sim.step(1);
  EXPECT_EQ(test::exact_check(sim).vertices_inside, 0u);
  for (const Vec3& p : sim.positions()) EXPECT_GE(p.y, 0.405f + 0.5f * s.collision.thickness);
}

namespace {

// The obstacle stage on its own (stage_body_moved, stage_obstacles) over cloth points that stand still
// where it leaves them, with its own copy of what it writes; `fresh` forgets the body clearances
// first, so every point queries the bodies' tree.
struct ObstacleStage {
  std::vector<Vec3> x, x_next, v_next, contact_normal, clear_at;
  std::vector<uint32_t> flags;
  std::vector<float> clearance, clear;
  std::vector<double> since;
  std::vector<Contact> contacts;
  double moved = 0.0;
  uint32_t skipped = 0;  // queries the clearances skipped in the last step

  explicit ObstacleStage(const std::vector<Vec3>& start)
      : x(start), x_next(start), v_next(start.size()), contact_normal(start.size()), clear_at(start.size()),
        flags(start.size()), clearance(start.size()), clear(start.size(), 0.0f), since(start.size(), 0.0) {}

  void run(StepView v, bool fresh) {
    const uint32_t n = uint32_t(x.size());
    if (fresh) std::fill(clear.begin(), clear.end(), 0.0f);
    x = x_next;  // the points stand still: the step proposes where the last one left them
    std::fill(v_next.begin(), v_next.end(), make_vec3(0, 0, 0));
    std::fill(flags.begin(), flags.end(), 0u);
    contacts.assign(n, Contact());
    v.x = x.data(), v.x_next = x_next.data(), v.v_next = v_next.data(), v.flags = flags.data();
    v.clearance = clearance.data(), v.contacts = contacts.data(), v.contact_normal = contact_normal.data();
    v.body_clear = clear.data(), v.body_clear_at = clear_at.data(), v.body_clear_since = since.data();
    v.body_moved = &moved;
    stage_body_moved(v);
    skipped = 0;
    for (uint32_t i = 0; i < n; ++i) {
      skipped += body_clear_of(v, i, x_next[i], v.coll.thickness + obstacle_reach(v)) ? 1u : 0u;
      stage_obstacles(v, i);
    }
  }
};

}  // namespace

// The obstacle stage's body clearances skip only queries that would find nothing. A sphere of
// 0.1 m flies at 3 mm a step through a sheet of still points (it pushes those it meets out of its
// way); on every step, every point's position, velocity, flags and clearance are those of a stage
// that queries every point, and over a third of the queries are skipped. Without the bodies' move
// since a clearance was measured (a still point keeps its clearance while the sphere comes at it),
// the points ahead of the sphere are not pushed: it fails at step 1.
TEST(Collision, ObstacleQueriesSkippedByClearancesGiveWhatEveryQueryGives) {
  SceneDef s = test::panel_scene(15, 0.4f, 0.0f);
  s.obstacles.push_back(test::sphere_obstacle(0.1f, {0.01f, 0.0f, -0.15f}));
  const ClothModel m = build_cloth_model(s);
  const ObstacleSet o = build_obstacles(s);
  const uint32_t n = m.num_vertices();
  std::vector<Vec3> body = o.world.vertices, body_prev = body;
  std::vector<uint32_t> prims;
  HostBvh bvh;
  StepCounters counters;
  StepView v;
  v.model = m.view();
  v.coll.thickness = 0.003f;
  v.bodies_move = true;
  v.counters = &counters;
  v.geom.obstacle_indices = o.collision_indices.data();
  v.obstacle_prev = body_prev.data();
  ObstacleStage kept(m.initial_positions), fresh(m.initial_positions);
  uint32_t skipped = 0, pushed = 0;
  for (int step = 0; step < 100; ++step) {
    body_prev = body;
    for (Vec3& p : body) p.z += 0.003f;
    build_bvh(bvh, body.data(), o.collision_indices.data(), o.num_collision_triangles());
    v.obstacle_bvh = bvh.view();
    v.geom.obstacle_vertices = body.data();
    counters = StepCounters();
    for (uint32_t k = 0; k < uint32_t(body.size()); ++k) stage_obstacle_move(v, k);
    kept.run(v, false);
    fresh.run(v, true);
    skipped += kept.skipped;
    EXPECT_EQ(fresh.skipped, 0u);
    for (uint32_t i = 0; i < n; ++i) {
      ASSERT_EQ(kept.x_next[i].x, fresh.x_next[i].x) << "step " << step << ", point " << i;
      ASSERT_EQ(kept.x_next[i].y, fresh.x_next[i].y) << "step " << step << ", point " << i;
      ASSERT_EQ(kept.x_next[i].z, fresh.x_next[i].z) << "step " << step << ", point " << i;
      ASSERT_EQ(kept.v_next[i].z, fresh.v_next[i].z) << "step " << step << ", point " << i;
      ASSERT_EQ(kept.flags[i], fresh.flags[i]) << "step " << step << ", point " << i;
      ASSERT_EQ(kept.clearance[i], fresh.clearance[i]) << "step " << step << ", point " << i;
      pushed += (kept.flags[i] & kFlagPushed) ? 1u : 0u;
    }
  }
  EXPECT_GT(pushed, 100u);              // the sphere met the sheet
  EXPECT_GT(skipped, 100u * n / 3u);  // and a third of the queries were skipped (9,517 of 22,500)
}
