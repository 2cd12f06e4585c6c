// The swept bound (sim/swept_bound.h), on its own: two crumpled sheets a few millimetres apart, the
// upper one driven down into the lower by their gap in one step. What it leaves is
// checked from outside: the exact check (CGAL's predicates) finds no edge through a triangle at the
// end, and CGAL's distances along the whole way (every feature pair sharing no vertex, at 65 points
// of the step) never come below the pair's floor, less float rounding. The same moves without it put
// edges through triangles, and a sheet that only slides along itself keeps its whole move.
#include <gtest/gtest.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "check/exact_check.h"
#include "collide/bvh.h"
#include "fixtures.h"
#include "sim/model.h"
#include "sim/model_check.h"
#include "sim/step.h"

using namespace raycloth;

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
K::Point_3 pt(DVec3 v) { return K::Point_3(v.x, v.y, v.z); }

using test::SerialExec;

// Two 12 x 12 sheets of 0.2 m, the upper `lift` to twice that above the lower, turned about the
// vertical and tilted by up to 2 degrees, both crumpled by up to 1 mm: they do not meet.
ClothModel two_sheets(std::mt19937& rng, float lift) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  SceneDef s = test::panel_scene(12, 0.2f, 0.0f);
  PanelDef upper = s.panels[0];
  upper.name = "upper";
  upper.transform.position = {0.03f * u(rng), lift + 0.5f * lift * (u(rng) + 1.0f), 0.03f * u(rng)};
  upper.transform.rotation = {2.0f * u(rng), 45.0f * u(rng), 2.0f * u(rng)};
  s.panels.push_back(upper);
  ClothModel m = build_cloth_model(s);
  for (Vec3& p : m.initial_positions) p += make_vec3(u(rng), u(rng), u(rng)) * 0.001f;
  return m;
}

struct Swept {
  std::vector<Vec3> x_next;
  StepCounters counters;
};

// The swept bound over one step from x toward x_next, every vertex's pairs checked (no balls).
Swept run_swept(const ClothModel& m, const std::vector<Vec3>& x, const std::vector<Vec3>& x_next, float thickness) {
  const uint32_t n = m.num_vertices();
  HostBvh bvh;
  build_bvh(bvh, x.data(), m.collision_triangles.data(), m.num_triangles());
  Swept out{x_next, StepCounters()};
  std::vector<Vec3> v_next(n, Vec3{});
  std::vector<uint32_t> flags(n, kFlagSweptOut), share(n, 0x3F800000u);
  StepView s;
  s.model = m.view();
  s.x = x.data(), s.x_next = out.x_next.data(), s.v_next = v_next.data();
  s.flags = flags.data(), s.swept_share = share.data(), s.counters = &out.counters;
  s.cloth_bvh = bvh.view();
  s.coll.thickness = thickness;
  SerialExec ex;
  run_swept_bound(ex, s);
  return out;
}

size_t crossings(const ClothModel& m, const std::vector<Vec3>& x) {
  return check_state(cloth_check_mesh(m, x), CheckMesh{}).crossings;
}

