// Where a body moves, the implicit integrator's long steps are cut into substeps (Simulator): the
// contact that pushes cloth out of a moving body carries a push through layers of cloth only about a
// millimetre a step, so no body point that can touch the cloth may move more than
// kImplicitMaxBodyMove in one substep. Up to 0.5.8 the number of substeps was fixed for the whole
// run by the fastest point of any body over it (a walking man's hands and feet); now each step takes
// as many as the body points within reach of the cloth in that step ask for, so a step where the
// fast parts of a body are far from the cloth, or where the body stands, takes fewer or none.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "raycloth/vec3.h"

namespace raycloth {

struct ClothModel;
struct ObstacleSet;

class BodyReach {
 public:
  // `margin`: metres added to every reach besides the ways (the collision thickness and tolerance);
  // the cloth's longest triangle edge is added to it here, and to each body vertex's reach the
  // longest edge of the body triangles it is a corner of, so that a body point inside a body triangle
  // and a cloth point inside a cloth triangle are within reach whenever they can touch.
  BodyReach(const ClothModel& model, const ObstacleSet& obstacles, float margin);

  // The cloth's positions and velocities at t, asked for only where a body point goes farther than
  // `enough` (on the GPU, a copy from the device).
  using ClothState = std::function<void(const std::vector<Vec3>*& x, const std::vector<Vec3>*& v)>;

  // The longest way a body point that can come within reach of the cloth goes over [t, t + dt]. A
  // vertex's own way is the larger of its displacement and its speed at either end times dt; its
  // way here the longest own way among the corners of the triangles it is a corner of (a point of a
  // triangle goes no farther than its farthest corner). A body vertex is within reach when its
  // distance at t to the nearest cloth vertex is at most its way, plus how far the cloth can go
  // (twice its way at its speed at t, plus gravity's dt^2), plus its edge and the
  // margin. Metres; 0 where no body moves or none is within reach. Looks fastest first and stops at
  // the first within reach, or at `enough` (a way that asks for no more than one substep; returned
  // as it is, and then the cloth is not asked for).
  double way_near_cloth(const ClothState& cloth, double t, double dt, double gravity, double enough);

  float margin() const { return margin_; }

 private:
  const ObstacleSet& obstacles_;
  std::vector<float> edge_;  // per body vertex: 1.25 times the longest edge of its triangles
  float margin_ = 0;
  // Scratch of way_near_cloth, kept between steps: the bodies at t and t + dt, the ways, the order.
  std::vector<Vec3> b0_, w0_, b1_, w1_;
  std::vector<double> own_, way_, cloth_way_;
  std::vector<uint32_t> order_;
};

}  // namespace raycloth
