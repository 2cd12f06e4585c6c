// Typed reading of JSON values for the scene reader: each read checks the value's type (and, for
// numbers, its range) and throws InputError naming the file, the JSON pointer of the field and the
// reason; an object's keys must all be known, so that a typo is an error, not a silent default.
#pragma once
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>

#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "scene/json_text.h"

namespace raycloth::scene_json {

// Shortest form of a number that reads back the same in a message: 0.75, -1, 1e+39.
inline std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

template <class T, size_t N>
std::string num_list(const std::array<T, N>& a) {
  std::string s = "[";
  for (size_t i = 0; i < N; ++i) s += (i ? ", " : "") + num(double(a[i]));
  return s + "]";
}

// Reads the values of one JSON document; `file` names it in errors.
class JsonFields {
 public:
  using json = nlohmann::json;

  explicit JsonFields(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }

  [[noreturn]] void fail(const std::string& field, const std::string& reason) const {
    throw InputError(file_, field, reason);
  }

  // An object whose keys must all be in `allowed`: a typo is an error, not a silent default.
  void object(const json& j, const std::string& ptr, std::initializer_list<std::string_view> allowed) const {
    if (!j.is_object()) fail(ptr, std::string("expected an object, got ") + j.type_name());
    for (const auto& [key, value] : j.items()) {
      bool known = false;
      for (auto a : allowed) known = known || key == a;
      if (!known) fail(ptr + "/" + json_pointer_token(key), "unknown field '" + key + "'");
    }
  }

  template <class F>
  void optional(const json& obj, const std::string& ptr, const char* key, F&& read) const {
    const auto it = obj.find(key);
    if (it != obj.end()) read(*it, ptr + "/" + key);
  }

  template <class F>
  void required(const json& obj, const std::string& ptr, const char* key, F&& read) const {
    const auto it = obj.find(key);
    if (it == obj.end()) fail(ptr + "/" + key, "missing required field");
    read(*it, ptr + "/" + key);
  }

  // An array of objects under `key`, each read by `read(value, pointer, index)`.
  template <class F>
  void list(const json& obj, const std::string& ptr, const char* key, bool need_one, F&& read) const {
    const std::string p = ptr + "/" + key;
    const auto it = obj.find(key);
    if (it == obj.end()) {
      if (need_one) fail(p, "missing required field");
      return;
    }
    if (!it->is_array()) fail(p, std::string("expected an array, got ") + it->type_name());
    if (need_one && it->empty()) fail(p, "needs at least one entry");
    for (size_t i = 0; i < it->size(); ++i) read((*it)[i], p + "/" + std::to_string(i), i);
  }

  double number(const json& j, const std::string& ptr) const {
    if (!j.is_number()) fail(ptr, std::string("expected a number, got ") + j.type_name());
    return j.get<double>();
  }

  float number_f(const json& j, const std::string& ptr) const {
    const double v = number(j, ptr);
    if (std::abs(v) > double(std::numeric_limits<float>::max())) fail(ptr, "is out of range (got " + num(v) + ")");
    return float(v);
  }

  int integer(const json& j, const std::string& ptr) const {
    if (!j.is_number()) fail(ptr, std::string("expected an integer, got ") + j.type_name());
    const double v = j.get<double>();
    if (v != std::floor(v)) fail(ptr, "expected an integer, got " + num(v));
    if (v < double(std::numeric_limits<int>::min()) || v > double(std::numeric_limits<int>::max()))
      fail(ptr, "is out of range (got " + num(v) + ")");
    return int(v);
  }

  bool boolean(const json& j, const std::string& ptr) const {
    if (!j.is_boolean()) fail(ptr, std::string("expected true or false, got ") + j.type_name());
    return j.get<bool>();
  }

  std::string string(const json& j, const std::string& ptr) const {
    if (!j.is_string()) fail(ptr, std::string("expected a string, got ") + j.type_name());
    return j.get<std::string>();
  }

  // A fixed-length array, each element read by `read`.
  template <class T, size_t N, class F>
  std::array<T, N> fixed(const json& j, const std::string& ptr, const char* what, F&& read) const {
    if (!j.is_array())
      fail(ptr, "expected an array of " + std::to_string(N) + " " + what + ", got " + j.type_name());
    if (j.size() != N)
      fail(ptr, "expected " + std::to_string(N) + " " + what + ", got " + std::to_string(j.size()));
    std::array<T, N> a{};
    for (size_t i = 0; i < N; ++i) a[i] = read(j[i], ptr + "/" + std::to_string(i));
    return a;
  }

  Float3 float3(const json& j, const std::string& ptr) const {
    return fixed<float, 3>(j, ptr, "numbers", [&](const json& v, const std::string& p) { return number_f(v, p); });
  }
  std::array<float, 2> float2(const json& j, const std::string& ptr) const {
    return fixed<float, 2>(j, ptr, "numbers", [&](const json& v, const std::string& p) { return number_f(v, p); });
  }
  std::array<int, 2> int2(const json& j, const std::string& ptr) const {
    return fixed<int, 2>(j, ptr, "integers", [&](const json& v, const std::string& p) { return integer(v, p); });
  }

 private:
  std::string file_;
};

}  // namespace raycloth::scene_json
