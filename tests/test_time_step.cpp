// The time step a scene file leaves to the mesh (TimeDef::dt_given, max_dt; Simulator::choose_dt):
// the scene's step where the explicit step can take it, else one below the mesh's limit.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "raycloth/simulator.h"
#include "sim/model.h"

namespace raycloth {
namespace {

// A 10 x 10 cm sheet at 21 x 21 (vertices of 4.5e-6 kg with springs summing to about 570 N/m: an
// explicit limit near 0.18 ms, below the default 0.4 ms), with `time` as the scene's time section.
SceneDef small_sheet(const std::string& time) {
  return parse_scene(R"({"time": {)" + time + R"(, "duration": 0.01},
    "materials": [{"name": "m", "density": 0.2, "stretch": 100, "shear": 40, "bend": 2}],
    "panels": [{"name": "sheet", "material": "m", "size": [0.1, 0.1], "resolution": [21, 21]}]})",
                     "sheet.json");
}

TEST(TimeStep, ChosenFromTheMeshWhereTheSceneLeavesItOut) {
  const SceneDef s = small_sheet(R"("fps": 100)");
  EXPECT_FALSE(s.time.dt_given);
  const ClothModel m = build_cloth_model(s);
  const double limit = std::min(m.natural_period(), m.stability_limit());
  ASSERT_LT(limit, 4e-4) << "the sheet should not take the default step";
  Simulator sim(s);
  EXPECT_TRUE(sim.dt_from_mesh());
  const double dt = sim.scene().time.dt;
  // The largest step of two significant digits at or below 0.9 of the limit.
  EXPECT_LE(dt, 0.9 * limit);
  EXPECT_GT(dt, 0.9 * limit - 1e-5);
  const double unit = std::pow(10.0, std::floor(std::log10(dt)) - 1.0);
  EXPECT_NEAR(dt / unit, std::round(dt / unit), 1e-6);
  // And it runs stably at it.
  EXPECT_NO_THROW(sim.step(int(0.01 / dt)));
  // The same step given explicitly is refused, as any dt the mesh cannot take.
  EXPECT_THROW(Simulator(small_sheet(R"("dt": 0.0004)")), InputError);
}

TEST(TimeStep, TheScenesStepOrMaxDtStaysWhereTheMeshTakesIt) {
  Simulator by_default(small_sheet(R"("dt": 0.0001)"));
  EXPECT_FALSE(by_default.dt_from_mesh());
  EXPECT_EQ(by_default.scene().time.dt, 1e-4);
  const SceneDef capped = small_sheet(R"("max_dt": 0.0001)");
  EXPECT_FALSE(capped.time.dt_given);
  Simulator sim(capped);
  EXPECT_FALSE(sim.dt_from_mesh());
  EXPECT_EQ(sim.scene().time.dt, 1e-4);
  // A max_dt above the limit is lowered like the default.
  Simulator lowered(small_sheet(R"("max_dt": 0.001)"));
  EXPECT_TRUE(lowered.dt_from_mesh());
  EXPECT_LT(lowered.scene().time.dt, 2e-4);
}

TEST(TimeStep, BadTimeStepFieldsAreRefusedWordForWord) {
  auto message = [](const std::string& time) {
    try {
      small_sheet(time);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(R"("dt": 0.0001, "max_dt": 0.0002)"),
            "sheet.json: /time/max_dt: give dt or max_dt, not both (max_dt lets the mesh choose a smaller step)");
  EXPECT_EQ(message(R"("max_dt": -0.001)"), "sheet.json: /time/max_dt: must be positive (got -0.001)");
}

}  // namespace
}  // namespace raycloth
