// The generalized winding number over a tree (check/winding.h): the same number as the sum
// triangle by triangle, to rounding, on the walking man's open body in a walking pose, at points
// everywhere around him and a millimetre either side of his skin, for a fraction of the solid angles.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "check/winding.h"
#include "raycloth/simulator.h"
#include "sim/model.h"

using namespace raycloth;

namespace {

ObstacleSet walking_man() {
  SceneDef s;
  ObstacleDef man;
  man.name = "man";
  man.type = ObstacleType::Skinned;
  man.file = std::string(RAYCLOTH_SOURCE_DIR) + "/assets/walking_man.glb";
  man.animation = "walk";
  s.obstacles.push_back(man);
  return build_obstacles(s);
}

}  // namespace

TEST(Winding, TreeGivesTheTriangleSumOnTheOpenWalkingManForAFractionOfTheWork) {
  const ObstacleSet set = walking_man();
  std::vector<Vec3> x, v;
  set.pose_at(0.7, x, v);
  const std::vector<uint32_t>& tris = set.world.indices;
  const uint32_t n = uint32_t(tris.size() / 3);
  const WindingTree tree(x, tris, 0, n);
  // Points: uniform in a box around him, and each 50th vertex moved 1 mm out and 1 mm in along its
  // faces' mean normal.
  std::vector<WPoint> points;
  Vec3 lo = x[0], hi = x[0];
  for (const Vec3& p : x) lo = vmin(lo, p), hi = vmax(hi, p);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.1, 1.1);
  for (int k = 0; k < 2000; ++k)
    points.push_back({lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y), lo.z + u(rng) * (hi.z - lo.z)});
  std::vector<Vec3> normal(x.size(), make_vec3(0, 0, 0));
  for (uint32_t t = 0; t < n; ++t) {
    const Vec3 a = x[tris[3 * t]], b = x[tris[3 * t + 1]], c = x[tris[3 * t + 2]];
    const Vec3 f = cross(b - a, c - a);
    for (int k = 0; k < 3; ++k) normal[tris[3 * t + k]] += f;
  }
  size_t near = 0;
  for (size_t i = 0; i < x.size(); i += 50) {
    if (!(length(normal[i]) > 0)) continue;
    const Vec3 m = normal[i] / length(normal[i]);
    for (float side : {1e-3f, -1e-3f}) {
      const Vec3 p = x[i] + m * side;
      points.push_back({p.x, p.y, p.z});
      ++near;
    }
  }
  ASSERT_GT(near, 100u);
  size_t direct_terms = 0, tree_terms = 0, inside = 0, outside = 0;
  for (const WPoint& p : points) {
    const double want = winding_number_direct(x, tris, 0, n, p), got = tree(p);
    ASSERT_NEAR(got, want, 1e-9) << "at " << p[0] << " " << p[1] << " " << p[2];
    ASSERT_EQ(std::abs(got) >= 0.5, std::abs(want) >= 0.5);
    (std::abs(want) >= 0.5 ? inside : outside) += 1;
    direct_terms += n;
    tree_terms += tree.terms(p);
  }
  // Both sides are met: the points inside him (half of those 1 mm in, some of the box) and outside.
  EXPECT_GT(inside, near / 4);
  EXPECT_GT(outside, points.size() / 2);
  // The work (docs/collision.md quotes the share): a tenth of the solid angles at most.
  std::printf("the tree summed %zu of the %zu solid angles the triangle sums took (%.1f %%)\n", tree_terms, direct_terms,
              100.0 * double(tree_terms) / double(direct_terms));
  EXPECT_LT(tree_terms * 10, direct_terms) << tree_terms << " of " << direct_terms;
}

TEST(Winding, AnOpenHemisphereHasTheSameNumberEitherWay) {
  // A triangulated half sphere (open along its rim), points on a grid through it: where the tree
  // closes a far node over its boundary the number is the same, rim and all.
  std::vector<Vec3> x;
  std::vector<uint32_t> tris;
  const int rings = 12, segments = 24;
  x.push_back(make_vec3(0, 1, 0));
  for (int r = 1; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const float th = 0.5f * float(M_PI) * float(r) / float(rings), ph = 2.0f * float(M_PI) * float(s) / float(segments);
      x.push_back(make_vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)));
    }
  auto at = [&](int r, int s) { return r == 0 ? 0u : uint32_t(1 + (r - 1) * segments + (s % segments)); };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      if (r == 0) {
        tris.insert(tris.end(), {at(0, 0), at(1, s + 1), at(1, s)});
      } else {
        tris.insert(tris.end(), {at(r, s), at(r, s + 1), at(r + 1, s + 1)});
        tris.insert(tris.end(), {at(r, s), at(r + 1, s + 1), at(r + 1, s)});
      }
    }
  const uint32_t n = uint32_t(tris.size() / 3);
  const WindingTree tree(x, tris, 0, n);
  double most = 0;
  for (int i = -6; i <= 6; ++i)
    for (int j = -6; j <= 6; ++j)
      for (int k = -6; k <= 6; ++k) {
        const WPoint p{0.3 * i + 0.01, 0.3 * j + 0.013, 0.3 * k + 0.007};
        const double want = winding_number_direct(x, tris, 0, n, p);
        ASSERT_NEAR(tree(p), want, 1e-9);
        most = std::max(most, std::abs(want));
      }
  EXPECT_GT(most, 0.5);  // the inside is reached (the sphere's faces turn outward)
  EXPECT_LT(tree.terms({5, 5, 5}), size_t(n));  // far away: the rim alone
}
