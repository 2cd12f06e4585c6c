// Moving obstacles on the device: the host turns each obstacle's motion at a step's time into a
// RigidPose with the same transform_at and make_transform that ObstacleSet::pose_at uses; a kernel
// applies it per vertex. pose_vertex is the one place that repeats pose_at's per-vertex lines
// (Transform::apply and the rigid velocity), because transform.h is host-only; tests/test_cuda.cpp
// pins the two bit for bit on the host.
// Skinned bodies: the host computes each step's joint matrices (ObstacleSet::skinned_joints, with
// their rate of change) and uploads them; skin_obstacle_vertex (scene/skinned_mesh.h), the same
// code the host's pose_at runs, skins each vertex on the device. The host bounds how far the body
// moves in a step from the joint matrices alone (skinned_reach), since the device keeps the poses.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "raycloth/hd.h"
#include "raycloth/scene.h"
#include "raycloth/vec3.h"
#include "scene/skinned_mesh.h"
#include "scene/transform.h"

namespace raycloth {

struct RigidPose {
  Vec3 r0, r1, r2;  // rotation rows
  Vec3 scale = make_vec3(1, 1, 1);
  Vec3 translation;
  Vec3 velocity;  // m/s
  Vec3 omega;     // rad/s
  uint32_t moving = 0;  // 0 before the motion starts: the surface is at rest
};

// World position and velocity of a local vertex (ObstacleSet::pose_at for one vertex).
RC_HD void pose_vertex(const RigidPose& p, Vec3 local, Vec3& x, Vec3& v) {
  const Vec3 s = make_vec3(local.x * p.scale.x, local.y * p.scale.y, local.z * p.scale.z);
  x = make_vec3(dot(p.r0, s), dot(p.r1, s), dot(p.r2, s)) + p.translation;
  v = p.moving ? p.velocity + cross(p.omega, x - p.translation) : make_vec3(0, 0, 0);
}

// The pose of a moving obstacle at simulated time t, as ObstacleSet::pose_at computes it.
inline RigidPose rigid_pose_at(const ObstacleDef& def, double t) {
  const MotionDef& mo = *def.motion;
  const Transform xf = make_transform(transform_at(def, t));
  RigidPose p;
  p.r0 = xf.rotation.r0;
  p.r1 = xf.rotation.r1;
  p.r2 = xf.rotation.r2;
  p.scale = xf.scale;
  p.translation = xf.translation;
  p.velocity = to_vec3(mo.velocity);
  p.omega = to_vec3(mo.angular_velocity) * float(M_PI / 180.0);
  p.moving = t >= mo.start ? 1u : 0u;
  return p;
}

// The ball around the bind-pose positions of the vertices a joint moves (radius < 0: none).
struct JointBall {
  Vec3 center;
  float radius = -1.0f;
};

inline std::vector<JointBall> joint_balls(const SkinnedMesh& m) {
  std::vector<Vec3> lo(m.joints.size(), make_vec3(INFINITY, INFINITY, INFINITY));
  std::vector<Vec3> hi(m.joints.size(), make_vec3(-INFINITY, -INFINITY, -INFINITY));
  for (const SkinnedVertex& v : m.vertices)
    for (int k = 0; k < 4; ++k)
      if (v.weight[k] > 0.0f) lo[v.joint[k]] = vmin(lo[v.joint[k]], v.rest), hi[v.joint[k]] = vmax(hi[v.joint[k]], v.rest);
  std::vector<JointBall> balls(m.joints.size());
  for (size_t j = 0; j < balls.size(); ++j) {
    if (!(lo[j].x <= hi[j].x)) continue;
    balls[j].center = (lo[j] + hi[j]) * 0.5f;
    balls[j].radius = length(hi[j] - lo[j]) * 0.5f;
  }
  return balls;
}

// At most how far any vertex of a skinned body moves from the pose of joint matrices `before` to
// that of `after`. A vertex moves by the weighted mean (weights >= 0, summing to 1) of its joints'
// moves of it, and joint j moves a point p of its ball by |D c| + |D (p - c)| <= |D c| + |A| r,
// with D = after - before, c and r the ball's centre and radius, A D's 3 x 3 part and |A| its
// Frobenius norm (at least its largest singular value). Scaled by 1.01 like the CPU's reach.
inline float skinned_reach(const std::vector<JointBall>& balls, const Affine* before, const Affine* after) {
  float reach = 0.0f;
  for (size_t j = 0; j < balls.size(); ++j) {
    if (balls[j].radius < 0.0f) continue;
    Affine d;
    double norm2 = 0.0;
    for (int k = 0; k < 12; ++k) {
      d.m[k] = after[j].m[k] - before[j].m[k];
      if (k % 4 != 3) norm2 += double(d.m[k]) * d.m[k];
    }
    reach = std::max(reach, length(affine_apply(d, balls[j].center)) + float(std::sqrt(norm2)) * balls[j].radius);
  }
  return reach * 1.01f + 1e-7f;
}

}  // namespace raycloth
