// Length-prefixed little-endian records in memory: what the step's state and the run's records are
// written as in a checkpoint (io/checkpoint.h), kept below every module that saves state.
#pragma once
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace raycloth {

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
  void raw(const void* p, size_t n) {
    if (n > 0) bytes_.append(static_cast<const char*>(p), n);  // an empty vector's data() may be null
  }
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
    if (n > 0) std::memcpy(v.data(), data_.data() + at_, n * sizeof(T));  // an empty vector's data() may be null
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

}  // namespace raycloth
