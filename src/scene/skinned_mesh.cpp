#include "scene/skinned_mesh.h"

#include <fmt/format.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "scene/json_text.h"
#include "scene/mesh.h"

namespace raycloth {

namespace {

using Fail = std::function<void(const std::string&, const std::string&)>;

Affine multiply(const Affine& a, const Affine& b) { return affine_multiply(a, b); }

Affine trs_matrix(const NodeTrs& n) {
  if (n.has_matrix) return n.matrix;
  const float x = n.r[0], y = n.r[1], z = n.r[2], w = n.r[3];
  const float rot[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
                        2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                        2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
  Affine a;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) a.m[4 * i + j] = rot[3 * i + j] * n.s[j];
    a.m[4 * i + 3] = n.t[i];
  }
  return a;
}

void slerp(const float* a, const float* b, float u, float* out) {
  float bb[4] = {b[0], b[1], b[2], b[3]};
  double d = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2] + double(a[3]) * b[3];
  if (d < 0) {
    d = -d;
    for (float& v : bb) v = -v;
  }
  double wa = 1.0 - u, wb = u;
  if (d < 0.9995) {
    const double theta = std::acos(d), s = std::sin(theta);
    wa = std::sin((1.0 - u) * theta) / s;
    wb = std::sin(u * theta) / s;
  }
  double len = 0;
  double q[4];
  for (int k = 0; k < 4; ++k) q[k] = wa * a[k] + wb * bb[k], len += q[k] * q[k];
  len = std::sqrt(len);
  for (int k = 0; k < 4; ++k) out[k] = float(q[k] / len);
}

// The value of a channel at time t (clamped to its keys), `width` floats.
void sample_channel(const AnimationChannel& c, float t, float* out) {
  const int width = c.path == AnimationChannel::Path::Rotation ? 4 : 3;
  const bool cubic = c.interpolation == AnimationChannel::Interpolation::CubicSpline;
  const size_t stride = size_t(width) * (cubic ? 3 : 1);
  const size_t n = c.times.size();
  auto value = [&](size_t key) { return c.values.data() + key * stride + (cubic ? width : 0); };
  if (t <= c.times.front() || n == 1) return (void)std::copy_n(value(0), width, out);
  if (t >= c.times.back()) return (void)std::copy_n(value(n - 1), width, out);
  const size_t k = size_t(std::upper_bound(c.times.begin(), c.times.end(), t) - c.times.begin()) - 1;
  const float t0 = c.times[k], t1 = c.times[k + 1], dt = t1 - t0;
  const float u = dt > 0 ? (t - t0) / dt : 0.0f;
  switch (c.interpolation) {
    case AnimationChannel::Interpolation::Step: std::copy_n(value(k), width, out); break;
    case AnimationChannel::Interpolation::Linear:
      if (width == 4) {
        slerp(value(k), value(k + 1), u, out);
      } else {
        for (int i = 0; i < width; ++i) out[i] = value(k)[i] * (1 - u) + value(k + 1)[i] * u;
      }
      break;
    case AnimationChannel::Interpolation::CubicSpline: {
      // glTF's Hermite spline: p0, out-tangent of k, in-tangent of k + 1, p1, tangents scaled by dt.
      const float* p0 = value(k);
      const float* m0 = c.values.data() + k * stride + 2 * width;
      const float* m1 = c.values.data() + (k + 1) * stride;
      const float* p1 = value(k + 1);
      const float u2 = u * u, u3 = u2 * u;
      double len = 0;
      for (int i = 0; i < width; ++i) {
        out[i] = (2 * u3 - 3 * u2 + 1) * p0[i] + (u3 - 2 * u2 + u) * dt * m0[i] + (-2 * u3 + 3 * u2) * p1[i] +
                 (u3 - u2) * dt * m1[i];
        len += double(out[i]) * out[i];
      }
      if (width == 4 && len > 0)
        for (int i = 0; i < 4; ++i) out[i] = float(out[i] / std::sqrt(len));
      break;
    }
  }
}

