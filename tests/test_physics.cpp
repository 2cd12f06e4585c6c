// Analytic physics: free fall, the period of one spring, spring counts, energy, the stability limit.
#include <gtest/gtest.h>

#include <cmath>

#include "fixtures.h"
#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "sim/model.h"
#include "sim/integrate/explicit.h"

using namespace raycloth;

TEST(Physics, FreeFallMatchesAnalyticSolution) {
  SceneDef s = test::panel_scene(5, 0.12f, 10.0f);
  Simulator sim(s);
  const int n = 500;
  sim.step(n);
  const double dt = s.time.dt, g = 9.81, t = n * dt;
  // Eq. (3) is semi-implicit Euler: y_n = y0 - g dt^2 n (n + 1) / 2 exactly ...
  const double discrete = 10.0 - g * dt * dt * n * (n + 1) / 2.0;
  // ... which is the continuous y0 - g t^2 / 2 shifted by g dt t / 2.
  const double continuous = 10.0 - g * t * t / 2.0;
  for (const Vec3& p : sim.positions()) {
    EXPECT_NEAR(p.y, discrete, 2e-4);
    EXPECT_NEAR(p.y, continuous, g * dt * t / 2.0 + 2e-4);
  }
  for (const Vec3& v : sim.velocities()) EXPECT_NEAR(v.y, -g * t, 1e-3);
}

TEST(Physics, OneSpringOscillatesWithPeriodTwoPiSqrtMOverK) {
  ClothModel m;
  const float mass = 0.01f, k = 50.0f, rest = 0.1f;
  m.initial_positions = {make_vec3(0, 0, 0), make_vec3(0.12f, 0, 0)};
  m.mass = {mass, mass};
  m.inv_mass = {0.0f, 1.0f / mass};  // vertex 0 held
  m.damping = {0, 0};
  m.springs.push_back({0, 1, rest, k, 0.0f, SpringType::Stretch});
  build_adjacency(m);
  const ModelView view = m.view();
  std::vector<Vec3> x = m.initial_positions, v(2), xn(2), vn(2);
  const float dt = 1e-5f;
  std::vector<double> crossings;  // upward zero crossings of x - rest
  double prev = x[1].x - rest;
  for (int step = 1; step < 200000 && crossings.size() < 6; ++step) {
    for (uint32_t i = 0; i < 2; ++i) integrate_vertex(view, x.data(), v.data(), i, make_vec3(0, 0, 0), dt, vn[i], xn[i]);
    std::swap(x, xn);
    std::swap(v, vn);
    const double cur = x[1].x - rest;
    if (prev < 0 && cur >= 0) crossings.push_back(step * dt - dt * cur / (cur - prev));
    prev = cur;
  }
  ASSERT_GE(crossings.size(), 3u);
  const double period = (crossings.back() - crossings.front()) / double(crossings.size() - 1);
  EXPECT_NEAR(period, 2.0 * M_PI * std::sqrt(mass / k), 1e-3 * 2.0 * M_PI * std::sqrt(mass / k));
}

TEST(Physics, SpringCountsFollowThePapersDefinitions) {
  for (auto [l, n] : {std::pair{2, 2}, std::pair{5, 3}, std::pair{51, 26}, std::pair{40, 40}}) {
    SceneDef s = test::panel_scene(2, 1.0f, 0.0f);
    s.panels[0].resolution_u = l;
    s.panels[0].resolution_v = n;
    const ClothModel m = build_cloth_model(s);
    EXPECT_EQ(m.num_vertices(), uint32_t(l * n));
    EXPECT_EQ(m.spring_counts[size_t(SpringType::Stretch)], size_t((l - 1) * n + l * (n - 1)));
    EXPECT_EQ(m.spring_counts[size_t(SpringType::Shear)], size_t(2 * (l - 1) * (n - 1)));
    EXPECT_EQ(m.spring_counts[size_t(SpringType::Bend)], size_t(std::max(0, l - 2) * n + l * std::max(0, n - 2)));
    EXPECT_EQ(m.num_triangles(), uint32_t(2 * (l - 1) * (n - 1)));
  }
}

namespace {
double total_energy(const ClothModel& m, const std::vector<Vec3>& x, const std::vector<Vec3>& v, double g) {
  double e = 0;
  for (size_t i = 0; i < x.size(); ++i)
    if (m.inv_mass[i] > 0) e += 0.5 * m.mass[i] * length_sq(v[i]) + m.mass[i] * g * x[i].y;
  for (const Spring& s : m.springs) {
    const double stretch = length(x[s.b] - x[s.a]) - s.rest;
    e += 0.5 * s.k * stretch * stretch;
  }
  return e;
}
}  // namespace

