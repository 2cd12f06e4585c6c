// Small skinned glTF files written by the tests themselves (tinygltf, buffers embedded as data
// URIs), so that every number in them is visible in the test that uses them.
#pragma once
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "fixtures.h"

namespace raycloth::test {

struct GltfNode {
  std::string name;
  int parent = -1;
  std::array<float, 3> translation{0, 0, 0};  // the rest pose; joints have no rest rotation here
};

struct GltfChannel {
  int node = 0;
  std::string path;           // translation, rotation or scale
  std::string interpolation;  // LINEAR, STEP or CUBICSPLINE
  std::vector<float> times;
  std::vector<float> values;  // CUBICSPLINE: in-tangent, value, out-tangent per key
};

struct GltfAnimation {
  std::string name;
  std::vector<GltfChannel> channels;
};

struct SkinnedGltf {
  std::vector<GltfNode> nodes;
  std::vector<int> joints;  // node indices; inverse bind matrices undo each joint's rest translation
  bool skinned = true;      // false: the mesh and nodes without a skin
  std::vector<float> positions;     // 3 per vertex, the bind pose
  std::vector<uint16_t> joints0;    // 4 per vertex
  std::vector<float> weights0;      // 4 per vertex
  std::vector<uint16_t> joints1;    // 4 per vertex, or empty
  std::vector<float> weights1;      // 4 per vertex, or empty
  std::vector<uint32_t> indices;    // 3 per triangle
  std::vector<GltfAnimation> animations;
};

namespace detail {

class Buffers {
 public:
  explicit Buffers(tinygltf::Model& m) : m_(m) { m_.buffers.resize(1); }
  template <class T>
  int add(const std::vector<T>& v, int component, int type, int components) {
    std::vector<unsigned char>& data = m_.buffers[0].data;
    tinygltf::BufferView bv;
    bv.buffer = 0;
    bv.byteOffset = data.size();
    bv.byteLength = v.size() * sizeof(T);
    data.resize(data.size() + bv.byteLength);
    if (!v.empty()) std::memcpy(data.data() + bv.byteOffset, v.data(), bv.byteLength);
    data.resize((data.size() + 3) / 4 * 4);
    m_.bufferViews.push_back(bv);
    tinygltf::Accessor a;
    a.bufferView = int(m_.bufferViews.size() - 1);
    a.componentType = component;
    a.type = type;
    a.count = v.size() / size_t(components);
    if (type == TINYGLTF_TYPE_VEC3 && component == TINYGLTF_COMPONENT_TYPE_FLOAT && !v.empty()) {
      a.minValues = {1e30, 1e30, 1e30};
      a.maxValues = {-1e30, -1e30, -1e30};
      for (size_t i = 0; i < v.size(); ++i) {
        a.minValues[i % 3] = std::min(a.minValues[i % 3], double(v[i]));
        a.maxValues[i % 3] = std::max(a.maxValues[i % 3], double(v[i]));
      }
    }
    if (type == TINYGLTF_TYPE_SCALAR && component == TINYGLTF_COMPONENT_TYPE_FLOAT && !v.empty()) {
      a.minValues = {double(v.front())};
      a.maxValues = {double(v.back())};
    }
    m_.accessors.push_back(a);
    return int(m_.accessors.size() - 1);
  }

