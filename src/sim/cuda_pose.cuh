// Moving obstacles on the device: the host turns each obstacle's motion at a step's time into a
// RigidPose with the same transform_at and make_transform that ObstacleSet::pose_at uses; a kernel
// applies it per vertex. pose_vertex is the one place that repeats pose_at's per-vertex lines
// (Transform::apply and the rigid velocity), because transform.h is host-only; tests/test_cuda.cpp
// pins the two bit for bit on the host.
// Skinned bodies: the host computes each step's joint matrices (ObstacleSet::skinned_joints, with
// their rate of change) and uploads them; skin_obstacle_vertex (scene/skinned_mesh.h), the same
// code the host's pose_at runs, skins each vertex on the device. How far the bodies move in a step
// is measured on the device, as on the CPU (obstacle_reach, sim/step_view.h).
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

}  // namespace raycloth