// Quaternion product a * b, (x, y, z, w).
void quat_multiply(const float* a, const float* b, float* out) {
  const float r[4] = {a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
                      a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
                      a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
                      a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
  std::copy_n(r, 4, out);
}

// Makes a looping channel close: adds the fraction u in [0, 1] of the cycle's mismatch (value at
// the cycle's start less value at its end) to v. Translations and scales add it linearly; a
// rotation is turned by the same fraction of the shortest rotation from the end value to the start
// value (applied on the left, so at u = 1 the end value becomes the start value exactly).
void close_loop(const AnimationChannel& c, float start, float end, float u, float* v) {
  float first[4], last[4];
  sample_channel(c, start, first);
  sample_channel(c, end, last);
  if (c.path != AnimationChannel::Path::Rotation) {
    for (int i = 0; i < 3; ++i) v[i] += (first[i] - last[i]) * u;
    return;
  }
  const float last_inverse[4] = {-last[0], -last[1], -last[2], last[3]};
  float d[4];
  quat_multiply(first, last_inverse, d);  // d * last = first
  const float identity[4] = {0, 0, 0, 1};
  float part[4];
  slerp(identity, d, u, part);  // slerp takes the shorter way (flips d when d.w < 0)
  quat_multiply(part, v, v);
}

// Reads an accessor as floats (normalized integers scaled to [0, 1]), `width` per element.
std::vector<float> read_floats(const tinygltf::Model& m, int index, int width, const std::string& what,
                               const Fail& fail) {
  if (index < 0 || size_t(index) >= m.accessors.size()) fail("file", what + ": no such accessor");
  const tinygltf::Accessor& a = m.accessors[size_t(index)];
  const int comps = tinygltf::GetNumComponentsInType(uint32_t(a.type));
  if (comps != width) fail("file", fmt::format("{}: {} components per element, expected {}", what, comps, width));
  if (a.bufferView < 0) fail("file", what + ": sparse or empty accessors are not supported");
  if (size_t(a.bufferView) >= m.bufferViews.size()) fail("file", what + ": no such buffer view");
  const tinygltf::BufferView& v = m.bufferViews[size_t(a.bufferView)];
  if (v.buffer < 0 || size_t(v.buffer) >= m.buffers.size()) fail("file", what + ": no such buffer");
  const tinygltf::Buffer& b = m.buffers[size_t(v.buffer)];
  const int csize = tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType));
  if (csize <= 0) fail("file", what + ": unknown component type");
  switch (a.componentType) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: break;
    default: fail("file", what + ": unsupported component type");
  }
  const size_t element = size_t(csize * comps);
  const size_t stride = v.byteStride ? v.byteStride : element;
  // Every figure comes from the file: compared without overflow before anything is allocated.
  const size_t size = b.data.size();
  if (v.byteOffset > size || a.byteOffset > size - v.byteOffset)
    fail("file", what + ": accessor starts past the end of its buffer");
  const size_t offset = v.byteOffset + a.byteOffset;
  if (a.count > 0 && (element > size - offset || a.count - 1 > (size - offset - element) / stride))
    fail("file", what + ": accessor runs past the end of its buffer");
  std::vector<float> out(a.count * size_t(comps));
  for (size_t e = 0; e < a.count; ++e)
    for (int c = 0; c < comps; ++c) {
      const unsigned char* p = b.data.data() + offset + e * stride + size_t(c * csize);
      float f = 0;
      switch (a.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
          std::memcpy(&f, p, 4);
          if (!std::isfinite(f)) fail("file", what + ": a value is not a finite number");
          break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: f = float(*p) / (a.normalized ? 255.0f : 1.0f); break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          uint16_t s;
          std::memcpy(&s, p, 2);
          f = float(s) / (a.normalized ? 65535.0f : 1.0f);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
          uint32_t s;
          std::memcpy(&s, p, 4);
          f = float(s);
          break;
        }
        default: fail("file", what + ": unsupported component type");
      }
      out[e * size_t(comps) + size_t(c)] = f;
    }
  return out;
}

NodeTrs node_trs(const tinygltf::Node& n) {
  NodeTrs r;
  if (n.matrix.size() == 16) {
    r.has_matrix = true;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) r.matrix.m[4 * i + j] = float(n.matrix[size_t(4 * j + i)]);  // column-major
    return r;
  }
  for (size_t k = 0; k < n.translation.size() && k < 3; ++k) r.t[k] = float(n.translation[k]);
  for (size_t k = 0; k < n.rotation.size() && k < 4; ++k) r.r[k] = float(n.rotation[k]);
  for (size_t k = 0; k < n.scale.size() && k < 3; ++k) r.s[k] = float(n.scale[k]);
  return r;
}

}  // namespace

