// Checkpoints of a run (OUT/checkpoint.bin): everything a step reads that is not a pure function of
// the scene and the time, the counters and frame records that go into run.json, and what the output
// sinks keep in memory, so that `raycloth run ... --resume` (or `raycloth resume DIR`) continues an
// interrupted run to the same bytes as an uninterrupted one.
//
// The file: a header (magic, format version, raycloth version, a hash of the scene file and of every
// mesh it uses, the run's settings, the command that started it) and the state, as length-prefixed
// little-endian records, then a 64-bit hash of everything before it. It is written atomically.
#pragma once
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "raycloth/scene.h"

namespace raycloth {

inline constexpr uint32_t kCheckpointFormat = 1;
inline constexpr const char* kCheckpointName = "checkpoint.bin";

// raycloth's version (CMake's project version).
std::string raycloth_version();
// The text of the built-in default scene (scenes/seed_drape.json, compiled in).
std::string_view default_scene_text();

// FNV-1a, 64 bits.
uint64_t hash_bytes(std::string_view bytes, uint64_t h = 14695981039346656037ull);

// What identifies the scene: its text (the file's bytes, or the built-in text when `scene_text` is
// empty and the scene has no readable file) and the bytes of every mesh or glTF file it uses.
uint64_t scene_fingerprint(const SceneDef& scene, const std::string& scene_text);

class ByteWriter {
 public:
  void u32(uint32_t v) { raw(&v, sizeof v); }
  void u64(uint64_t v) { raw(&v, sizeof v); }
  void f64(double v) { raw(&v, sizeof v); }
  void str(std::string_view s) {
    u64(s.size());
    bytes_.append(s.data(), s.size());
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    u64(v.size());
    raw(v.data(), v.size() * sizeof(T));
  }
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    raw(&v, sizeof(T));
  }
  const std::string& bytes() const { return bytes_; }
  std::string& bytes() { return bytes_; }

 private:
  void raw(const void* p, size_t n) { bytes_.append(static_cast<const char*>(p), n); }
  std::string bytes_;
};

// Reads what ByteWriter wrote; a record that runs past the end throws InputError naming `file`.
class ByteReader {
 public:
  ByteReader(std::string_view data, std::string file) : data_(data), file_(std::move(file)) {}
  uint32_t u32() { return scalar<uint32_t>(); }
  uint64_t u64() { return scalar<uint64_t>(); }
  double f64() { return scalar<double>(); }
  std::string str() {
    const uint64_t n = u64();
    need(n);
    std::string s(data_.substr(at_, n));
    at_ += n;
    return s;
  }
  template <class T>
  void vec(std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const uint64_t n = u64();
    if (n > (data_.size() - at_) / sizeof(T)) fail_truncated();
    v.resize(n);
    std::memcpy(v.data(), data_.data() + at_, n * sizeof(T));
    at_ += n * sizeof(T);
  }
  // A vector that must have `count` elements (the model's vertex count...).
  template <class T>
  void vec(std::vector<T>& v, size_t count, const char* what) {
    vec(v);
    if (v.size() != count) fail(std::string("holds ") + std::to_string(v.size()) + " " + what + ", the run has " + std::to_string(count));
  }
  template <class T>
  void pod(T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T));
    std::memcpy(&v, data_.data() + at_, sizeof(T));
    at_ += sizeof(T);
  }
  bool at_end() const { return at_ == data_.size(); }
  [[noreturn]] void fail(const std::string& reason) const;

 private:
  template <class T>
  T scalar() {
    T v;
    pod(v);
    return v;
  }
  void need(uint64_t n) const {
    if (n > data_.size() - at_) fail_truncated();
  }
  [[noreturn]] void fail_truncated() const;
  std::string_view data_;
  size_t at_ = 0;
  std::string file_;
};

struct CheckpointHeader {
  uint32_t format = 0;
  std::string version;
  uint64_t scene_hash = 0;
  std::string settings;    // JSON: what must match for a resume (formats, duration, device, ...)
  std::string invocation;  // JSON: how the run was started (the CLI's `resume DIR` reads it)
};

// Writes header + state + hash to DIR/checkpoint.bin atomically.
void write_checkpoint(const std::filesystem::path& dir, const CheckpointHeader& header, const std::string& state);
// Reads DIR/checkpoint.bin: checks the magic, the format, the version and the trailing hash, and
// returns the header and the state bytes. Throws InputError naming the file (missing, not a
// checkpoint, damaged, from another format or raycloth version).
struct CheckpointFile {
  CheckpointHeader header;
  std::string state;
};
CheckpointFile read_checkpoint(const std::filesystem::path& dir);

}  // namespace raycloth
