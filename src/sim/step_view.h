// The step's view: plain pointers into the state, the model and the obstacles, and the step's own
// values (its context), which every stage reads on host and device; the step's counters, the contact
// pairs, the per-vertex flags and what a batch of steps reports.
#pragma once
#include <cstdint>

#include "collide/proximity.h"
#include "collide/rules.h"
#include "raycloth/totals.h"
#include "sim/model.h"

namespace raycloth {

// A velocity component past this (m/s) right after integration is a blow-up: the bound would
// otherwise keep an unstable step's positions in range and hide it.
inline constexpr float kRunawaySpeed = 1e3f;

// The displacement bound's refresh in a step (sim/bound.h).
// kRefreshPass: a further pass's (sim/bound.h, stage_bound_pass_begin), a full one but for the
// vertices that stay where they are.
inline constexpr uint32_t kRefreshNone = 0u, kRefreshPartial = 1u, kRefreshFull = 2u, kRefreshPass = 3u;

// Counters of one step, in the backend's memory (device memory on the GPU). Float maxima are kept
// as bit patterns so that atomics and reductions give the same value in any thread order. The ones
// a run reports are RAYCLOTH_SUMMED_COUNTERS (raycloth/totals.h); these are the step's own.
// X(name, start value)
#define RAYCLOTH_STEP_COUNTERS(X)                                                                            \
  X(hits, 0u)          /* vertices with an entry in the collision buffer */                                  \
  X(wants, 0u)         /* vertices whose proposed position left their ball */                                \
  X(wants_now, 0u)     /* of those, vertices marked for a partial refresh (kFlagRefresh) */                  \
  X(refresh, 0u)       /* kRefreshNone, kRefreshPartial, kRefreshFull or kRefreshPass (the one running) */ \
  X(refresh_made, 0u)  /* the step's own refresh (before further passes of the bound) */                     \
  X(starved, 0u)       /* > 0 when a partial refresh could not give a vertex room for its move */            \
  X(escalate, 0u)      /* 1 when a starved partial refresh was redone as a full one */                       \
  X(pad_max, 0u)       /* float bits: the largest ball radius (or target radius) on a partial refresh */     \
  X(move_max, 0u)      /* float bits: the largest |x' - x| of a vertex before the contact solve */           \
  X(drift_max, 0u)     /* float bits: the largest |x' - x_ref| of a vertex before the contact solve */       \
  X(contact_active, 0u) /* pairs that acted in the last round of the contact solve */                        \
  X(contact_done, 0u)  /* 1 once a round found nothing to do: later rounds are skipped */                    \
  X(held, 0u)          /* pushed vertices the last clamp held back (run_bound_passes) */                     \
  X(pass_active, 0u)   /* 1 while a further pass of the bound runs */                                        \
  X(pass_moved, 0u)    /* 1 when the last further pass moved a vertex (else the next would change nothing) */ \
  X(residual, 0u)      /* float bits: the implicit integrator's largest step in its last sweep (metres) */   \
  X(obstacle_move, 0u) /* float bits: the largest move of an obstacle vertex in this step (obstacle_reach) */ \
  X(clear_drift, 0u)   /* float bits: the largest move of a vertex since its cloth clearance was measured */   \
  X(swept_move, 0u)    /* float bits: the largest |x' - x| of a vertex when the swept bound begins */         \
  X(swept_failing, 0u) /* 1 when the swept bound's last round found a pair that would pass its floor */       \
  X(bad_vertex, 0xFFFFFFFFu) /* smallest vertex that blew up */

struct StepCounters {
#define RAYCLOTH_COUNTER_SUMMED(name, json, section) uint32_t name = 0;
#define RAYCLOTH_COUNTER_OWN(name, start) uint32_t name = start;
  RAYCLOTH_SUMMED_COUNTERS(RAYCLOTH_COUNTER_SUMMED)
  RAYCLOTH_STEP_COUNTERS(RAYCLOTH_COUNTER_OWN)
#undef RAYCLOTH_COUNTER_SUMMED
#undef RAYCLOTH_COUNTER_OWN
};

// A pair of cloth features within the thickness (sim/contact.h): a vertex and a triangle (v[0] the
// vertex, weights 1 and minus the barycentric weights of the triangle's nearest point) or two edges
// (weights 1 - s, s and -(1 - t), -t of their closest points); n is the direction the first
// feature keeps its distance along. v[0] = kNoPair marks an empty slot.
inline constexpr uint32_t kNoPair = 0xFFFFFFFFu;
struct ContactPair {
  uint32_t v[4] = {kNoPair, 0, 0, 0};
  float w[4] = {0, 0, 0, 0};
  Vec3 n;
};

// The displacement bound's planes (sim/bound.h): where a pair of features is nearer than a ball can
// serve (a share of the thickness), each of its vertices keeps to its own side of the plane between
// them instead. Up to kBoundPlanes per vertex, each the unit direction it may not move against.
inline constexpr uint32_t kBoundPlanes = 4;
struct BoundPlanes {
  Vec3 n[kBoundPlanes] = {};
};

// The contact pair search's cloth clearances (sim/contact.h, stage_cloth_clear_decide): whether this
// step's search measures them again, and the pair distance (contact_gap) they were measured for (0
// until the first search measures them, and again whenever the state is built anew).
struct ClothClear {
  uint32_t remeasure = 0;
  float reach = 0.0f;
};

// What a batch of steps did (run_steps in sim/step.h, from the counters).
struct StepResult {
  uint64_t hits = 0;        // collision-buffer entries in the last step
  RunTotals totals;         // summed over the batch's steps
  int64_t bad_vertex = -1;  // first vertex that blew up, or -1
  uint64_t bad_step = 0;    // step (counted from the start of the run) where it did
};

// Adds one step's counters to a batch's result.
inline void add_step(StepResult& r, const StepCounters& c) {
  r.hits = c.hits;
  RunTotals& t = r.totals;
#define RAYCLOTH_COUNTER_ADD(name, json, section) t.name += c.name;
  RAYCLOTH_SUMMED_COUNTERS(RAYCLOTH_COUNTER_ADD)
#undef RAYCLOTH_COUNTER_ADD
  t.refreshes += c.refresh_made == kRefreshFull || c.bound_passes > 0 ? 1u : 0u;  // a pass refreshes in full
  t.partial_refreshes += c.refresh_made == kRefreshPartial && c.bound_passes == 0 ? 1u : 0u;
  t.max_residual = t.max_residual > double(float_from_bits(c.residual)) ? t.max_residual : double(float_from_bits(c.residual));
  const double move = double(float_from_bits(c.obstacle_move));
  t.max_obstacle_move = t.max_obstacle_move > move ? t.max_obstacle_move : move;
  t.solves += 1;
}

// The step's state arrays besides x and v, declared once: StepView's pointers (below) and
// SimState's arrays, their sizes, start values and checkpoints (sim/state.h) come from this list.
// X(type, name, count, start value, kept)
//   count: kPerVertex, kPerPairSlot or kOne;
//   start: a value for every element, or a vector (m is the ClothModel);
//   kept: true where the next step reads what this one left (checkpoints save those).
#define RAYCLOTH_STATE_ARRAYS(X)                                                                             \
  X(Ray, rays, kPerVertex, Ray(), true)               /* the paper's rays */                                  \
  X(RawHit, hits, kPerVertex, RawHit(), true)          /* their hits */                                        \
  X(Contact, contacts, kPerVertex, Contact(), true)    /* the collision buffer (normal XYZ, distance W) */     \
  X(Vec3, contact_normal, kPerVertex, Vec3{}, true)    /* last acting contact normal (0: none) */             \
  /* The displacement bound (sim/bound.h): nearest non-adjacent distance at x_ref (float bits), the */        \
  /* radius it was looked for within, the balls' centres, the steps since the last full refresh. */           \
  X(uint32_t, bound, kPerVertex, 0u, true)             /* allowance 0: the first step that moves refreshes */  \
  X(float, bound_radius, kPerVertex, 0.0f, true)                                                              \
  X(Vec3, x_ref, kPerVertex, m.initial_positions, true)                                                       \
  X(uint32_t, plane_count, kPerVertex, 0u, true)       /* planes of the vertex (may exceed kBoundPlanes) */    \
  X(uint32_t, plane_near, kPerVertex, 0u, true)        /* float bits: the nearest pair that gave it a plane */ \
  X(BoundPlanes, planes, kPerVertex, BoundPlanes(), true)                                                     \
  X(uint32_t, bound_age, kOne, 0u, true)                                                                      \
  X(uint32_t, flags, kPerVertex, 0u, true)             /* kFlag* of this step */                               \
  X(uint32_t, inside, kPerVertex, 0u, true)            /* 1: the vertex ended its last step inside an obstacle */ \
  /* The implicit integrator's (sim/integrate/vbd.h): each vertex's velocity at the last step's start. */  \
  X(Vec3, v_before, kPerVertex, Vec3{}, true)                                                                 \
  /* The bound's further passes: the step's goal and where the last pass left each vertex. */                 \
  X(Vec3, x_goal, kPerVertex, Vec3{}, false)                                                                  \
  X(Vec3, v_goal, kPerVertex, Vec3{}, false)                                                                  \
  X(Vec3, x_mid, kPerVertex, Vec3{}, false)                                                                   \
  /* The swept bound (sim/swept_bound.h): the share of its move each vertex may go (float bits). */          \
  X(uint32_t, swept_share, kPerVertex, 0x3F800000u, false)                                                    \
  /* Two-sided contact (sim/contact.h): clearance from the obstacles (stage_obstacles), how far the */        \
  /* solve moved each vertex, the pair slots (contact_slots: per vertex, then per edge) and the list of */    \
  /* those in use (counters->contact_pairs of them), the fixed-point sums (and counts) of a round. */         \
  X(float, clearance, kPerVertex, 0.0f, false)                                                                \
  X(float, contact_shift, kPerVertex, 0.0f, false)                                                            \
  X(ContactPair, pairs, kPerPairSlot, ContactPair(), false)                                                   \
  X(uint32_t, pair_list, kPerPairSlot, 0u, false)                                                             \
  X(FixedVec3, push, kPerVertex, FixedVec3(), false)                                                          \
  X(uint32_t, push_count, kPerVertex, 0u, false)                                                              \
  /* The pair search's cloth clearances: each vertex's distance to the nearest cloth triangle not its */     \
  /* own (up to kClearReach pair distances), where it was then, and whether they hold. Not kept: a */        \
  /* state built anew measures them again at its first search. */                                            \
  X(float, cloth_clear, kPerVertex, 0.0f, false)                                                              \
  X(Vec3, cloth_clear_at, kPerVertex, Vec3{}, false)                                                          \
  X(ClothClear, cloth_clear_state, kOne, ClothClear(), false)                                                 \
  /* The obstacle stage's body clearances (sim/stages.h, stage_obstacles): each vertex's distance to the */  \
  /* bodies (up to kBodyClearLook beyond its query's reach; 0: none), where it was then and how far the */   \
  /* bodies had moved in all (body_moved, summed over the steps) then. Not kept: measured again. */           \
  X(float, body_clear, kPerVertex, 0.0f, false)                                                               \
  X(Vec3, body_clear_at, kPerVertex, Vec3{}, false)                                                           \
  X(double, body_clear_since, kPerVertex, 0.0, false)                                                         \
  X(double, body_moved, kOne, 0.0, false)                                                                     \
  X(StepCounters, counters, kOne, StepCounters(), true) /* the step's counters */

// The step's own values (after Box2D's b2StepContext): the time step, how far seams have closed at
// its start (0 -> 1 over the model's sew_time) and the gravity then (eased in with the seams).
struct StepContext {
  float dt = 1e-3f;
  float sew = 1.0f;
  Vec3 gravity{};
  // Where a scene step is cut into substeps (StepSettings::substeps): which one this is, of how many.
  uint32_t substep = 0, substeps = 1;
};

struct StepView {
  ModelView model;
  StepContext ctx;
  CollisionParams coll;
  CollisionGeometry geom;      // obstacle vertices/velocities at t + dt, cloth at x
  float blowup_limit = 1e4f;   // |x| past this (metres) is a blow-up
  const Vec3* x = nullptr;     // state at t
  const Vec3* v = nullptr;
  Vec3* x_next = nullptr;      // state at t + dt
  Vec3* v_next = nullptr;
#define RAYCLOTH_STATE_POINTER(type, name, count, start, kept) type* name = nullptr;
  RAYCLOTH_STATE_ARRAYS(RAYCLOTH_STATE_POINTER)
#undef RAYCLOTH_STATE_POINTER
  float mean_edge = 0;             // the cloth's mean edge length: the bound's look-ahead scale
  bool cloth_contact = true;       // the scene's collision.cloth_cloth
  BvhView obstacle_bvh;            // over geom.obstacle_indices at t + dt
  BvhView cloth_bvh;               // over model.triangles at x
  // Moving obstacles: whether any does (host), and their vertices at t (obstacle_reach).
  bool bodies_move = false;
  const Vec3* obstacle_prev = nullptr;
  // The bound's planes (sim/bound.h), where something drives the cloth into itself: a body moves or
  // seams are sewn. Static scenes keep the paper's step and its bound (the default scene's frames
  // byte for byte), as for the contact solve.
  bool bound_planes = false;
  // The step's bound is the swept one (sim/swept_bound.h): a vertex its ball cannot hold has its
  // pairs checked over the step instead of being held back (sim/step.h, run_bound).
  bool swept = false;
  uint32_t num_obstacle_vertices = 0;
};

// How far an obstacle's surface moves in this step, at most: every vertex moves along a straight line
// within the step, so the largest vertex move (stage_obstacle_move, the step's first stage where a
// body moves) bounds every surface point's. 0 where nothing moves. The one definition both backends
// use.
RC_HD float obstacle_reach(const StepView& s) {
  return s.bodies_move ? float_from_bits(s.counters->obstacle_move) * 1.01f + 1e-7f : 0.0f;
}

RC_HD void stage_obstacle_move(const StepView& s, uint32_t i) {
  atomic_max_nonneg(&s.counters->obstacle_move, length(s.geom.obstacle_vertices[i] - s.obstacle_prev[i]));
}

inline constexpr uint32_t kFlagPushed = 1u;   // an obstacle pushed the vertex this step
inline constexpr uint32_t kFlagClamped = 2u;  // the bound shortened its move
inline constexpr uint32_t kFlagBlowup = 4u;   // integration gave a non-finite or runaway velocity
inline constexpr uint32_t kFlagInside = 8u;   // inside an obstacle at t + dt, or pushed hard by one
inline constexpr uint32_t kFlagRefresh = 16u; // its ball is recomputed by this step's partial refresh
inline constexpr uint32_t kFlagContact = 32u; // the two-sided contact solve pushed it this step
inline constexpr uint32_t kFlagNearCloth = 64u; // a cloth triangle not its own is near it (sim/contact.h)
inline constexpr uint32_t kFlagSqueezed = 128u; // held between a body and cloth a body backs (sim/contact.h)
inline constexpr uint32_t kFlagPassMove = 256u; // short of its goal in a further pass of the bound (sim/bound.h)
inline constexpr uint32_t kFlagSweptLess = 512u; // the swept bound's last round shortened its move (sim/swept_bound.h)
inline constexpr uint32_t kFlagSweptOut = 1024u; // its ball does not hold its move: the swept bound checks its pairs

// How far off a body a squeezed vertex is held (a share of the thickness): a vertex between a body
// and cloth that another body (or another side of the body) pushes from the far side cannot be at
// the thickness from both; it yields into its own thickness toward the body, never into the body.
inline constexpr float kSqueezeOffset = 0.25f;
// The smallest body gap (metres) that a pushed vertex is put halfway across (stage_obstacles):
// halfway across it the vertex is 10 um off both surfaces, far above the rounding of float positions
// near a body (0.1 um at 1 m); a gap below it is surfaces that touch, or a neighbouring face met at
// a crease, where halfway would be on the surface.
inline constexpr float kPinchMinGap = 2e-5f;



RC_HD bool is_representative(const ModelView& m, uint32_t i) { return m.alias[i] == i; }

}  // namespace raycloth