std::vector<NodeTrs> SkinnedMesh::sample(float time, float blend, bool loop) const {
  std::vector<NodeTrs> local = rest;
  const float span = end - start;
  const float cycle = loop && span > 0 ? std::clamp((time - start) / span, 0.0f, 1.0f) : 0.0f;
  for (const AnimationChannel& c : channels) {
    NodeTrs& n = local[size_t(c.node)];
    const NodeTrs& r = rest[size_t(c.node)];
    float v[4];
    sample_channel(c, time, v);
    if (cycle > 0) close_loop(c, start, end, cycle, v);
    switch (c.path) {
      case AnimationChannel::Path::Translation:
        for (int i = 0; i < 3; ++i) n.t[i] = r.t[i] + (v[i] - r.t[i]) * blend;
        break;
      case AnimationChannel::Path::Rotation: slerp(r.r, v, blend, n.r); break;
      case AnimationChannel::Path::Scale:
        for (int i = 0; i < 3; ++i) n.s[i] = r.s[i] + (v[i] - r.s[i]) * blend;
        break;
    }
    n.has_matrix = false;
  }
  return local;
}

std::vector<Affine> SkinnedMesh::joint_matrices(const std::vector<NodeTrs>& local) const {
  // Global transforms, parents first (memoised over the node tree, which the loader checked has no
  // cycle); without recursion, so that a deep chain of nodes cannot overflow the stack.
  std::vector<Affine> global(local.size());
  std::vector<char> done(local.size(), 0);
  std::vector<int> chain;
  auto world = [&](int node) -> const Affine& {
    for (int n = node; n >= 0 && !done[size_t(n)]; n = parent[size_t(n)]) chain.push_back(n);
    for (; !chain.empty(); chain.pop_back()) {
      const size_t n = size_t(chain.back());
      const Affine own = trs_matrix(local[n]);
      global[n] = parent[n] < 0 ? own : multiply(global[size_t(parent[n])], own);
      done[n] = 1;
    }
    return global[size_t(node)];
  };
  std::vector<Affine> out(joints.size());
  for (size_t j = 0; j < joints.size(); ++j) out[j] = multiply(world(joints[j]), inverse_bind[j]);
  return out;
}

void SkinnedMesh::skin(const std::vector<Affine>& joint_matrices, std::vector<Vec3>& out) const {
  out.resize(vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i)
    out[i] = skin_vertex(joint_matrices.data(), vertices[i].joint, vertices[i].weight, vertices[i].rest);
}

