// The stages of one step as per-vertex functions over plain pointers. The CPU backend runs them
// in oneTBB loops, the CUDA backend in kernels: one copy of the physics for both.
//
//   integrate      eq. (2)+(3): proposed v', x'
//   (update)       backend: refit the cloth's acceleration structure at x
//   velocity rays  the paper's ray per vertex along v'      -> cast -> hits
//   respond 1      collision buffer from the hit; respond; second rays: along the corrected move
//                  for vertices that responded, along the last contact normal for the others
//   (cast)         backend: second rays                     -> hits
//   respond 2      respond to second-ray hits; remember contact normals; check for blow-up;
//                  a move made by this response gets a third ray        -> cast -> hits
//   certify        the third ray's move stops a thickness short of any surface it would cross
//   crossing guard (cloth-cloth only) refit the cloth at x_next; one ray along every cloth edge
//                  -> cast against the cloth; an edge that passes through a cloth triangle freezes
//                  the edge's and the triangle's vertices at x (v = 0); repeated until no edge
//                  crosses. x is crossing-free, so this always ends crossing-free.
#pragma once
#include <cstdint>

#include "collide/rules.h"
#include "sim/physics.h"

namespace raycloth {

struct StepView {
  ModelView model;
  CollisionParams coll;
  CollisionGeometry geom;
  Vec3 gravity;
  float blowup_limit = 1e4f;  // |x| past this (metres) is a blow-up
  const Vec3* x = nullptr;    // state at t
  const Vec3* v = nullptr;
  Vec3* x_next = nullptr;     // state at t + dt
  Vec3* v_next = nullptr;
  Ray* rays = nullptr;
  RawHit* hits = nullptr;
  Contact* contacts = nullptr;     // the collision buffer, one entry per vertex
  Vec3* contact_normal = nullptr;  // last step's acting contact normal (0 = none), updated in place
  Ray* edge_rays = nullptr;        // crossing guard: one per model edge
  RawHit* edge_hits = nullptr;
  uint32_t* frozen = nullptr;      // crossing guard: per vertex, nonzero = put back to x
};

RC_HD void stage_integrate(const StepView& s, uint32_t i) {
  integrate_vertex(s.model, s.x, s.v, i, s.gravity, s.coll.dt, s.v_next[i], s.x_next[i]);
}

RC_HD void stage_velocity_ray(const StepView& s, uint32_t i) {
  s.contacts[i] = Contact();
  s.rays[i] = s.model.inv_mass[i] == 0.0f ? Ray() : velocity_ray(s.x[i], s.x_next[i], s.model.alias[i], s.coll);
  s.rays[i].vertex = s.model.alias[i];
}

// Responds to the velocity ray's hit and prepares each vertex's second ray.
RC_HD void stage_respond_velocity(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  const Contact c = make_contact(r, s.hits[i], s.geom);
  s.contacts[i] = c;
  const Vec3 last = s.contact_normal[i];
  s.contact_normal[i] = make_vec3(0, 0, 0);
  Ray next;
  next.vertex = r.vertex;
  if (r.tmax > 0.0f && respond(r, c, s.coll, s.v_next[i], s.x_next[i])) {
    s.contact_normal[i] = c.normal;
    // The response moved the vertex: that move must not carry it through another surface (a
    // cloth layer lying on the obstacle it was pushed out of), so it is cast again.
    next = velocity_ray(s.x[i], s.x_next[i], r.vertex, s.coll);
  } else if (s.model.inv_mass[i] != 0.0f) {
    next = contact_ray(s.x[i], last, r.vertex, s.coll);
  }
  s.rays[i] = next;
}

// Responds to the second ray's hit and, when that moved the vertex, prepares the third ray along
// its whole move; then checks the new state. Returns false on a blow-up.
RC_HD bool stage_respond_contact(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  Ray third;
  third.vertex = r.vertex;
  if (r.tmax > 0.0f && s.hits[i].kind != kHitNone) {
    const Contact c = make_contact(r, s.hits[i], s.geom);
    if (s.contacts[i].w < 0.0f) s.contacts[i] = c;
    if (respond(r, c, s.coll, s.v_next[i], s.x_next[i])) {
      s.contact_normal[i] = c.normal;
      third = velocity_ray(s.x[i], s.x_next[i], r.vertex, s.coll);
    }
  }
  s.rays[i] = third;
  const Vec3 xn = s.x_next[i];
  return is_finite(xn) && is_finite(s.v_next[i]) && fabsf(xn.x) < s.blowup_limit && fabsf(xn.y) < s.blowup_limit &&
         fabsf(xn.z) < s.blowup_limit;
}

// The second response's move must not cross a surface either: it stops a thickness short. Leaving
// an obstacle through its back face is always allowed (the vertex was inside).
RC_HD void stage_certify(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  if (!(r.tmax > 0.0f) || s.hits[i].kind == kHitNone) return;
  const Contact c = make_contact(r, s.hits[i], s.geom);
  if (s.hits[i].kind == kHitObstacle && dot(c.normal, r.dir) > 0.0f) return;
  clamp_move(r, c, s.coll, s.x[i], s.v_next[i], s.x_next[i]);
}

// Crossing guard, per edge: a ray from one end to the other at the new positions. The triangles of
// either end are skipped (an edge meets them at its ends, and a tight fold is not a crossing).
RC_HD void stage_edge_ray(const StepView& s, uint32_t e) {
  const uint32_t a = s.model.edges[2 * e], b = s.model.edges[2 * e + 1];
  Ray r;
  r.vertex = s.model.alias[a];
  r.vertex2 = s.model.alias[b];
  const Vec3 d = s.x_next[b] - s.x_next[a];
  const float len = length(d);
  if (len > 1e-9f) {
    r.org = s.x_next[a];
    r.dir = d / len;
    r.tmax = len;
  }
  s.edge_rays[e] = r;
}

// Crossing guard, per edge: an edge through a cloth triangle marks its two ends and the triangle's
// corners. Every writer stores the same value, so the result does not depend on thread order.
RC_HD bool stage_edge_mark(const StepView& s, uint32_t e) {
  const RawHit h = s.edge_hits[e];
  if (h.kind != kHitCloth) return false;
  s.frozen[s.model.edges[2 * e]] = 1u;
  s.frozen[s.model.edges[2 * e + 1]] = 1u;
  const uint32_t* t = s.model.triangles + 3 * h.prim;
  s.frozen[t[0]] = 1u;
  s.frozen[t[1]] = 1u;
  s.frozen[t[2]] = 1u;
  return true;
}

// Crossing guard, per vertex: a marked vertex goes back to where it was at the start of the step and
// stops. Returns true when it did.
RC_HD bool stage_freeze(const StepView& s, uint32_t i) {
  if (s.frozen[i] == 0u) return false;
  s.frozen[i] = 0u;
  s.x_next[i] = s.x[i];
  s.v_next[i] = make_vec3(0, 0, 0);
  return true;
}

}  // namespace raycloth
