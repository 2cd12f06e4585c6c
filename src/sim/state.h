// The simulation state, declared once for both backends (in the manner of Warp's State and
// pbrt-v4's SoA buffers): every per-vertex and per-pair array the step reads and writes, sized and
// given its starting value by one constructor and wired into the step's view by one function.
// `Array` is the backend's memory: HostArray (std::vector) on the CPU, DeviceBuffer on the GPU;
// both are built from a host vector. A new array of the step goes here, and only here.
#pragma once
#include <cstdint>
#include <vector>

#include "sim/contact.h"
#include "sim/model.h"

namespace raycloth {

template <class T>
using HostArray = std::vector<T>;

template <template <class> class Array>
struct SimState {
  // Positions and velocities, double-buffered: [cur] holds the state at t, the other the state at
  // t + dt that the step writes; flip() makes it current.
  Array<Vec3> x[2], v[2];
  int cur = 0;
  // The paper's rays and the collision buffer (normal XYZ, distance W per vertex).
  Array<Ray> rays;
  Array<RawHit> hits;
  Array<Contact> contacts;
  Array<Vec3> contact_normal;  // last acting contact normal per vertex, kept across steps
  // The displacement bound (sim/bound.h), kept across steps: nearest distance (float bits), the
  // radius it was looked for within, the balls' centres, and the steps since the last full refresh.
  Array<uint32_t> bound;
  Array<float> bound_radius;
  Array<Vec3> x_ref;
  Array<uint32_t> bound_age;  // one value
  Array<uint32_t> flags;      // per vertex, per step (kFlag*)
  // The bound's further passes: the step's goal and where the last pass left each vertex.
  Array<Vec3> x_goal, v_goal, x_mid;
  // The implicit integrator's Chebyshev acceleration: the iterate before the last sweep and the one
  // before that.
  Array<Vec3> x_sweep, x_sweep_prev;
  // And its contact with the bodies inside the solve (stage_implicit_plane): per vertex the plane
  // it is kept above (normal, 0 for none; offset), and the body surface's velocity there.
  Array<Vec3> plane_normal, plane_velocity;
  Array<float> plane_offset;
  // Two-sided contact (sim/contact.h): clearance from the obstacles, how far the solve moved each
  // vertex, the pair slots and the list of those in use, the fixed-point sums of a round.
  Array<float> clearance, contact_shift;
  Array<ContactPair> pairs;
  Array<uint32_t> pair_list;
  Array<FixedVec3> push;
  Array<uint32_t> push_count;
  Array<StepCounters> counters;  // one value: the step's counters

  explicit SimState(const ClothModel& m) {
    const size_t n = m.num_vertices();
    const std::vector<Vec3> zero(n, make_vec3(0, 0, 0));
    for (int b = 0; b < 2; ++b) {
      x[b] = Array<Vec3>(m.initial_positions);
      v[b] = Array<Vec3>(zero);
    }
    rays = Array<Ray>(std::vector<Ray>(n));
    hits = Array<RawHit>(std::vector<RawHit>(n));
    contacts = Array<Contact>(std::vector<Contact>(n));
    contact_normal = Array<Vec3>(zero);
    bound = Array<uint32_t>(std::vector<uint32_t>(n, 0u));  // allowance 0: the first step that moves anything refreshes
    bound_radius = Array<float>(std::vector<float>(n, 0.0f));
    x_ref = Array<Vec3>(m.initial_positions);
    bound_age = Array<uint32_t>(std::vector<uint32_t>(1, 0u));
    flags = Array<uint32_t>(std::vector<uint32_t>(n, 0u));
    x_goal = Array<Vec3>(zero);
    v_goal = Array<Vec3>(zero);
    x_mid = Array<Vec3>(zero);
    x_sweep = Array<Vec3>(zero);
    x_sweep_prev = Array<Vec3>(zero);
    plane_normal = Array<Vec3>(zero);
    plane_velocity = Array<Vec3>(zero);
    plane_offset = Array<float>(std::vector<float>(n, 0.0f));
    clearance = Array<float>(std::vector<float>(n, 0.0f));
    contact_shift = Array<float>(std::vector<float>(n, 0.0f));
    const size_t slots = n * kVertexPairs + size_t(m.num_edges()) * kEdgePairs;
    pairs = Array<ContactPair>(std::vector<ContactPair>(slots));
    pair_list = Array<uint32_t>(std::vector<uint32_t>(slots, 0u));
    push = Array<FixedVec3>(std::vector<FixedVec3>(n));
    push_count = Array<uint32_t>(std::vector<uint32_t>(n, 0u));
    counters = Array<StepCounters>(std::vector<StepCounters>(1));
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
    s.rays = rays.data();
    s.hits = hits.data();
    s.contacts = contacts.data();
    s.contact_normal = contact_normal.data();
    s.bound = bound.data();
    s.bound_radius = bound_radius.data();
    s.x_ref = x_ref.data();
    s.bound_age = bound_age.data();
    s.flags = flags.data();
    s.x_goal = x_goal.data();
    s.v_goal = v_goal.data();
    s.x_mid = x_mid.data();
    s.x_sweep = x_sweep.data();
    s.x_sweep_prev = x_sweep_prev.data();
    s.plane_normal = plane_normal.data();
    s.plane_velocity = plane_velocity.data();
    s.plane_offset = plane_offset.data();
    s.clearance = clearance.data();
    s.contact_shift = contact_shift.data();
    s.pairs = pairs.data();
    s.pair_list = pair_list.data();
    s.push = push.data();
    s.push_count = push_count.data();
    s.counters = counters.data();
  }

  void flip() { cur ^= 1; }
};

}  // namespace raycloth