 private:
  tinygltf::Model& m_;
};

}  // namespace detail

// Writes `g` to `path` (.gltf). Node 0 .. nodes.size() - 1 are the joints' nodes; the mesh node
// comes last.
inline void write_skinned_gltf(const std::filesystem::path& path, const SkinnedGltf& g) {
  tinygltf::Model m;
  m.asset.version = "2.0";
  detail::Buffers b(m);
  for (const GltfNode& n : g.nodes) {
    tinygltf::Node node;
    node.name = n.name;
    node.translation = {n.translation[0], n.translation[1], n.translation[2]};
    m.nodes.push_back(node);
  }
  tinygltf::Scene scene;
  for (size_t i = 0; i < g.nodes.size(); ++i) {
    if (g.nodes[i].parent >= 0) m.nodes[size_t(g.nodes[i].parent)].children.push_back(int(i));
    else scene.nodes.push_back(int(i));
  }
  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] = b.add(g.positions, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 3);
  prim.attributes["JOINTS_0"] = b.add(g.joints0, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4, 4);
  prim.attributes["WEIGHTS_0"] = b.add(g.weights0, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, 4);
  if (!g.joints1.empty()) {
    prim.attributes["JOINTS_1"] = b.add(g.joints1, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4, 4);
    prim.attributes["WEIGHTS_1"] = b.add(g.weights1, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, 4);
  }
  prim.indices = b.add(g.indices, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, 1);
  tinygltf::Mesh mesh;
  mesh.name = "body";
  mesh.primitives.push_back(prim);
  m.meshes.push_back(mesh);
  tinygltf::Node mesh_node;
  mesh_node.name = "body";
  mesh_node.mesh = 0;
  if (g.skinned) {
    mesh_node.skin = 0;
    tinygltf::Skin skin;
    skin.joints = g.joints;
    std::vector<float> ibm;
    for (int j : g.joints) {
      float t[3] = {0, 0, 0};  // the joint's rest position: its translation and its ancestors'
      for (int n = j; n >= 0; n = g.nodes[size_t(n)].parent)
        for (int k = 0; k < 3; ++k) t[k] += g.nodes[size_t(n)].translation[size_t(k)];
      const std::vector<float> matrix = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -t[0], -t[1], -t[2], 1};  // column-major
      ibm.insert(ibm.end(), matrix.begin(), matrix.end());
    }
    skin.inverseBindMatrices = b.add(ibm, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_MAT4, 16);
    m.skins.push_back(skin);
  }
  m.nodes.push_back(mesh_node);
  scene.nodes.push_back(int(m.nodes.size() - 1));
  for (const GltfAnimation& a : g.animations) {
    tinygltf::Animation anim;
    anim.name = a.name;
    for (const GltfChannel& c : a.channels) {
      tinygltf::AnimationSampler s;
      s.input = b.add(c.times, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, 1);
      const bool rotation = c.path == "rotation";
      s.output = b.add(c.values, TINYGLTF_COMPONENT_TYPE_FLOAT, rotation ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3,
                       rotation ? 4 : 3);
      s.interpolation = c.interpolation;
      anim.samplers.push_back(s);
      tinygltf::AnimationChannel ch;
      ch.sampler = int(anim.samplers.size() - 1);
      ch.target_node = c.node;
      ch.target_path = c.path;
      anim.channels.push_back(ch);
    }
    m.animations.push_back(anim);
  }
  m.buffers[0].name = "data";
  m.scenes.push_back(scene);
  m.defaultScene = 0;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToFile(&m, path.string(), false, true, true, false))
    throw std::runtime_error(path.string() + ": the glTF writer failed");
}

// One root joint at the origin and one triangle skinned fully to it.
inline SkinnedGltf one_joint_triangle() {
  SkinnedGltf g;
  g.nodes = {GltfNode{"root", -1, {0, 0, 0}}};
  g.joints = {0};
  g.positions = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  g.joints0.assign(12, 0);
  g.weights0 = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  g.indices = {0, 1, 2};
  return g;
}

// Quaternion (x, y, z, w) of `degrees` about +y.
inline std::array<float, 4> about_y(float degrees) {
  const double h = double(degrees) * M_PI / 360.0;
  return {0.0f, float(std::sin(h)), 0.0f, float(std::cos(h))};
}