TEST(Physics, UndampedEnergyStaysBoundedAtAStableStep) {
  // A cloth pinned along one edge swings under gravity with no damping for 1.2 s.
  SceneDef s = test::panel_scene(15, 0.42f, 1.0f);
  PinDef pin;
  pin.panel = "cloth";
  pin.edge = "bottom";
  s.pins.push_back(pin);
  Simulator sim(s);
  const double e0 = total_energy(sim.model(), sim.positions(), sim.velocities(), 9.81);
  // The swing converts ~ m g h of potential energy; the total must not drift by more than a few
  // percent of that.
  double scale = 0;
  for (size_t i = 0; i < sim.model().mass.size(); ++i) scale += sim.model().mass[i] * 9.81 * 0.42;
  double worst = 0;
  float lowest = 1.0f;  // of the free edge's first vertex (the last row; the bottom row is pinned)
  const size_t free_vertex = sim.positions().size() - 15;
  for (int k = 0; k < 3000; ++k) {
    sim.step(1);
    lowest = std::min(lowest, sim.positions()[free_vertex].y);
    if (k % 50 == 0)
      worst = std::max(worst, std::abs(total_energy(sim.model(), sim.positions(), sim.velocities(), 9.81) - e0));
  }
  EXPECT_LT(worst, 0.05 * scale);
  EXPECT_LT(lowest, 1.0f - 0.3f);  // it did swing down: the free edge fell most of the panel's 0.42 m
}

TEST(Physics, StabilityCheckRefusesTimeStepAtOrAboveT0) {
  SceneDef s = test::panel_scene(3, 0.06f, 0.0f);
  const ClothModel m = build_cloth_model(s);
  const double t0 = m.natural_period();
  // m = 0.2 kg/m^2 * 0.06^2 m^2 / 9 = 8e-5 kg, K = 200 N/m: T0 = pi sqrt(4e-7) = 1.98692e-3 s.
  EXPECT_NEAR(t0, M_PI * std::sqrt(8e-5 / 200.0), 1e-9);
  s.time.dt = t0;
  try {
    Simulator sim(s);
    FAIL() << "dt = T0 was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "/time/dt");
    EXPECT_STREQ(e.what(),
                 "<scene>: /time/dt: time step 0.00198692 s is not below the natural period T0 = pi*sqrt(m/K) = "
                 "0.00198692 s (lightest vertex m = 8e-05 kg, stiffest spring K = 200 N/m); lower dt below "
                 "0.00198692 s or allow it explicitly");
  }
  // Below T0 the mesh's own limit still holds: the middle vertex (8e-5 kg) has 4 stretch, 4 shear
  // and no bend springs, K = 960 N/m, so dt < 2 sqrt(m / K) = 0.000577350 s.
  s.time.dt = 0.9 * t0;
  try {
    Simulator sim(s);
    FAIL() << "dt above the mesh's limit was accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "<scene>: /time/dt: time step 0.00178823 s is not below the mesh's stability limit 0.00057735 s: "
                 "vertex 4 of panel 'cloth' has mass 8e-05 kg and springs summing to K = 960 N/m, and explicit Euler "
                 "needs dt < 2 sqrt(m / K); lower dt below 0.00057735 s, or make the panel's edges longer or its "
                 "springs softer or allow it explicitly");
  }
  EXPECT_NEAR(build_cloth_model(s).stability_limit(), 2 * std::sqrt(8e-5 / 960.0), 1e-9);
  s.time.dt = 0.95 * 2 * std::sqrt(8e-5 / 960.0);
  EXPECT_NO_THROW(Simulator{s});
  s.time.dt = 2 * t0;
  SimOptions allow;
  allow.allow_unstable_dt = true;
  EXPECT_NO_THROW((Simulator{s, allow}));
}

TEST(Physics, BlowUpStopsWithStepAndVertex) {
  SceneDef s = test::panel_scene(10, 0.27f, 0.0f);
  s.panels[0].transform.scale = {1.5f, 1, 1};  // start stretched
  s.time.dt = 0.03;                           // far past T0
  // A pinned corner deforms the panel, so the unstable step has something to amplify (a panel in
  // free fall stays undeformed: the displacement bound scales every vertex's move alike).
  s.pins.push_back({.panel = "cloth", .corner = "top_left"});
  SimOptions allow;
  allow.allow_unstable_dt = true;
  Simulator sim(s, allow);
  try {
    sim.step(2000);
    FAIL() << "no blow-up detected";
  } catch (const SimulationError& e) {
    EXPECT_NE(std::string(e.what()).find("the simulation blew up at step "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("of panel 'cloth'"), std::string::npos) << e.what();
  }
}
