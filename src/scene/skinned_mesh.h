// Skinned, animated bodies from glTF 2.0 (.glb / .gltf, read with tinygltf): every skinned mesh
// primitive of the file, its skin and one named animation, posed by linear blend skinning.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "raycloth/vec3.h"
#include "raycloth/hd.h"

namespace raycloth {

// A 3 x 4 affine matrix, rows.
struct Affine {
  float m[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
};

RC_HD Vec3 affine_apply(const Affine& a, Vec3 p) {
  return make_vec3(a.m[0] * p.x + a.m[1] * p.y + a.m[2] * p.z + a.m[3],
                   a.m[4] * p.x + a.m[5] * p.y + a.m[6] * p.z + a.m[7],
                   a.m[8] * p.x + a.m[9] * p.y + a.m[10] * p.z + a.m[11]);
}

// a * b: b's map first, then a's.
RC_HD Affine affine_multiply(const Affine& a, const Affine& b) {
  Affine r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) {
      float v = a.m[4 * i + 0] * b.m[j] + a.m[4 * i + 1] * b.m[4 + j] + a.m[4 * i + 2] * b.m[8 + j];
      if (j == 3) v += a.m[4 * i + 3];
      r.m[4 * i + j] = v;
    }
  return r;
}

// Linear blend skinning of one vertex: sum of weight[k] * joint_matrix[joint[k]] * rest.
RC_HD Vec3 skin_vertex(const Affine* joint_matrices, const uint16_t joint[4], const float weight[4], Vec3 rest) {
  Vec3 out = make_vec3(0, 0, 0);
  for (int k = 0; k < 4; ++k)
    if (weight[k] != 0.0f) out += affine_apply(joint_matrices[joint[k]], rest) * weight[k];
  return out;
}

struct SkinnedVertex {
  Vec3 rest;           // bind-pose position (the skeleton's space)
  uint16_t joint[4];   // indices into the skin's joints
  float weight[4];
};

// A skinned obstacle vertex in world space and its surface velocity, on the host (ObstacleSet::pose_at)
// and on the device (the CUDA backend) alike. `pose`: the joint matrices at t with the obstacle's
// transform applied; `rate`: their rate of change per second. Skinning is linear in the matrices, so
// skinning with `rate` gives the vertex's velocity.
RC_HD void skin_obstacle_vertex(const Affine* pose, const Affine* rate, const SkinnedVertex& v, Vec3& x, Vec3& vel) {
  x = skin_vertex(pose, v.joint, v.weight, v.rest);
  vel = skin_vertex(rate, v.joint, v.weight, v.rest);
}

// One animation channel: a node's translation, rotation (x, y, z, w) or scale over time.
struct AnimationChannel {
  int node = 0;
  enum class Path { Translation, Rotation, Scale } path = Path::Translation;
  enum class Interpolation { Linear, Step, CubicSpline } interpolation = Interpolation::Linear;
  std::vector<float> times;
  std::vector<float> values;  // 3 or 4 per key (CUBICSPLINE: in-tangent, value, out-tangent per key)
};

struct NodeTrs {
  float t[3] = {0, 0, 0};
  float r[4] = {0, 0, 0, 1};
  float s[3] = {1, 1, 1};
  bool has_matrix = false;  // then `matrix` holds the node's fixed local transform
  Affine matrix;
};

struct SkinnedMesh {
  std::string file;
  std::vector<SkinnedVertex> vertices;
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<int> parent;        // per node, -1 for a root
  std::vector<NodeTrs> rest;      // per node, the file's own transform (the rest pose)
  std::vector<int> joints;        // the skin's joint nodes
  std::vector<Affine> inverse_bind;
  std::string animation;          // the chosen animation's name
  std::vector<AnimationChannel> channels;
  float start = 0, end = 0;       // the animation's key time range (seconds)

  // The local transform of every node at animation time `time` (clamped to the key range), blended
  // from the rest pose by `blend` in [0, 1] (0: rest pose, 1: the animation). With `loop`, each
  // channel's mismatch between its value at `end` and at `start` is spread linearly over the cycle
  // (a clip whose last key differs from its first then plays as a closed loop: the value at `end`
  // equals the value at `start`, so wrapping around does not jump).
  std::vector<NodeTrs> sample(float time, float blend, bool loop = false) const;
  // Joint matrices (global joint transform times inverse bind matrix) for the given node transforms.
  std::vector<Affine> joint_matrices(const std::vector<NodeTrs>& local) const;
  // Skinned positions for the given joint matrices.
  void skin(const std::vector<Affine>& joint_matrices, std::vector<Vec3>& out) const;
};

// Reads `path`; `animation` empty chooses the file's first animation. `fail(field, reason)` must
// throw; field is "file" or "animation".
SkinnedMesh load_skinned_mesh(const std::string& path, const std::string& animation,
                              const std::function<void(const std::string&, const std::string&)>& fail);

}  // namespace raycloth