// An arm: a closed square tube 0.6 m long along +x from its shoulder (the origin), 8 cm thick, in
// 12 segments; the shoulder joint at the origin and the elbow joint at x = 0.3 (a child of the
// shoulder). Vertices up to x = 0.25 follow the shoulder, from x = 0.35 the elbow, and in between
// both with weights blended linearly. Animation `swing`: the shoulder turns about +y from 180
// degrees (the arm along -x) by `sweep` degrees and back at 900 degrees/s (the tip at 9.4 m/s), in
// keys at most 45 degrees apart, while the elbow bends 30 degrees and straightens twice.
inline SkinnedGltf swinging_arm(float sweep = 180.0f) {
  SkinnedGltf g;
  g.nodes = {GltfNode{"shoulder", -1, {0, 0, 0}}, GltfNode{"elbow", 0, {0.3f, 0, 0}}};
  g.joints = {0, 1};
  const int segments = 12;
  const float length = 0.6f, half = 0.04f;
  const float corner[4][2] = {{-half, -half}, {half, -half}, {half, half}, {-half, half}};  // (y, z)
  for (int i = 0; i <= segments; ++i) {
    const float x = length * float(i) / float(segments);
    const float elbow = std::clamp((x - 0.25f) / 0.1f, 0.0f, 1.0f);
    for (const auto& c : corner) {
      g.positions.insert(g.positions.end(), {x, c[0], c[1]});
      g.joints0.insert(g.joints0.end(), {0, 1, 0, 0});
      g.weights0.insert(g.weights0.end(), {1.0f - elbow, elbow, 0.0f, 0.0f});
    }
  }
  auto add = [&](uint32_t a, uint32_t b, uint32_t c) {  // outward: away from the tube's centre line
    const float* p[3] = {&g.positions[3 * a], &g.positions[3 * b], &g.positions[3 * c]};
    float e1[3], e2[3], n[3], out[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = p[1][k] - p[0][k];
      e2[k] = p[2][k] - p[0][k];
      out[k] = (p[0][k] + p[1][k] + p[2][k]) / 3 - (k == 0 ? length / 2 : 0.0f);
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    if (n[0] * out[0] + n[1] * out[1] + n[2] * out[2] < 0) std::swap(b, c);
    g.indices.insert(g.indices.end(), {a, b, c});
  };
  for (uint32_t i = 0; i < uint32_t(segments); ++i)
    for (uint32_t k = 0; k < 4; ++k) {
      const uint32_t a = 4 * i + k, b = 4 * i + (k + 1) % 4, c = b + 4, d = a + 4;
      add(a, b, c);
      add(a, c, d);
    }
  const uint32_t last = 4 * uint32_t(segments);
  add(0, 1, 2), add(0, 2, 3), add(last, last + 1, last + 2), add(last, last + 2, last + 3);

  const int keys = int(std::ceil(sweep / 45.0f));  // each way
  const float seconds = sweep / 900.0f;             // each way
  GltfChannel shoulder{0, "rotation", "LINEAR", {}, {}};
  for (int k = 0; k <= 2 * keys; ++k) {
    const int out = k <= keys ? k : 2 * keys - k;
    shoulder.times.push_back(seconds * float(k) / float(keys));
    const auto q = about_y(180.0f + sweep * float(out) / float(keys));
    shoulder.values.insert(shoulder.values.end(), q.begin(), q.end());
  }
  GltfChannel elbow{1, "rotation", "LINEAR", {}, {}};
  for (int k = 0; k < 5; ++k) {
    elbow.times.push_back(seconds * 0.5f * float(k));
    const auto q = about_y(k % 2 ? 30.0f : 0.0f);
    elbow.values.insert(elbow.values.end(), q.begin(), q.end());
  }
  g.animations = {GltfAnimation{"swing", {shoulder, elbow}}};
  return g;
}

// A 0.5 m panel (6 x 6) falling from 0.3 m beside the arm of swinging_arm(135), which its transform
// turns, scales and moves; 0.2 s (frame 0 and 7 more). The glTF goes to `dir`.
inline SceneDef panel_beside_an_arm(const std::filesystem::path& dir, const std::string& name) {
  std::filesystem::create_directories(dir);
  const std::filesystem::path gltf = dir / "arm.gltf";
  write_skinned_gltf(gltf, swinging_arm(135.0f));
  SceneDef s = panel_scene(6, 0.5f, 0.3f);
  s.name = name;
  s.time.duration = 0.2;
  ObstacleDef arm;
  arm.name = "arm";
  arm.type = ObstacleType::Skinned;
  arm.file = gltf.string();
  arm.animation = "swing";
  arm.loop = false;
  arm.transform.position = {1.0f, 0.2f, -0.5f};
  arm.transform.rotation = {0, 30, 10};
  arm.transform.scale = {1.5f, 1.5f, 1.5f};
  s.obstacles.push_back(arm);
  return s;
}

// A directory of its own under the system's temporary directory, emptied first.
inline std::filesystem::path fresh_temp_dir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("raycloth_test_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace raycloth::test
