// The backend seam: an acceleration structure that is updated and then casts a batch of rays.
// What a hit means (which triangles to skip, the normal, the response) is shared code in rules.h.
#pragma once
#include <cstddef>
#include <cstdint>

#include "raycloth/vec3.h"

namespace raycloth {

inline constexpr uint32_t kNoAlias = 0xFFFFFFFFu;

// One collision ray. tmax <= 0 means "no ray for this vertex".
struct Ray {
  Vec3 org;
  float tmax = 0;
  Vec3 dir;
  uint32_t vertex = 0;  // alias of the cloth vertex casting it: triangles with that alias are skipped
  uint32_t vertex2 = kNoAlias;  // a second alias whose triangles are skipped (edge rays)
};

enum HitKind : uint32_t { kHitNone = 0, kHitObstacle = 1, kHitCloth = 2 };

// What the ray tracer returns: the nearest accepted hit.
struct RawHit {
  float t = -1.0f;
  uint32_t prim = 0;
  uint32_t kind = kHitNone;
};

class Collider {
 public:
  virtual ~Collider() = default;
  // World-space obstacle triangles; `dynamic` when they will move (then update_obstacles refits).
  virtual void set_obstacles(const Vec3* vertices, size_t num_vertices, const uint32_t* indices,
                             size_t num_triangles, bool dynamic) = 0;
  virtual void update_obstacles(const Vec3* vertices) = 0;
  // Cloth triangles and, per corner, the alias used to skip a ray's own triangles.
  virtual void set_cloth(size_t num_vertices, const uint32_t* indices, const uint32_t* tri_alias,
                         size_t num_triangles, bool cast_against_cloth) = 0;
  virtual void update_cloth(const Vec3* positions) = 0;
  // Nearest hit per ray; rays with tmax <= 0 get kind = kHitNone.
  virtual void cast(const Ray* rays, size_t count, RawHit* hits) = 0;
};

}  // namespace raycloth
