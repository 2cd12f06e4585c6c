#include "io/gltf_writer.h"

#include <fmt/format.h>
#include <tiny_gltf.h>

#include <cstring>
#include <limits>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/checkpoint.h"
#include "io/obj_writer.h"
#include "scene/transform.h"
#include "sim/model.h"

namespace raycloth {

namespace {

// Appends buffer views and accessors to one buffer.
class GltfBuilder {
 public:
  explicit GltfBuilder(tinygltf::Model& m) : m_(m) { m_.buffers.resize(1); }

  int vec3(const std::vector<Vec3>& v, bool min_max) {
    static_assert(sizeof(Vec3) == 12);
    tinygltf::Accessor a = make(view(v.data(), v.size() * sizeof(Vec3), TINYGLTF_TARGET_ARRAY_BUFFER),
                                TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, v.size());
    if (min_max) {
      Vec3 lo = v.empty() ? Vec3{} : v[0], hi = lo;
      for (const Vec3& p : v) lo = vmin(lo, p), hi = vmax(hi, p);
      a.minValues = {lo.x, lo.y, lo.z};
      a.maxValues = {hi.x, hi.y, hi.z};
    }
    return add(std::move(a));
  }
  // Animation data: `type` components per element (SCALAR, VEC3, VEC4).
  int floats(const std::vector<float>& v, int type, int components, bool min_max) {
    tinygltf::Accessor a = make(view(v.data(), v.size() * sizeof(float), 0), TINYGLTF_COMPONENT_TYPE_FLOAT, type,
                                v.size() / size_t(components));
    if (min_max && !v.empty()) {
      a.minValues.assign(size_t(components), std::numeric_limits<double>::max());
      a.maxValues.assign(size_t(components), std::numeric_limits<double>::lowest());
      for (size_t i = 0; i < v.size(); ++i) {
        double& lo = a.minValues[i % size_t(components)];
        double& hi = a.maxValues[i % size_t(components)];
        lo = std::min(lo, double(v[i]));
        hi = std::max(hi, double(v[i]));
      }
    }
    return add(std::move(a));
  }
  int indices(const std::vector<uint32_t>& v) {
    return add(make(view(v.data(), v.size() * sizeof(uint32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
                    TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, v.size()));
  }
  size_t bytes() const { return m_.buffers[0].data.size(); }

 private:
  int view(const void* src, size_t size, int target) {
    std::vector<unsigned char>& data = m_.buffers[0].data;
    tinygltf::BufferView bv;
    bv.buffer = 0;
    bv.byteOffset = data.size();
    bv.byteLength = size;
    bv.target = target;
    data.resize(data.size() + size);
    if (size) std::memcpy(data.data() + bv.byteOffset, src, size);
    data.resize((data.size() + 3) / 4 * 4);  // every accessor here has 4-byte components
    m_.bufferViews.push_back(std::move(bv));
    return int(m_.bufferViews.size() - 1);
  }
  static tinygltf::Accessor make(int view, int component, int type, size_t count) {
    tinygltf::Accessor a;
    a.bufferView = view;
    a.componentType = component;
    a.type = type;
    a.count = count;
    return a;
  }
  int add(tinygltf::Accessor a) {
    m_.accessors.push_back(std::move(a));
    return int(m_.accessors.size() - 1);
  }
  tinygltf::Model& m_;
};

int add_material(tinygltf::Model& m, const std::string& name, std::vector<double> color, double roughness,
                 bool double_sided) {
  tinygltf::Material mat;
  mat.name = name;
  mat.pbrMetallicRoughness.baseColorFactor = std::move(color);
  mat.pbrMetallicRoughness.metallicFactor = 0.0;
  mat.pbrMetallicRoughness.roughnessFactor = roughness;
  mat.doubleSided = double_sided;
  m.materials.push_back(std::move(mat));
  return int(m.materials.size() - 1);
}

void set_trs(tinygltf::Node& n, const TransformDef& td) {
  n.translation = {td.position[0], td.position[1], td.position[2]};
  const auto q = rotation_quaternion_xyz_degrees(td.rotation);
  n.rotation = {q[0], q[1], q[2], q[3]};
  n.scale = {td.scale[0], td.scale[1], td.scale[2]};
}

int add_channel(tinygltf::Animation& anim, int node, const std::string& path, int input, int output) {
  tinygltf::AnimationSampler s;
  s.input = input;
  s.output = output;
  s.interpolation = "LINEAR";
  anim.samplers.push_back(s);
  tinygltf::AnimationChannel c;
  c.sampler = int(anim.samplers.size() - 1);
  c.target_node = node;
  c.target_path = path;
  anim.channels.push_back(c);
  return c.sampler;
}

}  // namespace

void GlbSink::begin(Simulator&, const std::filesystem::path& out) { path_ = out / "cloth.glb"; }

void GlbSink::frame(Simulator& sim, const FrameRecord& r) {
  times_.push_back(r.time);
  frames_.push_back(sim.positions());
  bool any_skinned = false;
  for (const auto& sk : sim.obstacles().skinned) any_skinned = any_skinned || sk;
  if (any_skinned) obstacle_frames_.push_back(sim.obstacle_vertices());
}

// Checkpoints hold the frames kept so far.
void GlbSink::save(ByteWriter& out) {
  out.vec(times_);
  for (const auto& f : frames_) out.vec(f);
  out.u64(obstacle_frames_.size());
  for (const auto& f : obstacle_frames_) out.vec(f);
}

void GlbSink::resume(Simulator& sim, const std::filesystem::path& out, ByteReader& in) {
  begin(sim, out);
  in.vec(times_);
  frames_.resize(times_.size());
  for (auto& f : frames_) in.vec(f, sim.model().num_vertices(), "cloth vertices");
  obstacle_frames_.resize(in.u64());
  if (!obstacle_frames_.empty() && obstacle_frames_.size() != frames_.size()) in.fail("was written for other outputs");
  for (auto& f : obstacle_frames_) in.vec(f, sim.obstacles().world.vertices.size(), "obstacle vertices");
}

void GlbSink::end(Simulator& sim) {
  if (frames_.empty()) return;
  const ClothModel& model = sim.model();
  const ObstacleSet& obstacles = sim.obstacles();
  const size_t num_frames = frames_.size();
  const bool animated = num_frames > 1;

  tinygltf::Model g;
  g.asset.version = "2.0";
  g.asset.generator = "raycloth";
  GltfBuilder b(g);
  tinygltf::Scene scene;
  scene.name = sim.scene().name;
  tinygltf::Animation anim;
  anim.name = "simulation";

  std::vector<float> times(times_.begin(), times_.end());
  const int time_accessor = animated ? b.floats(times, TINYGLTF_TYPE_SCALAR, 1, true) : -1;
  int weights_accessor = -1;
  if (animated) {
    std::vector<float> w(num_frames * num_frames, 0.0f);  // key k selects target k
    for (size_t k = 0; k < num_frames; ++k) w[k * num_frames + k] = 1.0f;
    weights_accessor = b.floats(w, TINYGLTF_TYPE_SCALAR, 1, false);
  }
  tinygltf::Value::Array target_names;
  for (size_t k = 0; k < num_frames; ++k) target_names.emplace_back(fmt::format("frame_{:04d}", k));

  // Normals of every frame, computed once over the whole cloth.
  std::vector<std::vector<Vec3>> normals(num_frames);
  for (size_t k = 0; k < num_frames; ++k) normals[k] = cloth_vertex_normals(model, frames_[k]);

  const int cloth_material = add_material(g, "cloth", {0.80, 0.30, 0.22, 1.0}, 0.9, true);
  for (const Piece& piece : model.pieces) {
    const uint32_t first = piece.first_vertex, count = piece.num_vertices();
    auto slice = [&](const std::vector<Vec3>& v) {
      return std::vector<Vec3>(v.begin() + first, v.begin() + first + count);
    };
    std::vector<uint32_t> idx(model.triangles.begin() + 3 * piece.first_triangle,
                              model.triangles.begin() + 3 * (piece.first_triangle + piece.num_triangles));
    for (uint32_t& i : idx) {
      if (i < first || i >= first + count)
        throw std::logic_error(fmt::format("panel '{}': triangle corner {} outside its vertices", piece.name, i));
      i -= first;
    }
    const std::vector<Vec3> base_x = slice(frames_[0]), base_n = slice(normals[0]);
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = cloth_material;
    prim.attributes["POSITION"] = b.vec3(base_x, true);
    prim.attributes["NORMAL"] = b.vec3(base_n, false);
    prim.indices = b.indices(idx);
    tinygltf::Mesh mesh;
    mesh.name = piece.name;
    if (animated) {
      std::vector<Vec3> dx(count), dn(count);
      for (size_t k = 0; k < num_frames; ++k) {
        for (uint32_t i = 0; i < count; ++i) {
          dx[i] = frames_[k][first + i] - base_x[i];
          dn[i] = normals[k][first + i] - base_n[i];
        }
        prim.targets.push_back({{"POSITION", b.vec3(dx, true)}, {"NORMAL", b.vec3(dn, false)}});
      }
      mesh.weights.assign(num_frames, 0.0);
      mesh.extras = tinygltf::Value(tinygltf::Value::Object{{"targetNames", tinygltf::Value(target_names)}});
    }
    mesh.primitives.push_back(std::move(prim));
    g.meshes.push_back(std::move(mesh));
    tinygltf::Node node;
    node.name = piece.name;
    node.mesh = int(g.meshes.size() - 1);
    g.nodes.push_back(std::move(node));
    const int n = int(g.nodes.size() - 1);
    scene.nodes.push_back(n);
    if (animated) add_channel(anim, n, "weights", time_accessor, weights_accessor);
  }

  const int obstacle_material =
      obstacles.names.empty() ? -1 : add_material(g, "obstacle", {0.60, 0.62, 0.66, 1.0}, 0.7, false);
  for (size_t o = 0; o < obstacles.names.size(); ++o) {
    const TriMesh& local = obstacles.local[o];
    if (obstacles.skinned[o] && obstacle_frames_.size() == num_frames) {
      // World space, posed per frame: frame 0's vertices, morph target k holds frame k.
      const size_t first = obstacles.first_vertex[o], count = local.vertices.size();
      auto slice = [&](size_t k) {
        return std::vector<Vec3>(obstacle_frames_[k].begin() + long(first), obstacle_frames_[k].begin() + long(first + count));
      };
      const std::vector<Vec3> base = slice(0);
      tinygltf::Primitive prim;
      prim.mode = TINYGLTF_MODE_TRIANGLES;
      prim.material = obstacle_material;
      prim.attributes["POSITION"] = b.vec3(base, true);
      prim.indices = b.indices(local.indices);
      tinygltf::Mesh mesh;
      mesh.name = obstacles.names[o];
      if (animated) {
        std::vector<Vec3> dx(count);
        for (size_t k = 0; k < num_frames; ++k) {
          const std::vector<Vec3> posed = slice(k);
          for (size_t i = 0; i < count; ++i) dx[i] = posed[i] - base[i];
          prim.targets.push_back({{"POSITION", b.vec3(dx, true)}});
        }
        mesh.weights.assign(num_frames, 0.0);
        mesh.extras = tinygltf::Value(tinygltf::Value::Object{{"targetNames", tinygltf::Value(target_names)}});
      }
      mesh.primitives.push_back(std::move(prim));
      g.meshes.push_back(std::move(mesh));
      tinygltf::Node node;
      node.name = obstacles.names[o];
      node.mesh = int(g.meshes.size() - 1);
      g.nodes.push_back(std::move(node));
      const int n = int(g.nodes.size() - 1);
      scene.nodes.push_back(n);
      if (animated) add_channel(anim, n, "weights", time_accessor, weights_accessor);
      continue;
    }
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = obstacle_material;
    prim.attributes["POSITION"] = b.vec3(local.vertices, true);
    prim.indices = b.indices(local.indices);
    tinygltf::Mesh mesh;
    mesh.name = obstacles.names[o];
    mesh.primitives.push_back(std::move(prim));
    g.meshes.push_back(std::move(mesh));
    tinygltf::Node node;
    node.name = obstacles.names[o];
    node.mesh = int(g.meshes.size() - 1);
    const ObstacleDef& def = obstacles.defs[o];
    set_trs(node, transform_at(def, times_[0]));
    g.nodes.push_back(std::move(node));
    const int n = int(g.nodes.size() - 1);
    scene.nodes.push_back(n);
    if (animated && def.motion) {
      std::vector<float> translation, rotation;
      for (double t : times_) {
        const TransformDef td = transform_at(def, t);
        translation.insert(translation.end(), td.position.begin(), td.position.end());
        const auto q = rotation_quaternion_xyz_degrees(td.rotation);
        rotation.insert(rotation.end(), q.begin(), q.end());
      }
      add_channel(anim, n, "translation", time_accessor, b.floats(translation, TINYGLTF_TYPE_VEC3, 3, false));
      add_channel(anim, n, "rotation", time_accessor, b.floats(rotation, TINYGLTF_TYPE_VEC4, 4, false));
    }
  }

  // A .glb chunk length is a 32-bit count of bytes.
  if (b.bytes() > 0xFFFFFF00u)
    throw std::runtime_error(fmt::format("{}: {} frames of {} vertices need {:.1f} GB, more than a .glb holds "
                                         "(4 GB); write pc2 or ply instead, or fewer frames",
                                         path_.string(), num_frames, model.num_vertices(), b.bytes() / 1e9));
  g.buffers[0].name = "data";
  g.scenes.push_back(std::move(scene));
  g.defaultScene = 0;
  if (animated) g.animations.push_back(std::move(anim));

  tinygltf::TinyGLTF writer;
  write_file_atomically(path_, [&](std::ostream& out) {
    if (!writer.WriteGltfSceneToStream(&g, out, false, true))
      throw std::runtime_error(path_.string() + ": the glTF writer failed");
  });
  frames_.clear();
  obstacle_frames_.clear();
  times_.clear();
}

}  // namespace raycloth
