#include "io/checkpoint.h"

#include <cerrno>
#include <fstream>
#include <sstream>

#include "io/atomic_file.h"
#include "raycloth/error.h"

#ifndef RAYCLOTH_VERSION
#define RAYCLOTH_VERSION "unknown"
#endif

namespace raycloth {

namespace {
constexpr std::string_view kMagic = "RAYCLOTH CHECKPOINT\n";

std::string read_all(const std::filesystem::path& path, bool& ok) {
  std::ifstream in(path, std::ios::binary);
  ok = bool(in);
  if (!ok) return {};
  std::ostringstream s;
  s << in.rdbuf();
  ok = !in.bad();
  return s.str();
}
}  // namespace

std::string raycloth_version() { return RAYCLOTH_VERSION; }

uint64_t hash_bytes(std::string_view bytes, uint64_t h) {
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

uint64_t scene_fingerprint(const SceneDef& scene, const std::string& scene_text) {
  uint64_t h = hash_bytes("scene");
  if (!scene_text.empty()) {
    h = hash_bytes(scene_text, h);
  } else {
    bool ok = false;
    std::string text = scene.source.empty() ? std::string() : read_all(scene.source, ok);
    h = hash_bytes(ok ? std::string_view(text) : default_scene_text(), h);
  }
  for (const ObstacleDef& o : scene.obstacles) {
    if (o.file.empty()) continue;
    bool ok = false;
    const std::string bytes = read_all(o.file, ok);
    h = hash_bytes(bytes, hash_bytes(ok ? "file" : "missing file", h));
  }
  return h;
}


void write_checkpoint(const std::filesystem::path& dir, const CheckpointHeader& header, const std::string& state) {
  ByteWriter w;
  w.bytes().append(kMagic);
  w.u32(header.format);
  w.str(header.version);
  w.u64(header.scene_hash);
  w.str(header.settings);
  w.str(header.invocation);
  w.str(state);
  w.u64(hash_bytes(w.bytes()));
  write_file_atomically(dir / kCheckpointName, [&](std::ostream& out) {
    out.write(w.bytes().data(), std::streamsize(w.bytes().size()));
  });
}

CheckpointFile read_checkpoint(const std::filesystem::path& dir) {
  const std::filesystem::path path = dir / kCheckpointName;
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw InputError(file, "", "no checkpoint to resume from (the run finished, or never wrote one)");
  bool ok = false;
  const std::string bytes = read_all(path, ok);
  if (!ok) throw InputError(file, "", std::string("cannot read the checkpoint: ") + std::strerror(errno));
  if (bytes.compare(0, kMagic.size(), kMagic) != 0) throw InputError(file, "", "is not a raycloth checkpoint");
  if (bytes.size() < kMagic.size() + 8) throw InputError(file, "", "is truncated or damaged; start the run again without --resume");
  ByteReader trailer(std::string_view(bytes).substr(bytes.size() - 8), file);
  ByteReader r(std::string_view(bytes).substr(kMagic.size(), bytes.size() - 8 - kMagic.size()), file);
  CheckpointFile c;
  c.header.format = r.u32();
  if (c.header.format != kCheckpointFormat)
    throw InputError(file, "", "was written in checkpoint format " + std::to_string(c.header.format) +
                                   ", this raycloth reads format " + std::to_string(kCheckpointFormat) +
                                   "; start the run again without --resume");
  c.header.version = r.str();
  if (c.header.version != raycloth_version())
    throw InputError(file, "", "was written by raycloth " + c.header.version + ", this is raycloth " +
                                   raycloth_version() + "; start the run again without --resume");
  if (trailer.u64() != hash_bytes(std::string_view(bytes).substr(0, bytes.size() - 8)))
    throw InputError(file, "", "is truncated or damaged; start the run again without --resume");
  c.header.scene_hash = r.u64();
  c.header.settings = r.str();
  c.header.invocation = r.str();
  c.state = r.str();
  if (!r.at_end()) throw InputError(file, "", "is truncated or damaged; start the run again without --resume");
  return c;
}

}  // namespace raycloth
