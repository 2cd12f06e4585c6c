// The response stages as per-vertex functions over plain pointers (the step's view, sim/step_view.h).
// The sequence that calls them is written once, in sim/step.h, and run by every backend: oneTBB
// loops on the CPU, kernels on the GPU.
//
//   integrate        sim/integrate/: the proposed v', x' (the paper's explicit eq. (3), or implicit
//                    Euler by vertex block descent); the paper's ray per vertex along the move
//   (cast)           backend: rays against the obstacles (posed at t + dt) and the cloth (at x)
//   respond 1        the collision buffer from the hit; respond; second ray along the last contact
//                    normal (resting and sliding contact) or along the corrected move
//   (cast)           backend: second rays
//   respond 2        respond to second-ray hits
//   obstacles        the obstacles at t + dt: a vertex inside one, or nearer than the thickness,
//                    goes to the thickness outside its nearest point and takes the surface's
//                    velocity there (minus friction): a body moving into cloth at rest pushes it
//   contact          two-sided contact between cloth features, with the obstacles (sim/contact.h)
//   bound            the displacement bound: refresh, clamp, further passes (sim/bound.h)
//   weld             seam partners take their representative's state
//   check            blow-up test
#pragma once
#include <cstdint>

#include "sim/obstacle_query.h"
#include "sim/step_view.h"

