// The measured fabrics of Wang, Ramamoorthi and O'Brien (2011) (src/fabric/measured.h,
// docs/materials.md): the reading of ARCSim's file format against values computed by hand, the
// sheet's bending rigidity that ARCSim's hinge energy gives, the springs warp and weft apart, the
// pull of a square against the measured model, and the errors word for word.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>

#include "fabric/kes.h"
#include "fixtures.h"
#include "fabric/measured.h"
#include "fabric/stiffening.h"
#include "lab/fabric_tests.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "sim/model.h"

namespace raycloth {
namespace {

constexpr double kPi = 3.14159265358979323846;

using test::expect_input_error;

const fabric::MeasuredData& gray() { return fabric::find_measured("gray_interlock")->data; }

TEST(MeasuredFabric, TenFabricsEachWithItsSource) {
  ASSERT_EQ(fabric::measured_fabrics().size(), 10u);
  for (const auto& f : fabric::measured_fabrics()) {
    EXPECT_NE(f.source.find("Wang, Ramamoorthi, O'Brien"), std::string::npos) << f.name;
    EXPECT_NE(f.source.find(f.file), std::string::npos) << f.name;
    EXPECT_GT(f.data.density, 0.1) << f.name;
  }
  EXPECT_EQ(fabric::find_measured("denim_11oz")->file, "11oz-black-denim.json");
  EXPECT_EQ(fabric::find_measured("velvet"), nullptr);
}

TEST(MeasuredFabric, FormatReadAsHandComputed) {
  // gray-interlock.json: density 0.187; row 0 [16.593832, -14.695990, 34.477123, 36.860302];
  // row 1 (0 degrees at strain 1/6) [46.364765, ...]; row 3 (45 degrees) [123.989220, 105.181770,
  // 365.966217, 44.217571]; bending rows (hinge at 0, 45, 90 degrees) start 23.191698e-6,
  // 24.749964e-6, 14.267624e-6.
  const fabric::MeasuredData& d = gray();
  EXPECT_DOUBLE_EQ(d.density, 0.187);
  EXPECT_DOUBLE_EQ(d.stretching[0][1], -14.695990);
  EXPECT_DOUBLE_EQ(d.stretching[3][2], 365.966217);
  EXPECT_DOUBLE_EQ(d.bending[2][0], 14.267624e-6);
  // No strain: the coefficients doubled, the negative coupling taken as 0.
  const auto k0 = fabric::stretch_coefficients(d, 0, 0);
  EXPECT_NEAR(k0[0], 33.187664, 1e-9);
  EXPECT_EQ(k0[1], 0.0);
  EXPECT_NEAR(k0[2], 68.954246, 1e-9);
  EXPECT_NEAR(k0[3], 73.720604, 1e-9);
  // Strain 1/12 along the warp: halfway to row 1, 2 (16.593832 + 46.364765) / 2 = 62.958597.
  EXPECT_NEAR(fabric::stretch_coefficients(d, 1.0 / 12, 0)[0], 62.958597, 1e-6);
  // Strain 1/6 at 45 degrees (and at 135: the model is symmetric about the warp): row 3, doubled.
  EXPECT_NEAR(fabric::stretch_coefficients(d, 1.0 / 6, kPi / 4)[2], 731.932434, 1e-3);
  EXPECT_NEAR(fabric::stretch_coefficients(d, 1.0 / 6, 3 * kPi / 4)[2], 731.932434, 1e-3);
  // Halfway between 45 and 67.5 degrees: the mean of rows 3 and 4 for the warp coefficient.
  EXPECT_NEAR(fabric::stretch_coefficients(d, 1.0 / 6, 56.25 * kPi / 180)[0], 123.989220 + 139.686325, 1e-3);
  // The tension along the warp at 1/6: (1 + e) (e + e^2/2) 2 c0 = (7/6) (13/72) 92.72953 = 19.53346 N/m.
  EXPECT_NEAR(fabric::measured_tension(d, 1.0 / 6, 0), 7.0 / 6 * 13.0 / 72 * 92.72953, 1e-3);
  // At 45 degrees no strain: C = (k0 + k2 + 2 (k1 + k3)) / 4 = (33.187664 + 68.954246 + 147.441208) / 4.
  EXPECT_NEAR(fabric::strain_modulus(k0, kPi / 4), (33.187664 + 68.954246 + 147.441208) / 4, 1e-9);
  // Bending along the warp: the hinges run along the weft (row 2), times 1/4.
  EXPECT_NEAR(fabric::measured_bending(d, 0), 14.267624e-6 / 4, 1e-15);
  EXPECT_NEAR(fabric::measured_bending(d, kPi / 2), 23.191698e-6 / 4, 1e-15);
  EXPECT_NEAR(fabric::measured_bending(d, kPi / 4), 24.749964e-6 / 4, 1e-15);
}

// ARCSim's hinge energy k_e l^2 theta^2 / (8 (A0 + A1)) summed over a sheet bent into a cylinder of
// curvature kappa, against (1/2) B kappa^2 per area: B = k_e / 4 (kHingeToSheet) on equilateral
// meshes in every direction, and on right-triangle grids along their cells' sides.
double hinge_energy_per_area(bool equilateral, double direction, double kappa) {
  const int n = 40;
  const double h = 0.005;
  std::vector<std::array<double, 2>> p;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      p.push_back(equilateral ? std::array<double, 2>{(i + 0.5 * (j % 2)) * h, j * h * std::sqrt(3.0) / 2}
                              : std::array<double, 2>{i * h, j * h});
  std::vector<std::array<int, 3>> tris;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      if (!equilateral || j % 2 == 0) tris.push_back({a, b, c}), tris.push_back({b, d, c});
      else tris.push_back({a, d, c}), tris.push_back({a, b, d});
    }
  auto bent = [&](int v) {
    const double t = p[size_t(v)][0] * std::cos(direction) + p[size_t(v)][1] * std::sin(direction);
    const double w = -p[size_t(v)][0] * std::sin(direction) + p[size_t(v)][1] * std::cos(direction);
    return std::array<double, 3>{std::sin(kappa * t) / kappa, w, (1 - std::cos(kappa * t)) / kappa};
  };
  auto normal = [&](const std::array<int, 3>& t) {
    const auto a = bent(t[0]), b = bent(t[1]), c = bent(t[2]);
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    std::array<double, 3> nrm{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const double l = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    for (double& x : nrm) x /= l;
    return nrm;
  };
  auto area = [&](const std::array<int, 3>& t) {
    const auto &a = p[size_t(t[0])], &b = p[size_t(t[1])], &c = p[size_t(t[2])];
    return 0.5 * std::abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
  };
  std::map<std::pair<int, int>, std::vector<size_t>> edges;
  double total_area = 0;
  for (size_t t = 0; t < tris.size(); ++t) {
    total_area += area(tris[t]);
    for (int k = 0; k < 3; ++k) {
      const int a = tris[t][size_t(k)], b = tris[t][size_t(k + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back(t);
    }
  }
  double energy = 0;
  for (const auto& [e, faces] : edges) {
    if (faces.size() != 2) continue;
    const auto n0 = normal(tris[faces[0]]), n1 = normal(tris[faces[1]]);
    const double theta = std::acos(std::clamp(n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2], -1.0, 1.0));
    const double l = std::hypot(p[size_t(e.first)][0] - p[size_t(e.second)][0], p[size_t(e.first)][1] - p[size_t(e.second)][1]);
    energy += l * l * theta * theta / (8 * (area(tris[faces[0]]) + area(tris[faces[1]])));  // k_e = 1
  }
  // Hinges only inside: the energy over the area their hinges cover (one cell row short each side).
  return energy / total_area * double(n - 1) / double(n - 2);
}

TEST(MeasuredFabric, ArcsimHingesBendASheetWithAQuarterOfTheirCoefficient) {
  const double kappa = 5.0;
  for (double deg : {0.0, 30.0, 45.0, 90.0})
    EXPECT_NEAR(2 * hinge_energy_per_area(true, deg * kPi / 180, kappa) / (kappa * kappa), fabric::kHingeToSheet, 0.01) << deg;
  for (double deg : {0.0, 45.0, 90.0})
    EXPECT_NEAR(2 * hinge_energy_per_area(false, deg * kPi / 180, kappa) / (kappa * kappa), fabric::kHingeToSheet, 0.01) << deg;
}

TEST(MeasuredFabric, StiffeningSpringGrowsToItsStiffnessAtOneSixth) {
  EXPECT_EQ(fabric::stiffened(10.0f, 30.0f, -0.01f, 1.0f), 10.0f);  // compressed: k
  EXPECT_FLOAT_EQ(fabric::stiffened(10.0f, 30.0f, 1.0f / 12, 1.0f), 25.0f);
  EXPECT_FLOAT_EQ(fabric::stiffened(10.0f, 30.0f, 0.5f, 1.0f), 40.0f);
  EXPECT_FLOAT_EQ(fabric::stiffened_tangent(10.0f, 30.0f, 1.0f / 12, 1.0f), 40.0f);
  EXPECT_EQ(fabric::stiffened(10.0f, 0.0f, 0.5f, 1.0f), 10.0f);
}

TEST(MeasuredFabric, GridSpringsFollowTheMeasuredPullInEveryDirection) {
  // The sheet of the fitted grid, pulled along 0, 22.5, 45, 67.5 and 90 degrees (the fit used 0,
  // 45, 90, 135), against the measured model at no strain: exact for an orthotropic sheet. A
  // spring family's share is k l^2 / A: k for the sides of square cells, 2 k for the diagonals, 4 k
  // for the bend springs (twice a cell long, one a cell).
  const fabric::MeasuredData& d = fabric::find_measured("denim_11oz")->data;
  const double h = 0.01;
  const fabric::MeasuredGrid g = fabric::measured_grid(d, d.density, h, h, 0);
  EXPECT_EQ(g.clamped, 0);
  EXPECT_NEAR(g.diag_a, g.diag_b, 1e-9 * g.diag_a);
  for (double deg : {0.0, 22.5, 45.0, 67.5, 90.0}) {
    const double t = deg * kPi / 180;
    const double springs = (g.stretch_u + 4 * g.bend_u) * std::pow(std::cos(t), 4) + (g.stretch_v + 4 * g.bend_v) * std::pow(std::sin(t), 4) +
                           2 * g.diag_a * std::pow(std::cos(t - kPi / 4), 4) + 2 * g.diag_b * std::pow(std::cos(t + kPi / 4), 4);
    EXPECT_NEAR(springs, fabric::strain_modulus(fabric::stretch_coefficients(d, 0, t), t), 1e-6 * springs) << deg;
  }
  // The warp turned a quarter: u and v trade places.
  const fabric::MeasuredGrid q = fabric::measured_grid(d, d.density, h, h, kPi / 2);
  EXPECT_NEAR(q.stretch_u, g.stretch_v, 1e-6 * g.stretch_v);
  EXPECT_NEAR(q.bend_u, g.bend_v, 1e-9);
}

TEST(MeasuredFabric, GridStretchSpringsNeverPullLessAsTheyStretch) {
  // A stretch spring's tangent k + 2 dk w (w = strain / (1/6) up to 1) stays >= 0 after it gave up
  // the bend springs' pull: the swimsuit knit's springs at 45 degrees from its warp soften (dk < 0)
  // and, on cells of 5 mm, used to give up so much that they pulled less as they stretched.
  for (const auto& f : fabric::measured_fabrics())
    for (double deg = 0; deg <= 180; deg += 22.5)
      for (double h : {0.003, 0.005, 0.008, 0.012})
        for (double aspect : {1.0, 2.0}) {
          const fabric::MeasuredGrid g = fabric::measured_grid(f.data, f.data.density, h, h * aspect, deg * kPi / 180);
          const double k[4] = {g.stretch_u, g.stretch_v, g.diag_a, g.diag_b}, dk[4] = {g.stiff_u, g.stiff_v, g.stiff_a, g.stiff_b};
          for (int i = 0; i < 4; ++i) {
            EXPECT_GE(k[i], 0.0) << f.name << " " << deg << " " << h << " " << aspect << " spring " << i;
            EXPECT_GE(k[i] + 2 * std::min(dk[i], 0.0), -1e-9 * k[i]) << f.name << " " << deg << " " << h << " " << aspect << " spring " << i;
          }
        }
}

TEST(MeasuredFabric, SwimsuitPulledAt45DegreesPullsAsMeasured) {
  // It used to push back (-48 N/m against 21.4 measured at 1/6): its rows buckled in the plane.
  const MaterialDef m = lab::preset_material("white_swim_solid");
  lab::DirectionalOptions o;
  o.stepping.settle = 0.1;
  for (const auto& p : lab::directional_tensile(m, 45, o)) EXPECT_NEAR(p.tension / p.measured, 1.0, 0.10) << p.strain;
}

std::string scene_with(const std::string& material, const std::string& panel_extra = "") {
  return R"({"materials": [)" + material + R"(], "panels": [{"name": "p", "material": "m", "size": [0.1, 0.1], "resolution": [11, 11])" +
         panel_extra + "}]}";
}

TEST(MeasuredFabric, SceneMaterialNamesAMeasuredFabric) {
  SceneDef s = parse_scene(scene_with(R"({"name": "m", "fabric": "denim_11oz"})", R"(, "warp": 90)"), "f.json");
  EXPECT_EQ(s.materials[0].measured, "denim_11oz");
  EXPECT_FALSE(s.materials[0].fabric);
  EXPECT_EQ(s.panels[0].warp, 90.0f);
  const ClothModel m = build_cloth_model(s);
  ASSERT_FALSE(m.adj_k_stiff.empty());
  // The denim's weft (c2 = 1013.9) is five times stiffer than its warp (c0 = 205.4): with the warp
  // along v, the springs along u are the stiff ones.
  float ku = 0, kv = 0;
  for (const Spring& sp : m.springs)
    if (sp.type == SpringType::Stretch && sp.a == 12 && sp.b == 13) ku = sp.k;
    else if (sp.type == SpringType::Stretch && sp.a == 12 && sp.b == 23) kv = sp.k;
  EXPECT_GT(ku, 3 * kv);
  // The density from the file: 0.324 kg/m^2 over 0.01 m^2.
  double mass = 0;
  for (float w : m.mass) mass += w;
  EXPECT_NEAR(mass, 0.324 * 0.01, 1e-6);
  // KES-F fabrics and plain materials keep springs that do not stiffen.
  EXPECT_TRUE(build_cloth_model(parse_scene(scene_with(R"({"name": "m", "fabric": "denim"})"), "f.json")).adj_k_stiff.empty());
}

TEST(MeasuredFabric, BadNamesAndMalformedFilesAreRefused) {
  expect_input_error([] { parse_scene(scene_with(R"({"name": "m", "fabric": "grey_interlock"})"), "f.json"); },
                     "f.json: /materials/0/fabric: unknown fabric 'grey_interlock' (expected a KES-F preset, cotton_shirting, "
                     "wool_suiting, polyester_plain, silk_crepe, denim, cotton_jersey or linen_plain, or a measured fabric, "
                     "ivory_rib_knit, pink_ribbon_brown, white_dots_on_blk, navy_sparkle_sweat, camel_ponte_roma, gray_interlock, "
                     "denim_11oz, white_swim_solid, tango_red_jet_set or royal_target)");
  expect_input_error([] { parse_scene(scene_with(R"({"name": "m", "fabric": 3})"), "f.json"); },
                     "f.json: /materials/0/fabric: expected a string, got number");
  expect_input_error([] { parse_scene(scene_with(R"({"name": "m", "fabric": "gray_interlock", "kes": {"B": 1}})"), "f.json"); },
                     "f.json: /materials/0/kes: the measured fabric 'gray_interlock' takes no KES-F measurements");
  const std::string bend = R"("bending": [[1,1,1,1,1],[1,1,1,1,1],[1,1,1,1,1]])";
  const std::string rows = R"([[1,2,3,4],[1,2,3,4],[1,2,3,4],[1,2,3,4],[1,2,3,4],[1,2,3,4]])";
  auto parse = [](const std::string& text) { fabric::parse_measured(text, "m.json"); };
  EXPECT_NO_THROW(parse(R"({"density": 0.2, "stretching": )" + rows + ", " + bend + "}"));
  expect_input_error([&] { parse("{\"density\": 0.2,\n \"stretching\": [1,, 2]}"); }, "m.json: not JSON (line 2, column 19)");
  expect_input_error([&] { parse("[1, 2]"); }, "m.json: must be a JSON object with density, stretching and bending");
  expect_input_error([&] { parse(R"({"density": 0.2, )" + bend + "}"); }, "m.json: /stretching: missing required field");
  expect_input_error([&] { parse(R"({"density": 0.2, "stretch": 1, "stretching": )" + rows + ", " + bend + "}"); },
                     "m.json: /stretch: unknown field (expected density, stretching or bending)");
  expect_input_error([&] { parse(R"({"density": -0.2, "stretching": )" + rows + ", " + bend + "}"); },
                     "m.json: /density: must be above 0 kg/m^2 (got -0.2)");
  expect_input_error([&] { parse(R"({"density": 0.2, "stretching": [[1,2,3,4]], )" + bend + "}"); },
                     "m.json: /stretching: must be 6 rows of 4 numbers (got 1 rows)");
  expect_input_error([&] { parse(R"({"density": 0.2, "stretching": [[1,2,3,4],[1,2,3],[1,2,3,4],[1,2,3,4],[1,2,3,4],[1,2,3,4]], )" + bend + "}"); },
                     "m.json: /stretching/1: must be a row of 4 numbers (got 3)");
  expect_input_error([&] { parse(R"({"density": 0.2, "stretching": [[1,2,3,4],[1,2,"3",4],[1,2,3,4],[1,2,3,4],[1,2,3,4],[1,2,3,4]], )" + bend + "}"); },
                     "m.json: /stretching/1/2: must be a number");
  expect_input_error([&] { parse(R"({"density": 0.2, "stretching": )" + rows + R"(, "bending": [[1,1,1,1,1],[1,1,-1,1,1],[1,1,1,1,1]]})"); },
                     "m.json: /bending/1/2: must not be negative (got -1)");
}

TEST(MeasuredFabric, PulledSquareFollowsTheMeasuredModelAtTwoStrains) {
  // The t-shirt interlock along its weft, at 1/12 and 1/6, on a grid.
  const MaterialDef m = lab::preset_material("gray_interlock");
  lab::DirectionalOptions o;
  o.stepping.settle = 0.05;
  const auto curve = lab::directional_tensile(m, 90, o);
  ASSERT_EQ(curve.size(), 2u);
  for (const auto& p : curve) EXPECT_NEAR(p.tension / p.measured, 1.0, 0.10) << p.strain;
  EXPECT_GT(curve[1].tension, 2 * curve[0].tension);  // it stiffens
}

TEST(MeasuredFabric, DenimWeftPullsStifferThanItsWarp) {
  // As its data say: c2 = 1013.9 against c0 = 205.4 N/m at no strain, 443 against 98 N/m at 1/6.
  const MaterialDef m = lab::preset_material("denim_11oz");
  lab::DirectionalOptions o;
  o.stepping.settle = 0.05;
  o.strains = {1.0 / 6};
  const double warp = lab::directional_tensile(m, 0, o)[0].tension, weft = lab::directional_tensile(m, 90, o)[0].tension;
  EXPECT_GT(weft, 3 * warp);
  EXPECT_NEAR(weft / warp, fabric::measured_tension(fabric::find_measured("denim_11oz")->data, 1.0 / 6, kPi / 2) /
                               fabric::measured_tension(fabric::find_measured("denim_11oz")->data, 1.0 / 6, 0), 0.1 * weft / warp);
}

}  // namespace
}  // namespace raycloth
