// Skinned glTF bodies: the bytes written to a .glb (when they start with the GLB magic) or .gltf
// file, read by load_skinned_mesh, then posed once mid-animation as the simulator does.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "fuzz_common.h"
#include "raycloth/error.h"
#include "scene/skinned_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  static const std::string base = "/tmp/raycloth_fuzz_" + std::to_string(getpid());
  const std::string path = base + (binary ? ".glb" : ".gltf");
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f || std::fwrite(data, 1, size, f) != size || std::fclose(f) != 0) std::abort();
  const auto fail = [](const std::string& field, const std::string& reason) {
    throw raycloth::InputError("fuzz.json", "/obstacles/0/" + field, reason);
  };
  try {
    const raycloth::SkinnedMesh m = raycloth::load_skinned_mesh(path, "", fail);
    for (uint32_t i : m.indices)
      if (i >= m.vertices.size()) std::abort();
    std::vector<raycloth::Vec3> posed;
    m.skin(m.joint_matrices(m.sample(0.5f * (m.start + m.end), 1.0f)), posed);
  } catch (const raycloth::InputError& e) {
    raycloth_fuzz::check_message(e.what(), "fuzz.json: /obstacles/0/", std::string(reinterpret_cast<const char*>(data), size));
  }
  return 0;
}
