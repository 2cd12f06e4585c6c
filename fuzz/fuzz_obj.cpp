// OBJ obstacles: the bytes written to a file and read by load_obj_mesh, the one OBJ reader.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "fuzz_common.h"
#include "raycloth/error.h"
#include "scene/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/raycloth_fuzz_" + std::to_string(getpid()) + ".obj";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f || std::fwrite(data, 1, size, f) != size || std::fclose(f) != 0) std::abort();
  try {
    const raycloth::TriMesh m = raycloth::load_obj_mesh(path, "fuzz.json", "/obstacles/0/file");
    for (uint32_t i : m.indices)
      if (i >= m.vertices.size()) std::abort();
  } catch (const raycloth::InputError& e) {
    raycloth_fuzz::check_message(e.what(), "fuzz.json: /obstacles/0/file: OBJ file '" + path + "' ", std::string(reinterpret_cast<const char*>(data), size));
  }
  return 0;
}
