// The measured fabrics' membranes on triangle meshes (sim/membrane.h): the law against the measured
// model, forces that are its energy's gradient, no force on a turned and moved sheet, a pattern of
// triangles that pulls as the measured model along warp, bias and weft (stretch springs on the edges
// were 6 to 56 % off) and holds still, and the implicit step that pulls it as the explicit one.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "fabric/measured.h"
#include "lab/fabric_tests.h"
#include "raycloth/scene.h"
#include "sim/membrane.h"
#include "sim/model.h"

namespace raycloth {
namespace {

constexpr double kPi = 3.14159265358979323846;

ClothModel pattern_model(const std::string& fabric, float warp) {
  return build_cloth_model(parse_scene(
      R"({"materials": [{"name": "m", "fabric": ")" + fabric +
          R"("}], "panels": [{"name": "p", "material": "m", "warp": )" + std::to_string(warp) +
          R"(, "pattern": {"edge_length": 0.01, "outline": [{"from": [0, 0]}, {"from": [0.1, 0]}, {"from": [0.08, 0.07]}, {"from": [0, 0.05]}]}}]})",
      "f.json"));
}

TEST(Membrane, AMeasuredFabricsTrianglesCarryTheModelInsteadOfStretchSprings) {
  const ClothModel m = pattern_model("denim_11oz", 0);
  EXPECT_EQ(m.num_membranes(), m.num_triangles());
  EXPECT_EQ(m.spring_counts[size_t(SpringType::Stretch)], 0u);
  EXPECT_EQ(m.membrane_law.size(), size_t(kMembraneLaw));
  // A grid keeps its springs (four directions follow the model exactly there).
  const ClothModel g = build_cloth_model(parse_scene(
      R"({"materials": [{"name": "m", "fabric": "denim_11oz"}], "panels": [{"name": "p", "material": "m", "size": [0.1, 0.1], "resolution": [11, 11]}]})",
      "f.json"));
  EXPECT_EQ(g.num_membranes(), 0u);
  EXPECT_GT(g.spring_counts[size_t(SpringType::Stretch)], 0u);
}

// The law against the measured model: at no strain its moduli in every direction; pulled to 1/6
// along the warp, the weft and 45 degrees, its tensions (computed from the law by hand: a held pull
// strains the warp and weft by G cos^2, G sin^2 and the shear by G cos sin).
TEST(Membrane, TheLawIsTheMeasuredModelAtNoStrainAndAlongWarpWeftAndBiasAtOneSixth) {
  for (const auto& f : fabric::measured_fabrics()) {
    SCOPED_TRACE(std::string(f.name));
    const fabric::MembraneLaw law = fabric::membrane_law(f.data);
    const auto& p = law.p;
    for (double deg : {0.0, 20.0, 45.0, 70.0, 90.0}) {
      const double a = deg * kPi / 180, c = std::cos(a), s = std::sin(a);
      const double small = p[0] * c * c * c * c + p[2] * s * s * s * s + 2 * (p[4] + p[5]) * c * c * s * s;
      EXPECT_NEAR(small, fabric::strain_modulus(fabric::stretch_coefficients(f.data, 0, a), a), 1e-3) << deg;
    }
    const double e = fabric::kMeasuredStrain, g = e + e * e / 2;
    for (double deg : {0.0, 45.0, 90.0}) {
      const double a = deg * kPi / 180, c = std::cos(a), s = std::sin(a);
      const float gss = float(g * c * c), gtt = float(g * s * s), gst = float(g * c * s);
      const double sss = membrane_stress(p[0], p[1], p[7], gss) + p[4] * gtt, stt = membrane_stress(p[2], p[3], p[7], gtt) + p[4] * gss;
      const double sst = membrane_stress(p[5], p[6], 0.5f * p[7], gst);
      const double tension = (1 + e) * (c * c * sss + 2 * c * s * sst + s * s * stt);
      const double want = deg == 45.0 ? law.fitted_45 : fabric::measured_tension(f.data, e, a);
      EXPECT_NEAR(tension / want, 1.0, 1e-4) << deg;
    }
    // The shear's floor (a stress that grows as it stretches) holds two knits above their softening
    // at 45 degrees: the rib knit by 9.3 %, the swimsuit by 14.7 %; the other eight are fitted exactly.
    const double over = f.name == "ivory_rib_knit" ? 0.093 : f.name == "white_swim_solid" ? 0.147 : 0.0;
    EXPECT_NEAR(law.fitted_45 / law.measured_45, 1.0 + over, 1e-3);
  }
}