SkinnedMesh load_skinned_mesh(const std::string& path, const std::string& animation, const Fail& fail) {
  if (const std::string why = input_file_problem(path); !why.empty()) fail("file", "glTF file '" + path + "' " + why);
  tinygltf::TinyGLTF loader;
  // Textures are never used: their bytes are not decoded.
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                           void*) { return true; },
                        nullptr);
  tinygltf::Model m;
  std::string err, warn;
  const bool binary = std::filesystem::path(path).extension() == ".glb";
  const bool ok = binary ? loader.LoadBinaryFromFile(&m, &err, &warn, path) : loader.LoadASCIIFromFile(&m, &err, &warn, path);
  while (!err.empty() && (err.back() == '\n' || err.back() == '\r')) err.pop_back();
  err = without_json_exception_tags(err);  // tinygltf passes its JSON parser's message on
  if (!ok) fail("file", "glTF file '" + path + "' is malformed: " + err);
  const std::string in_file = "glTF file '" + path + "'";
  if (m.skins.empty()) fail("file", in_file + " has no skin");

  SkinnedMesh s;
  s.file = path;
  s.parent.assign(m.nodes.size(), -1);
  for (size_t n = 0; n < m.nodes.size(); ++n) {
    s.rest.push_back(node_trs(m.nodes[n]));
    for (int c : m.nodes[n].children) {
      if (c < 0 || size_t(c) >= m.nodes.size()) fail("file", fmt::format("{}: node {} has a child {} that is not a node", in_file, n, c));
      if (s.parent[size_t(c)] >= 0 || size_t(c) == n)
        fail("file", fmt::format("{}: node {} is the child of more than one node", in_file, c));
      s.parent[size_t(c)] = int(n);
    }
  }
  // Each node a child of at most one: the nodes form a forest unless a chain of parents loops.
  {
    std::vector<char> state(m.nodes.size(), 0);  // 0 not seen, 1 on the walk now, 2 reaches a root
    std::vector<int> walk;
    for (size_t n = 0; n < m.nodes.size(); ++n) {
      int p = int(n);
      for (; p >= 0 && state[size_t(p)] == 0; p = s.parent[size_t(p)]) state[size_t(p)] = 1, walk.push_back(p);
      if (p >= 0 && state[size_t(p)] == 1) fail("file", fmt::format("{}: node {} is its own ancestor", in_file, p));
      for (int w : walk) state[size_t(w)] = 2;
      walk.clear();
    }
  }
  const tinygltf::Skin& skin = m.skins.front();
  s.joints = skin.joints;
  for (int j : s.joints)
    if (j < 0 || size_t(j) >= m.nodes.size()) fail("file", in_file + ": a skin joint is not a node");
  if (s.joints.size() > 65535) fail("file", fmt::format("{}: {} joints, at most 65535", in_file, s.joints.size()));
  if (skin.inverseBindMatrices >= 0) {
    const std::vector<float> ibm = read_floats(m, skin.inverseBindMatrices, 16, in_file + " inverse bind matrices", fail);
    if (ibm.size() != 16 * s.joints.size()) fail("file", in_file + ": one inverse bind matrix per joint expected");
    for (size_t j = 0; j < s.joints.size(); ++j) {
      Affine a;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) a.m[4 * r + c] = ibm[16 * j + size_t(4 * c + r)];  // column-major
      s.inverse_bind.push_back(a);
    }
  } else {
    s.inverse_bind.assign(s.joints.size(), Affine());
  }

  // Every primitive of every node that uses the skin.
  for (const tinygltf::Node& node : m.nodes) {
    if (node.mesh < 0 || node.skin != 0) continue;
    if (size_t(node.mesh) >= m.meshes.size()) fail("file", fmt::format("{}: node '{}' has no mesh {}", in_file, node.name, node.mesh));
    for (const tinygltf::Primitive& prim : m.meshes[size_t(node.mesh)].primitives) {
      if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) continue;
      const std::string what = in_file + " mesh '" + m.meshes[size_t(node.mesh)].name + "'";
      auto attribute = [&](const char* name) {
        const auto it = prim.attributes.find(name);
        if (it == prim.attributes.end()) fail("file", what + " has no " + name);
        return it->second;
      };
      const std::vector<float> pos = read_floats(m, attribute("POSITION"), 3, what + " POSITION", fail);
      const std::vector<float> jnt = read_floats(m, attribute("JOINTS_0"), 4, what + " JOINTS_0", fail);
      const std::vector<float> wgt = read_floats(m, attribute("WEIGHTS_0"), 4, what + " WEIGHTS_0", fail);
      const size_t nv = pos.size() / 3;
      if (jnt.size() != 4 * nv || wgt.size() != 4 * nv) fail("file", what + ": JOINTS_0 or WEIGHTS_0 count differs from POSITION");
      // A second set of four influences is accepted only when it is unused (all its weights 0), as
      // some exporters write it so.
      std::vector<float> wgt1;
      if (prim.attributes.count("JOINTS_1") || prim.attributes.count("WEIGHTS_1")) {
        wgt1 = read_floats(m, attribute("WEIGHTS_1"), 4, what + " WEIGHTS_1", fail);
        if (wgt1.size() != 4 * nv) fail("file", what + ": WEIGHTS_1 count differs from POSITION");
      }
      const uint32_t base = uint32_t(s.vertices.size());
      for (size_t i = 0; i < nv; ++i) {
        SkinnedVertex v;
        v.rest = make_vec3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]);
        float sum = 0;
        if (!wgt1.empty())
          for (int k = 0; k < 4; ++k)
            if (wgt1[4 * i + size_t(k)] != 0.0f)
              fail("file", fmt::format("{}: vertex {} has weights in WEIGHTS_1: more than 4 joints per vertex, "
                                       "at most 4 are supported (JOINTS_0, WEIGHTS_0)",
                                       what, i));
        for (int k = 0; k < 4; ++k) {
          const float j = jnt[4 * i + size_t(k)], w = wgt[4 * i + size_t(k)];
          if (!(w >= 0) || !std::isfinite(w)) fail("file", fmt::format("{}: vertex {} has a weight that is not a number >= 0", what, i));
          if (w > 0 && !(j >= 0 && j < float(s.joints.size())))
            fail("file", fmt::format("{}: vertex {} uses joint {} but the skin has {} joints (0 to {})", what, i, j,
                                     s.joints.size(), s.joints.size() - 1));
          v.joint[k] = uint16_t(w > 0 ? j : 0);
          v.weight[k] = w;
          sum += w;
        }
        if (std::fabs(sum - 1.0f) > 1e-3f)
          fail("file", fmt::format("{}: the weights of vertex {} sum to {:g}, not 1", what, i, sum));
        for (float& w : v.weight) w /= sum;
        s.vertices.push_back(v);
      }
      if (prim.indices >= 0) {
        const std::vector<float> idx = read_floats(m, prim.indices, 1, what + " indices", fail);
        for (float f : idx) {
          if (!(f >= 0 && f < float(nv))) fail("file", what + ": an index is out of range");
          s.indices.push_back(base + uint32_t(f));
        }
      } else {
        for (uint32_t i = 0; i < nv; ++i) s.indices.push_back(base + i);
      }
    }
  }
  if (s.indices.empty()) fail("file", in_file + " has no triangles skinned by its first skin");

  // The animation.
  if (m.animations.empty()) {
    if (!animation.empty()) fail("animation", in_file + " has no animations");
    return s;
  }
  const tinygltf::Animation* anim = &m.animations.front();
  if (!animation.empty()) {
    anim = nullptr;
    std::string names;
    for (const auto& a : m.animations) {
      if (a.name == animation) anim = &a;
      names += (names.empty() ? "'" : ", '") + a.name + "'";
    }
    if (!anim) fail("animation", "unknown animation '" + animation + "' (" + in_file + " has " + names + ")");
  }
  s.animation = anim->name;
  s.start = INFINITY, s.end = -INFINITY;
  for (const tinygltf::AnimationChannel& ch : anim->channels) {
    AnimationChannel c;
    c.node = ch.target_node;
    if (c.node < 0 || size_t(c.node) >= m.nodes.size()) continue;
    if (ch.target_path == "translation") c.path = AnimationChannel::Path::Translation;
    else if (ch.target_path == "rotation") c.path = AnimationChannel::Path::Rotation;
    else if (ch.target_path == "scale") c.path = AnimationChannel::Path::Scale;
    else continue;  // morph target weights do not move a skinned surface here
    const std::string what = in_file + " animation '" + anim->name + "'";
    if (ch.sampler < 0 || size_t(ch.sampler) >= anim->samplers.size()) fail("file", what + ": a channel has no sampler");
    const tinygltf::AnimationSampler& smp = anim->samplers[size_t(ch.sampler)];
    if (smp.interpolation == "STEP") c.interpolation = AnimationChannel::Interpolation::Step;
    else if (smp.interpolation == "CUBICSPLINE") c.interpolation = AnimationChannel::Interpolation::CubicSpline;
    else c.interpolation = AnimationChannel::Interpolation::Linear;
    const int width = c.path == AnimationChannel::Path::Rotation ? 4 : 3;
    c.times = read_floats(m, smp.input, 1, what + " key times", fail);
    c.values = read_floats(m, smp.output, width, what + " key values", fail);
    const size_t per_key = size_t(width) * (c.interpolation == AnimationChannel::Interpolation::CubicSpline ? 3 : 1);
    if (c.times.empty() || c.values.size() != per_key * c.times.size())
      fail("file", what + ": key times and values do not match");
    if (!std::is_sorted(c.times.begin(), c.times.end())) fail("file", what + ": key times are not in increasing order");
    s.start = std::min(s.start, c.times.front());
    s.end = std::max(s.end, c.times.back());
    s.channels.push_back(std::move(c));
  }
  if (s.channels.empty()) s.start = s.end = 0;
  return s;
}

}  // namespace raycloth