namespace raycloth {

// Responds to the velocity ray's hit and prepares each vertex's second ray.
RC_HD void stage_respond_velocity(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  const Contact c = make_contact(r, s.hits[i], s.geom);
  s.contacts[i] = c;
  const Vec3 last = s.contact_normal[i];
  s.contact_normal[i] = make_vec3(0, 0, 0);
  Ray next;
  next.vertex = r.vertex;
  if (r.tmax > 0.0f && respond(r, c, s.coll, s.ctx.dt, s.v_next[i], s.x_next[i])) {
    s.contact_normal[i] = c.normal;
    // The response moved the vertex: that move is cast again, so that it sees a second surface.
    next = velocity_ray(s.x[i], s.x_next[i], r.vertex, s.coll);
  } else if (s.model.inv_mass[i] != 0.0f) {
    next = contact_ray(s.x[i], last, r.vertex, s.coll);
  }
  s.rays[i] = next;
}

// Responds to the second ray's hit. Returns 1 when the vertex has an entry in the collision buffer.
RC_HD uint32_t stage_respond_contact(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  if (r.tmax > 0.0f && s.hits[i].kind != kHitNone) {
    const Contact c = make_contact(r, s.hits[i], s.geom);
    if (s.contacts[i].w < 0.0f) s.contacts[i] = c;
    if (respond(r, c, s.coll, s.ctx.dt, s.v_next[i], s.x_next[i])) s.contact_normal[i] = c.normal;
  }
  return s.contacts[i].w >= 0.0f ? 1u : 0u;
}

// The body clearances. Most cloth vertices are farther from every body than the obstacle stage's
// reach (80 to 87 % of its queries under the walking skirt and dress find nothing), and the query
// costs a walk down the bodies' tree. So each query also measures the vertex's clearance c: its
// distance to the bodies, up to kBodyClearLook metres beyond its reach (the query box grown for
// it), at its position z then, and how far the bodies had moved in all (body_moved). Later, with B
// what the bodies' surfaces have moved since (each step's obstacle_reach, summed), no body is nearer
// than c - |y - z| - B to the vertex at y; where that exceeds the reach, the query would find nothing
// and is skipped, with the same result. Each vertex measures again whenever it queries.
inline constexpr float kBodyClearLook = 0.006f;
// Metres taken off every clearance test (here and sim/contact.h): the rounding of its lengths (float
// positions near 1 m).
inline constexpr double kClearMargin = 1e-6;

// A clearance test: nothing was within `clear` of z, the point is now at p, and what it could meet has
// moved at most `moved` since; true when nothing can be within `reach` of p.
RC_HD bool still_clear(float clear, Vec3 z, Vec3 p, double moved, double reach) {
  const DVec3 d = dvec(p) - dvec(z);
  return double(clear) - sqrt(ddot(d, d)) - moved - kClearMargin > reach;
}

// The bodies' moves, summed (one thread, once a step, before the obstacle stage).
RC_HD void stage_body_moved(const StepView& s) { *s.body_moved += double(obstacle_reach(s)); }

// True when no body is within `reach` of vertex i at p, by its clearance.
RC_HD bool body_clear_of(const StepView& s, uint32_t i, Vec3 p, float reach) {
  return still_clear(s.body_clear[i], s.body_clear_at[i], p, *s.body_moved - s.body_clear_since[i], double(reach));
}

// How far from vertex i at p (its position at t + dt) an obstacle query must reach to find any body
// it could be within the thickness of, or inside, having been outside at t: the thickness, its own
// move and the obstacles' (stage_obstacles, stage_conflict, stage_entered).
RC_HD float obstacle_query_reach(const StepView& s, uint32_t i, Vec3 p) {
  return s.coll.thickness + length(p - s.x[i]) + obstacle_reach(s);
}

// Obstacles at t + dt: a vertex inside, or nearer than the thickness, goes to the thickness outside
// the nearest surface point and loses its velocity into the surface relative to the surface's own
// velocity there (friction on the rest).
// Sets clearance[i]: how far the vertex can move from here before it could come within the thickness
// of an obstacle (0 where it was pushed, or lies under a face), so that the contact solve's rounds
// only look again where it matters.
RC_HD void stage_obstacles(const StepView& s, uint32_t i) {
  if (!is_representative(s.model, i)) return;
  Vec3& xn = s.x_next[i];
  s.clearance[i] = INFINITY;
  // The distance kept from the body: the thickness, or a share of it for a squeezed vertex.
  const float offset = (s.flags[i] & kFlagSqueezed) ? kSqueezeOffset * s.coll.thickness : s.coll.thickness;
  if (s.model.inv_mass[i] != 0.0f && s.obstacle_bvh.num_prims > 0 && is_finite(xn)) {
    // A vertex outside at t can be at most its own move plus the obstacle's move inside at t + dt.
    const float reach = obstacle_query_reach(s, i, xn);
    if (body_clear_of(s, i, xn, reach)) {
      s.clearance[i] = reach - s.coll.thickness;
      return;
    }
    const float look = reach + kBodyClearLook;
    double nearest2 = INFINITY;
    ObstaclePoint q = nearest_obstacle_point(s, xn, reach, look, &nearest2);
    s.body_clear[i] = float(fmin(sqrt(nearest2), double(look)));
    s.body_clear_at[i] = xn;
    s.body_clear_since[i] = *s.body_moved;
    s.clearance[i] = q.found ? 0.0f : reach - s.coll.thickness;
    if (q.found) {
      const uint32_t* t = s.geom.obstacle_indices + 3 * q.prim;  // the face that set the push
      const Vec3 face = triangle_normal(s.geom.obstacle_vertices, s.geom.obstacle_indices, q.prim);
      const DVec3 d = dvec(xn) - q.point;
      const double dist = sqrt(q.dist2);
      const bool inside = ddot(d, dvec(face)) < 0.0;
      Vec3 out = face;  // outward direction from the surface point
      if (dist > 1e-9) {
        const double k = (inside ? -1.0 : 1.0) / dist;
        out = make_vec3(float(d.x * k), float(d.y * k), float(d.z * k));
      }
      const bool near = inside || dist < double(offset);
      if (!near && q.num_under == 0) s.clearance[i] = float(dist) - offset;
      if (near || q.num_under > 0) {
        const Vec3 before = xn;
        bool pushed = near, under = false, overlapped = false;
        if (near) {
          const Vec3 surface = make_vec3(float(q.point.x), float(q.point.y), float(q.point.z));
          xn = surface + out * offset;
        }
        // Pushed out of the nearest surface, the vertex may still be straight under another face it
        // was under (an outer layer): then out in front of that one too, and so on.
        for (uint32_t pass = 0; pass < q.num_under; ++pass) {
          bool moved = false;
          for (uint32_t k = 0; k < q.num_under && !moved; ++k) {
            const uint32_t f = q.under[k];
            const uint32_t* ft = s.geom.obstacle_indices + 3 * f;
            const Vec3* ov = s.geom.obstacle_vertices;
            const DVec3 a = dvec(ov[ft[0]]), b = dvec(ov[ft[1]]), c = dvec(ov[ft[2]]);
            const TrianglePoint fp = closest_on_triangle(dvec(xn), a, b, c);
            const Vec3 fn = triangle_normal(ov, s.geom.obstacle_indices, f);
            const DVec3 fpoint = a * fp.wa + b * fp.wb + c * fp.wc, fd = dvec(xn) - fpoint;
            const double depth = -ddot(fd, dvec(fn));
            if (!(depth > 0.0) || depth * depth < 0.999999 * ddot(fd, fd)) continue;  // in front, or not under it
            xn = make_vec3(float(fpoint.x), float(fpoint.y), float(fpoint.z)) + fn * offset;
            out = fn;
            q.prim = f, q.wa = fp.wa, q.wb = fp.wb, q.wc = fp.wc;
            t = s.geom.obstacle_indices + 3 * f;
            moved = pushed = under = true;
          }
          if (!moved) break;
        }
        if (!pushed) return;
        // A pinch: where the body brings another of its surfaces within the offset in front of the
        // point it pushes the vertex out from (an arm against the side), the offset would put the
        // vertex inside that one. It goes halfway across the body's gap instead, outside both. A
        // face met within kPinchMinGap is a neighbour grazed at a crease or a surface touching this
        // one: halfway is then on the surface, where an open body's inside is not defined, so the
        // vertex takes the whole offset as before.
        {
          const Vec3 from = xn - out * offset;
          const float gap = pinch_gap_along(s, from, out, offset, q.prim);
          if (gap < offset && gap >= kPinchMinGap) xn = from + out * (0.5f * gap);
        }
        // Where the body passes into itself (his upper arm into his torso), the nearest surface can
        // lie inside another part, and so can the point in front of it: the vertex goes to the
        // nearest point in front of a face that is outside every part (obstacle_query.h), and is
        // left where the push put it if none is within reach.
        if (push_inside_parts(s, xn, out)) {
          const OverlapExit e = overlap_exit(s, before, offset);
          if (e.found) {
            xn = e.point;
            out = e.normal;
            q.prim = e.prim, q.wa = e.wa, q.wb = e.wb, q.wc = e.wc;
            t = s.geom.obstacle_indices + 3 * e.prim;
            overlapped = true;
            atomic_fetch_add_u32(&s.counters->overlap_exits, 1u);
          }
        }
        Vec3 u = make_vec3(0, 0, 0);
        if (s.geom.obstacle_velocities) {
          const Vec3* ovel = s.geom.obstacle_velocities;
          u = ovel[t[0]] * float(q.wa) + ovel[t[1]] * float(q.wb) + ovel[t[2]] * float(q.wc);
        }
        s.v_next[i] = contact_velocity(s.v_next[i], out, u, s.coll.friction);
        s.contact_normal[i] = out;
        // Inside, or pushed more than a tenth of the thickness by a surface moving into the cloth
        // (not cloth falling onto or resting on a body): the bound is refreshed at once if it holds it.
        const bool hard = inside || under || overlapped || (dot(u, out) > 0.0f && length(xn - before) > 0.1f * s.coll.thickness);
        s.flags[i] |= hard ? (kFlagPushed | kFlagInside) : kFlagPushed;
        if (s.contacts[i].w < 0.0f) {
          s.contacts[i].normal = out;
          s.contacts[i].w = float(dist);
          s.contacts[i].surface_velocity = u;
        }
      }
    }
  }
}

// Seam partners are one vertex: every partner takes its representative's state. Returns false on a
// blow-up (a non-finite or runaway position or velocity).
RC_HD bool stage_finish(const StepView& s, uint32_t i) {
  const uint32_t r = s.model.alias[i];
  if (r != i) {
    s.x_next[i] = s.x_next[r];
    s.v_next[i] = s.v_next[r];
  }
  const Vec3 xn = s.x_next[i];
  return !(s.flags[r] & kFlagBlowup) && is_finite(xn) && is_finite(s.v_next[i]) && fabsf(xn.x) < s.blowup_limit && fabsf(xn.y) < s.blowup_limit &&
         fabsf(xn.z) < s.blowup_limit;
}

}  // namespace raycloth