// The forces are the energy's gradient (a central difference at a stretched, sheared, bent sheet).
TEST(Membrane, ForcesAreTheEnergysGradient) {
  const ClothModel m = pattern_model("white_swim_solid", 20);
  std::vector<Vec3> x = m.rest_positions;
  for (Vec3& p : x) p = make_vec3(1.12f * p.x + 0.05f * p.y, 0.93f * p.y + 0.04f * p.x, 0.2f * p.x * p.x);
  const ModelView v = m.view();
  auto energy = [&](const std::vector<Vec3>& y) {
    double sum = 0;
    for (uint32_t t = 0; t < m.num_membranes(); ++t) sum += double(membrane_energy(v, y.data(), t));
    return sum;
  };
  for (uint32_t i : {3u, 17u, 40u}) {
    const Vec3 f = membrane_force(v, x.data(), i);
    for (int c = 0; c < 3; ++c) {
      std::vector<Vec3> y = x;
      const float h = 2e-5f;
      (&y[i].x)[c] += h;
      const double ep = energy(y);
      (&y[i].x)[c] -= 2 * h;
      const double em = energy(y);
      EXPECT_NEAR((&f.x)[c], -(ep - em) / (2 * h), 2e-2 * length(f)) << i << " " << c;
    }
  }
}

// Turned and moved, unstretched: no force at any corner.
TEST(Membrane, ATurnedAndMovedSheetFeelsNoForce) {
  const ClothModel m = pattern_model("denim_11oz", 30);
  std::vector<Vec3> x = m.rest_positions;
  const float c = std::cos(0.7f), s = std::sin(0.7f);
  for (Vec3& p : x) p = make_vec3(c * p.x - s * p.z + 0.03f, p.y + 0.1f, s * p.x + c * p.z - 0.02f);
  const ModelView v = m.view();
  // Against the forces of the same sheet stretched 1 % along its x.
  std::vector<Vec3> pulled = m.rest_positions;
  for (Vec3& p : pulled) p.x *= 1.01f;
  float scale = 0;
  for (uint32_t i = 0; i < m.num_vertices(); ++i) scale = std::max(scale, length(membrane_force(v, pulled.data(), i)));
  ASSERT_GT(scale, 0.0f);
  for (uint32_t i = 0; i < m.num_vertices(); ++i) EXPECT_LT(length(membrane_force(v, x.data(), i)), 1e-3f * scale) << i;
}

// The square of triangles pulled to 1/6 along 0, 45 and 90 degrees from the warp, held across, and
// held 0.3 s: the measured model's tension within 1 % (the denim's weft 4.5 times its warp; the
// knits' softening; the swimsuit at 45 degrees against its law's, 14.7 % above). Stretch springs on the edges were 28 to 36 % off along the denim's warp and
// weft; ARCSim's own forces (coefficients following the principal strain's direction) held the
// knits' squares 65 to 181 % above it after 0.3 s, gaining energy.
TEST(Membrane, TrianglesPullAsTheMeasuredModelAlongWarpBiasAndWeft) {
  for (const char* name : {"denim_11oz", "white_swim_solid", "navy_sparkle_sweat"})
    for (double angle : {0.0, 45.0, 90.0}) {
      SCOPED_TRACE(std::string(name) + " " + std::to_string(angle));
      lab::DirectionalOptions o;
      o.grid = false;
      o.strains = {1.0 / 6};
      o.stepping.settle = 0.3;
      const fabric::MembraneLaw law = fabric::membrane_law(fabric::find_measured(name)->data);
      for (const auto& p : lab::directional_tensile(lab::preset_material(name), angle, o))
        EXPECT_NEAR(p.tension / (angle == 45.0 ? law.fitted_45 : p.measured), 1.0, 0.01) << p.strain;
    }
}

// The implicit step (vertex block descent with the membranes' blocks) pulls the square as the
// explicit one does.
TEST(Membrane, TheImplicitStepPullsTheTrianglesAsTheExplicitOne) {
  lab::DirectionalOptions o;
  o.grid = false;
  o.strains = {1.0 / 6};
  o.stepping.integrator = Integrator::Implicit;
  o.stepping.dt = 1e-3;
  o.stepping.settle = 0.3;
  for (const auto& p : lab::directional_tensile(lab::preset_material("denim_11oz"), 90, o))
    EXPECT_NEAR(p.tension / p.measured, 1.0, 0.02) << p.strain;
}

}  // namespace
}  // namespace raycloth
