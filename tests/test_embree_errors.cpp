// Embree errors stop the run with a message, instead of a log line and a half-built scene.
#include <gtest/gtest.h>

#include <string>

#include "collide/cpu/embree_collider.h"
#include "raycloth/error.h"

namespace raycloth {
namespace {

TEST(EmbreeErrors, AFailedSceneBuildThrowsWithEmbreesReason) {
  auto collider = make_embree_collider();
  const Vec3 v[3] = {make_vec3(0, 0, 0), make_vec3(1, 0, 0), make_vec3(0, 0, 1)};
  const uint32_t idx[3] = {0, 1, 2};
  collider->set_obstacles(v, 3, idx, 1, false);  // fine
  try {
    // A vertex buffer of 2^60 vertices cannot be allocated: Embree reports an error, the collider
    // throws before touching the buffer it did not get.
    collider->set_obstacles(v, size_t(1) << 60, idx, 1, false);
    FAIL() << "no error";
  } catch (const SimulationError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("Embree failed while building the obstacles' scene: RTC_ERROR_", 0), 0u)
        << e.what();
  }
}

}  // namespace
}  // namespace raycloth
