#include "render/image_frames.h"

#include "scene/mesh.h"


#include <cerrno>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/checkpoint.h"
#include "raycloth/error.h"

namespace raycloth {

namespace fs = std::filesystem;

namespace {

void make_images_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir.string() + ": cannot create the images folder: " + ec.message());
}

struct ObjMesh {
  std::vector<Vec3> vertices;
  std::vector<uint32_t> indices, object;  // object: index of each triangle's `o` group
};

ObjMesh read_obj(const fs::path& path, const char* why_needed = "") {
  ObjTriangles obj = read_obj_triangles(path.string(), [&](const std::string& reason) {
    throw InputError(path.string(), "", reason == "does not exist" ? reason + why_needed : reason);
  });
  ObjMesh m;
  m.vertices = std::move(obj.vertices);
  m.indices = std::move(obj.indices);
  for (size_t g = 0; g < obj.group_first_triangle.size(); ++g) {
    const uint32_t end = g + 1 < obj.group_first_triangle.size() ? obj.group_first_triangle[g + 1]
                                                                  : uint32_t(m.indices.size() / 3);
    m.object.insert(m.object.end(), end - obj.group_first_triangle[g], uint32_t(g));
  }
  return m;
}

template <class T>
T field(const nlohmann::json& j, const char* name, const std::string& file) {
  if (!j.contains(name)) throw InputError(file, std::string("/") + name, "missing required field");
  try {
    return j.at(name).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(file, std::string("/") + name, std::string("unexpected type ") + j.at(name).type_name());
  }
}

}  // namespace

void ImageFrames::begin(Simulator&, const fs::path& out_dir) {
  dir_ = out_dir / "images";
  make_images_dir(dir_);
}

void ImageFrames::frame(Simulator& sim, const FrameRecord& record) {
  const RenderScene scene = make_render_scene(sim);
  seen_.add(scene.bounds());
  write_png(dir_ / frame_name("frame", record.index, "png"), renderer_.render(scene, make_view(seen_, camera_)));
  ++written_;
}

// The view follows everything seen so far: a resumed run continues from the same bounds.
void ImageFrames::save(ByteWriter& out) {
  out.pod(seen_);
  out.u32(uint32_t(written_));
}

void ImageFrames::resume(Simulator& sim, const fs::path& out_dir, ByteReader& in) {
  begin(sim, out_dir);
  in.pod(seen_);
  written_ = int(in.u32());
}

OutputFolder read_output_folder(const fs::path& dir) {
  const fs::path path = dir / "run.json";
  std::ifstream in(path);
  if (!in)
    throw InputError(path.string(), "", std::string("cannot open: ") + std::strerror(errno) +
                                            " (is it an output folder of raycloth run?)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path.string(), "", std::string("not valid JSON: ") + e.what());
  }
  OutputFolder f;
  f.dir = dir;
  f.fps = j.contains("fps") ? field<double>(j, "fps", path.string()) : 30.0;
  for (const auto& frame : field<nlohmann::json>(j, "frames", path.string())) {
    if (!frame.is_object() || !frame.contains("index") || !frame["index"].is_number_integer())
      throw InputError(path.string(), "/frames", "each frame needs an integer index");
    f.frames.push_back(frame["index"].get<int>());
  }
  if (f.frames.empty()) throw InputError(path.string(), "/frames", "the run has no frames");
  if (j.contains("camera")) {
    // Written by run_scene with the scene file's field names.
    try {
      const nlohmann::json& c = j["camera"];
      CameraDef cam;
      if (c.contains("position")) cam.position = c["position"].get<Float3>();
      if (c.contains("target")) cam.target = c["target"].get<Float3>();
      if (c.contains("fov")) cam.fov = c["fov"].get<float>();
      if (c.contains("resolution")) cam.width = c["resolution"][0].get<int>(), cam.height = c["resolution"][1].get<int>();
      if (c.contains("samples")) cam.samples = c["samples"].get<int>();
      f.camera = cam;
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string(), "/camera", std::string("malformed: ") + e.what());
    }
    OutputDef o;
    o.camera = f.camera;
    validate_output(o, path.string());
  }
  return f;
}

RenderScene read_output_frame(const OutputFolder& folder, int index) {
  RenderScene s;
  ObjMesh cloth = read_obj(folder.dir / "frames" / frame_name("cloth", index, "obj"),
                           " (rendering a folder needs the run's OBJ frames, output format obj)");
  s.cloth_vertices = std::move(cloth.vertices);
  s.cloth_indices = std::move(cloth.indices);
  s.cloth_panel = std::move(cloth.object);
  fs::path obstacles = folder.dir / "frames" / frame_name("obstacles", index, "obj");
  if (!fs::exists(obstacles)) obstacles = folder.dir / "obstacles.obj";
  if (fs::exists(obstacles)) {
    ObjMesh o = read_obj(obstacles);
    s.obstacle_vertices = std::move(o.vertices);
    s.obstacle_indices = std::move(o.indices);
  }
  return s;
}

void render_output_folder(const OutputFolder& folder, const CameraDef& camera,
                          const std::function<void(int, int)>& progress) {
  const fs::path images = folder.dir / "images";
  make_images_dir(images);
  Renderer renderer;
  Bounds seen;
  const int total = int(folder.frames.size());
  for (int i = 0; i < total; ++i) {
    const RenderScene scene = read_output_frame(folder, folder.frames[i]);
    seen.add(scene.bounds());
    write_png(images / frame_name("frame", folder.frames[i], "png"), renderer.render(scene, make_view(seen, camera)));
    if (progress) progress(i + 1, total);
  }
}

}  // namespace raycloth
