// The simulation state, declared once for both backends (in the manner of Warp's State and
// pbrt-v4's SoA buffers): positions and velocities, double-buffered, and the arrays of
// RAYCLOTH_STATE_ARRAYS (sim/step_view.h), each sized, given its start value, wired into the step's
// view and checkpointed from that one list. `Array` is the backend's memory: HostArray
// (std::vector) on the CPU, DeviceBuffer on the GPU; both are built from a host vector.
#pragma once
#include <cstdint>
#include <vector>

#include "sim/contact.h"
#include "sim/model.h"
#include "sim/step_view.h"

namespace raycloth {

template <class T>
using HostArray = std::vector<T>;

// How many elements an array of RAYCLOTH_STATE_ARRAYS has.
enum StateCount { kPerVertex, kPerPairSlot, kOne };

namespace state_detail {
// An array's start: the same value everywhere, or a given vector.
template <class T>
std::vector<T> start_values(size_t count, const T& value) {
  return std::vector<T>(count, value);
}
template <class T>
std::vector<T> start_values(size_t, const std::vector<T>& values) {
  return values;
}
}  // namespace state_detail

template <template <class> class Array>
struct SimState {
  // [cur] holds the state at t, the other the state at t + dt that the step writes; flip() makes it
  // current.
  Array<Vec3> x[2], v[2];
  int cur = 0;
#define RAYCLOTH_STATE_MEMBER(type, name, count, start, kept) Array<type> name;
  RAYCLOTH_STATE_ARRAYS(RAYCLOTH_STATE_MEMBER)
#undef RAYCLOTH_STATE_MEMBER

  explicit SimState(const ClothModel& m) {
    const size_t n = m.num_vertices();
    for (int b = 0; b < 2; ++b) {
      x[b] = Array<Vec3>(m.initial_positions);
      v[b] = Array<Vec3>(std::vector<Vec3>(n, Vec3{}));
    }
    const size_t sizes[] = {n, n * kVertexPairs + size_t(m.num_edges()) * kEdgePairs, 1};
#define RAYCLOTH_STATE_START(type, name, count, start, kept) \
  name = Array<type>(state_detail::start_values<type>(sizes[count], start));
    RAYCLOTH_STATE_ARRAYS(RAYCLOTH_STATE_START)
#undef RAYCLOTH_STATE_START
  }

  // The state's part of the step's view (the model, the obstacles and the trees are the backend's).
  void wire(StepView& s) {
    const int next = cur ^ 1;
    s.x = x[cur].data();
    s.v = v[cur].data();
    s.x_next = x[next].data();
    s.v_next = v[next].data();
    s.geom.cloth_positions = x[cur].data();
    s.geom.cloth_velocities = v[cur].data();
#define RAYCLOTH_STATE_WIRE(type, name, count, start, kept) s.name = name.data();
    RAYCLOTH_STATE_ARRAYS(RAYCLOTH_STATE_WIRE)
#undef RAYCLOTH_STATE_WIRE
  }

  // f(array, what it holds) for x and v (both buffers, the current first) and every kept array, in
  // one order: what a checkpoint holds.
  template <class F>
  void for_each_kept(F&& f) {
    f(x[cur], "positions"), f(v[cur], "velocities"), f(x[cur ^ 1], "positions"), f(v[cur ^ 1], "velocities");
#define RAYCLOTH_STATE_KEPT(type, name, count, start, kept) \
  if (kept) f(name, #name);
    RAYCLOTH_STATE_ARRAYS(RAYCLOTH_STATE_KEPT)
#undef RAYCLOTH_STATE_KEPT
  }

  // f(array, other's array) for every array of this state and of `other` (built for the same model),
  // x and v's buffers included: what a step may change. A retried step (Backend::keep) copies them
  // all, so that the step taken again starts from exactly what the first try started from.
  template <class F>
  void for_each_array(SimState& other, F&& f) {
    for (int b = 0; b < 2; ++b) f(x[b], other.x[b]), f(v[b], other.v[b]);
#define RAYCLOTH_STATE_PAIR(type, name, count, start, kept) f(name, other.name);
    RAYCLOTH_STATE_ARRAYS(RAYCLOTH_STATE_PAIR)
#undef RAYCLOTH_STATE_PAIR
  }

  void flip() { cur ^= 1; }
};

}  // namespace raycloth
