// The obstacles: built from the scene into one world mesh (holes capped for the step), and posed
// at any simulated time (rigid motion, scripted moves, skinning).
#include "sim/model.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <functional>
#include <map>
#include <set>

#include "collide/proximity.h"
#include "collide/rules.h"
#include "raycloth/error.h"
#include "collide/holes.h"
#include "fabric/kes.h"
#include "scene/pattern.h"
#include "scene/transform.h"


namespace raycloth {

ObstacleSet build_obstacles(const SceneDef& s) {
  ObstacleSet set;
  for (size_t oi = 0; oi < s.obstacles.size(); ++oi) {
    const ObstacleDef& od = s.obstacles[oi];
    const std::string field = "/obstacles/" + std::to_string(oi);
    TriMesh local;
    std::shared_ptr<const SkinnedMesh> skinned;
    switch (od.type) {
      case ObstacleType::UvSphere: local = make_uv_sphere(od.radius, od.slices, od.stacks); break;
      case ObstacleType::Box: local = make_box(to_vec3(od.size)); break;
      case ObstacleType::Plane: local = make_plane(to_vec3(od.size)); break;
      case ObstacleType::Mesh: local = load_obj_mesh(od.file, s.source, field + "/file"); break;
      case ObstacleType::Skinned: {
        auto mesh = std::make_shared<SkinnedMesh>(load_skinned_mesh(
            od.file, od.animation,
            [&](const std::string& f, const std::string& reason) { throw InputError(s.source, field + "/" + f, reason); }));
        local.indices = mesh->indices;
        mesh->skin(mesh->joint_matrices(mesh->sample(0, 0)), local.vertices);  // the rest pose
        skinned = std::move(mesh);
        break;
      }
    }
    const Transform xf = make_transform(od.transform);
    set.names.push_back(od.name);
    set.first_vertex.push_back(uint32_t(set.world.vertices.size()));
    set.first_triangle.push_back(uint32_t(set.world.num_triangles()));
    const uint32_t base = uint32_t(set.world.vertices.size());
    for (const Vec3& v : local.vertices) set.world.vertices.push_back(xf.apply(v));
    for (uint32_t i : local.indices) set.world.indices.push_back(base + i);
    set.local.push_back(std::move(local));
    set.defs.push_back(od);
    if (od.motion || skinned) set.any_moving = true;
    set.skinned.push_back(std::move(skinned));
  }
  set.collision_indices = set.world.indices;
  for (size_t oi = 0; oi < set.defs.size(); ++oi) {
    const ObstacleDef& od = set.defs[oi];
    if (!od.close_holes || !(od.type == ObstacleType::Mesh || od.type == ObstacleType::Skinned)) continue;
    // On the rest pose in world space: the same loops at every pose, since the caps reuse the loops'
    // own vertices.
    const uint32_t base = set.first_vertex[oi];
    const TriMesh& local = set.local[oi];
    const HoleCaps caps = cap_holes(local.vertices, local.indices, kHoleMaxShare);
    for (uint32_t v : caps.indices) set.collision_indices.push_back(base + v);
    set.holes_found += caps.loops;
    set.holes_capped += caps.capped;
  }
  set.cap_triangles = uint32_t(set.collision_indices.size() - set.world.indices.size()) / 3u;
  return set;
}

namespace {

// The animation time of a skinned obstacle at simulated time t, and how far the pose has blended
// from the rest pose into the animation.
std::pair<float, float> animation_time(const ObstacleDef& od, const SkinnedMesh& m, double t) {
  if (od.hold > 0) {
    if (t < od.hold) return {float(od.offset.value_or(m.start)), 0.0f};  // the rest pose
    t -= od.hold;
  }
  double a = od.offset.value_or(m.start) + double(od.speed) * t;
  const double span = double(m.end) - double(m.start);
  if (od.loop && span > 0) a = m.start + std::fmod(std::fmod(a - m.start, span) + span, span);
  double blend = 1.0;
  if (od.blend_in > 0 && t < od.blend_in) {
    const double u = std::max(0.0, t / od.blend_in);
    blend = u * u * (3 - 2 * u);  // smoothstep: no jolt at either end
  }
  return {float(a), float(blend)};
}

}  // namespace

void ObstacleSet::skinned_joints(size_t oi, double t, std::vector<Affine>& pose, std::vector<Affine>& rate) const {
  const SkinnedMesh& m = *skinned[oi];
  const Transform xf = make_transform(defs[oi].transform);
  Affine world;  // the obstacle's transform: rotation times scale, then translation
  const Vec3 rows[3] = {xf.rotation.r0, xf.rotation.r1, xf.rotation.r2};
  const float scale[3] = {xf.scale.x, xf.scale.y, xf.scale.z}, move[3] = {xf.translation.x, xf.translation.y, xf.translation.z};
  for (int i = 0; i < 3; ++i) {
    const float r[3] = {rows[i].x, rows[i].y, rows[i].z};
    for (int j = 0; j < 3; ++j) world.m[4 * i + j] = r[j] * scale[j];
    world.m[4 * i + 3] = move[i];
  }
  auto joints_at = [&](double time) {
    const auto [a, blend] = animation_time(defs[oi], m, time);
    std::vector<Affine> j = m.joint_matrices(m.sample(a, blend, defs[oi].loop));
    for (Affine& x : j) x = affine_multiply(world, x);
    return j;
  };
  pose = joints_at(t);
  const double h = 5e-4, t0 = std::max(0.0, t - h), t1 = t + h;
  const std::vector<Affine> a = joints_at(t0), b = joints_at(t1);
  const float inv = float(1.0 / (t1 - t0));
  rate.resize(pose.size());
  for (size_t j = 0; j < pose.size(); ++j)
    for (int k = 0; k < 12; ++k) rate[j].m[k] = (b[j].m[k] - a[j].m[k]) * inv;
}

void ObstacleSet::pose_at(double t, std::vector<Vec3>& vertices, std::vector<Vec3>& velocities) const {
  vertices = world.vertices;
  velocities.assign(vertices.size(), make_vec3(0, 0, 0));
  std::vector<Affine> pose, rate;
  for (size_t oi = 0; oi < defs.size(); ++oi) {
    if (skinned[oi]) {
      skinned_joints(oi, t, pose, rate);
      const std::vector<SkinnedVertex>& sv = skinned[oi]->vertices;
      const size_t first = first_vertex[oi];
      // Every vertex on its own (the walking man's 3,000-odd each substep of the implicit step: in
      // one thread, most of the step's update).
      tbb::parallel_for(tbb::blocked_range<size_t>(0, sv.size(), 512), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
          skin_obstacle_vertex(pose.data(), rate.data(), sv[i], vertices[first + i], velocities[first + i]);
      });
      continue;
    }
    if (!defs[oi].motion) continue;
    const MotionDef& mo = *defs[oi].motion;
    const bool moving = t >= mo.start;
    const Transform xf = make_transform(transform_at(defs[oi], t));
    const Vec3 omega = to_vec3(mo.angular_velocity) * float(M_PI / 180.0);
    for (size_t i = 0; i < local[oi].vertices.size(); ++i) {
      const size_t gi = first_vertex[oi] + i;
      vertices[gi] = xf.apply(local[oi].vertices[i]);
      if (moving) velocities[gi] = to_vec3(mo.velocity) + cross(omega, vertices[gi] - xf.translation);
    }
  }
  for (size_t oi = 0; oi < scripted.size(); ++oi) {
    const Scripted& s = scripted[oi];
    if (s.to.empty()) continue;
    const bool moving = t > s.t0 && t <= s.t1;  // the velocity of the move, up to its end
    const float u = t >= s.t1 ? 1.0f : t > s.t0 ? float((t - s.t0) / (s.t1 - s.t0)) : 0.0f;
    const float inv_duration = float(1.0 / (s.t1 - s.t0));
    for (size_t i = 0; i < s.to.size(); ++i) {
      const size_t gi = first_vertex[oi] + i;
      const Vec3 d = s.to[i] - s.from[i];
      vertices[gi] = u == 1.0f ? s.to[i] : s.from[i] + d * u;
      velocities[gi] = moving ? d * inv_duration : make_vec3(0, 0, 0);
    }
  }
}

}  // namespace raycloth
