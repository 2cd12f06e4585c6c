// Shared collision rules, host and device: which hits count, what goes into the collision buffer,
// and how a vertex responds. Every backend calls these; none has its own copy.
#pragma once
#include <cstdint>

#include "collide/collider.h"
#include "raycloth/hd.h"
#include "raycloth/vec3.h"

namespace raycloth {

// The paper's collision buffer entry (normal XYZ, distance W, W = -1 for none), plus the
// velocity of the surface at the hit so that moving bodies push the cloth.
struct Contact {
  Vec3 normal;
  float w = -1.0f;
  Vec3 surface_velocity;
  uint32_t kind = kHitNone;  // what was hit: the cloth (at t) or an obstacle (already at t + dt)
};

struct CollisionParams {
  float tolerance = 0.005f;
  float thickness = 0.002f;
  float friction = 0.4f;
};

// Triangles and vertices the rules read: obstacle mesh (world space) and the cloth.
struct CollisionGeometry {
  const Vec3* obstacle_vertices = nullptr;
  const Vec3* obstacle_velocities = nullptr;  // may be null: static obstacles
  const uint32_t* obstacle_indices = nullptr;
  const Vec3* cloth_positions = nullptr;
  const Vec3* cloth_velocities = nullptr;
  const uint32_t* cloth_indices = nullptr;
};

// A hit on a cloth triangle that has a corner joined to the ray's vertex (the vertex itself or
// a seam partner) is the vertex's own surface and is ignored.
RC_HD bool is_own_triangle(const uint32_t* tri_alias, uint32_t prim, uint32_t ray_alias) {
  return tri_alias[3 * prim] == ray_alias || tri_alias[3 * prim + 1] == ray_alias ||
         tri_alias[3 * prim + 2] == ray_alias;
}

// The paper's ray: from the vertex along its new velocity. Its length is the tolerance, or the
// whole move of this step plus the thickness when that is longer, so fast vertices cannot tunnel.
RC_HD Ray velocity_ray(Vec3 x, Vec3 x_next, uint32_t vertex, const CollisionParams& p) {
  Ray r;
  r.vertex = vertex;
  r.org = x;
  const Vec3 d = x_next - x;
  const float len = length(d);
  if (!(len > 1e-12f)) return r;  // at rest (or not finite): no velocity ray
  r.dir = d / len;
  r.tmax = fmaxf(p.tolerance, len + p.thickness);
  return r;
}

// Resting and sliding contact: a velocity parallel to a surface misses it, so a vertex that was
// in contact last step also looks back along the last contact normal.
RC_HD Ray contact_ray(Vec3 x, Vec3 last_normal, uint32_t vertex, const CollisionParams& p) {
  Ray r;
  r.vertex = vertex;
  r.org = x;
  if (length_sq(last_normal) == 0.0f) return r;
  r.dir = -last_normal;
  r.tmax = fmaxf(p.tolerance, 2.0f * p.thickness);
  return r;
}

RC_HD Vec3 triangle_normal(const Vec3* v, const uint32_t* idx, uint32_t prim) {
  const Vec3 a = v[idx[3 * prim]], b = v[idx[3 * prim + 1]], c = v[idx[3 * prim + 2]];
  return normalize_or_zero(cross(b - a, c - a));
}

// Fills a collision buffer entry. Obstacles are closed: their outward normal is kept even when the
// ray leaves through the back face (the vertex is inside and will be pushed out). Cloth is
// two-sided: its normal is turned to face the side the ray came from.
RC_HD Contact make_contact(const Ray& r, const RawHit& h, const CollisionGeometry& g) {
  Contact c;
  if (h.kind == kHitNone) return c;
  if (h.kind == kHitObstacle) {
    c.normal = triangle_normal(g.obstacle_vertices, g.obstacle_indices, h.prim);
    if (g.obstacle_velocities) {
      const uint32_t* t = g.obstacle_indices + 3 * h.prim;
      c.surface_velocity =
          (g.obstacle_velocities[t[0]] + g.obstacle_velocities[t[1]] + g.obstacle_velocities[t[2]]) * (1.0f / 3.0f);
    }
  } else {
    Vec3 n = triangle_normal(g.cloth_positions, g.cloth_indices, h.prim);
    c.normal = dot(n, r.dir) > 0.0f ? -n : n;
    if (g.cloth_velocities) {
      const uint32_t* t = g.cloth_indices + 3 * h.prim;
      c.surface_velocity =
          (g.cloth_velocities[t[0]] + g.cloth_velocities[t[1]] + g.cloth_velocities[t[2]]) * (1.0f / 3.0f);
    }
  }
  c.w = h.t;
  c.kind = h.kind;
  return c;
}

// The velocity after a contact with a surface of outward normal n moving at u: the part of the
// relative velocity into the surface is removed, and Coulomb friction takes up to `friction` times
// that much off the tangential part.
RC_HD Vec3 contact_velocity(Vec3 v, Vec3 n, Vec3 u, float friction) {
  const Vec3 rel = v - u;
  const float vn = dot(rel, n);
  if (!(vn < 0.0f)) return v;
  Vec3 vt = rel - n * vn;
  const float vt_len = length(vt);
  const float drop = friction * (-vn);
  vt = vt_len > drop ? vt * (1.0f - drop / vt_len) : make_vec3(0, 0, 0);
  return u + vt;
}

// The response: keep the vertex at least `thickness` on the normal's side of the surface plane at
// the hit, remove the velocity into the surface and apply Coulomb friction to the tangential part.
// Returns true when it acted. dt: the step's (a cloth surface hit at t moves on during it).
RC_HD bool respond(const Ray& r, const Contact& c, const CollisionParams& p, float dt, Vec3& v, Vec3& x_next) {
  if (c.w < 0.0f) return false;
  const Vec3 n = c.normal;
  // Cloth was hit where it is at t and moves on during the step; obstacles are cast at t + dt.
  Vec3 surface = r.org + r.dir * c.w;
  if (c.kind == kHitCloth) surface += c.surface_velocity * dt;
  const float s = dot(x_next - surface, n);
  if (s >= p.thickness) return false;
  x_next += n * (p.thickness - s);
  v = contact_velocity(v, n, c.surface_velocity, p.friction);
  return true;
}

}  // namespace raycloth