// The nearest any pair of features sharing no vertex comes to its floor over the way from x to
// x_next (65 points), as a share: the smallest distance / floor (below 1: a pair passed its floor).
double least_over_floor(const ClothModel& m, const std::vector<Vec3>& x, const std::vector<Vec3>& x_next, float thickness) {
  const uint32_t* tri = m.collision_triangles.data();
  const size_t nt = m.num_triangles();
  auto at = [&](uint32_t i, double u) { return dvec(x[i]) + (dvec(x_next[i]) - dvec(x[i])) * u; };
  auto floor_of = [&](double d0) {
    return d0 < kSweptTiny ? d0 : std::min(kSweptFloorOfGap * d0, double(kSweptFloorShare) * double(thickness));
  };
  double least = INFINITY;
  // A pair whose boxes over the step (x and x_next of its vertices) stay farther apart than the
  // largest floor cannot come within it: skipped.
  const double reach = double(kSweptFloorShare) * double(thickness);
  auto apart = [&](const uint32_t* w, int na) {
    for (int axis = 0; axis < 3; ++axis) {
      double alo = INFINITY, ahi = -INFINITY, blo = INFINITY, bhi = -INFINITY;
      for (int j = 0; j < 4; ++j)
        for (const Vec3* p : {&x[w[j]], &x_next[w[j]]}) {
          const double c = axis == 0 ? p->x : (axis == 1 ? p->y : p->z);
          if (j < na) alo = std::min(alo, c), ahi = std::max(ahi, c);
          else blo = std::min(blo, c), bhi = std::max(bhi, c);
        }
      if (alo > bhi + reach || blo > ahi + reach) return true;
    }
    return false;
  };
  auto pair = [&](const uint32_t* w, int na) {
    if (apart(w, na)) return;
    double d0 = 0.0, lo = INFINITY;
    for (int k = 0; k <= 64; ++k) {
      const double u = k / 64.0;
      double d2;
      if (na == 1) {
        d2 = CGAL::to_double(CGAL::squared_distance(pt(at(w[0], u)), K::Triangle_3(pt(at(w[1], u)), pt(at(w[2], u)), pt(at(w[3], u)))));
      } else {
        d2 = CGAL::to_double(CGAL::squared_distance(K::Segment_3(pt(at(w[0], u)), pt(at(w[1], u))),
                                                    K::Segment_3(pt(at(w[2], u)), pt(at(w[3], u)))));
      }
      if (k == 0) d0 = std::sqrt(d2);
      lo = std::min(lo, std::sqrt(d2));
    }
    // Float rounding of the stopped positions: 0.2 um.
    least = std::min(least, (lo + 2e-7) / floor_of(d0));
  };
  auto shares = [](const uint32_t* a, int na, const uint32_t* b, int nb) {
    for (int i = 0; i < na; ++i)
      for (int j = 0; j < nb; ++j)
        if (a[i] == b[j]) return true;
    return false;
  };
  for (size_t t = 0; t < nt; ++t) {
    for (size_t u = t + 1; u < nt; ++u) {
      const uint32_t* v = tri + 3 * t;
      const uint32_t* w = tri + 3 * u;
      for (int k = 0; k < 3; ++k) {
        if (!shares(&v[k], 1, w, 3)) {
          const uint32_t f[4] = {v[k], w[0], w[1], w[2]};
          pair(f, 1);
        }
        if (!shares(&w[k], 1, v, 3)) {
          const uint32_t f[4] = {w[k], v[0], v[1], v[2]};
          pair(f, 1);
        }
        for (int l = 0; l < 3; ++l) {
          const uint32_t f[4] = {v[k], v[(k + 1) % 3], w[l], w[(l + 1) % 3]};
          if (!shares(f, 2, f + 2, 2)) pair(f, 2);
        }
      }
    }
  }
  return least;
}

}  // namespace

// The upper sheet driven down by the sheets' mean gap (8 to 16 mm) into the lower one, every vertex
// jittered by up to 2 mm: without the swept bound its edges end through the lower sheet; with it, no
// pair of features comes nearer than its floor anywhere along the step and the exact check finds no
// crossing.
TEST(SweptBound, SheetDrivenThroughASheetNeverPassesItsFloor) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const float thickness = 0.002f;
  int crossed_without = 0;
  for (int trial = 0; trial < 3; ++trial) {
    const ClothModel m = two_sheets(rng, 0.008f);
    const uint32_t n = m.num_vertices(), half = n / 2;
    const std::vector<Vec3>& x = m.initial_positions;
    ASSERT_EQ(crossings(m, x), 0u);
    // Down by the sheets' mean gap: the upper one ends halfway through the lower one.
    float drive = 0.0f;
    for (uint32_t i = 0; i < n; ++i) drive += (i >= half ? x[i].y : -x[i].y) / float(half);
    std::vector<Vec3> goal(n);
    for (uint32_t i = 0; i < n; ++i)
      goal[i] = x[i] + make_vec3(u(rng), u(rng), u(rng)) * 0.002f + (i >= half ? make_vec3(0, -drive, 0) : Vec3{});
    if (crossings(m, goal) > 0) ++crossed_without;
    const Swept r = run_swept(m, x, goal, thickness);
    EXPECT_EQ(r.counters.swept_stops, 0u) << "trial " << trial;
    EXPECT_GT(r.counters.clamped, 0u) << "trial " << trial;
    EXPECT_EQ(crossings(m, r.x_next), 0u) << "trial " << trial;
    EXPECT_GE(least_over_floor(m, x, r.x_next, thickness), 1.0) << "trial " << trial;
  }
  EXPECT_EQ(crossed_without, 3);
}

// Both sheets carried 30 mm sideways together (far beyond their balls: 0.4 of a gap of a few
// millimetres) with up to 0.1 mm of their own: no pair closes to its floor, and every vertex keeps
// its whole move, where the balls would have held every vertex to a fraction of it.
TEST(SweptBound, SheetsMovingTogetherKeepTheirWholeMoves) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 2; ++trial) {
    const ClothModel m = two_sheets(rng, 0.008f);
    const uint32_t n = m.num_vertices();
    const std::vector<Vec3>& x = m.initial_positions;
    ASSERT_EQ(crossings(m, x), 0u);
    std::vector<Vec3> goal(n);
    for (uint32_t i = 0; i < n; ++i) goal[i] = x[i] + make_vec3(0.03f, 0, 0.01f) + make_vec3(u(rng), u(rng), u(rng)) * 0.0001f;
    const Swept r = run_swept(m, x, goal, 0.002f);
    EXPECT_EQ(r.counters.clamped, 0u) << "trial " << trial;
    for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(length(r.x_next[i] - goal[i]), 0.0f) << "trial " << trial << ", vertex " << i;
  }
}
