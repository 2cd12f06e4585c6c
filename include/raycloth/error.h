// Errors the library reports: always with where (file, JSON path or step) and why.
#pragma once
#include <stdexcept>
#include <string>

namespace raycloth {

// Bad input: a scene or mesh file, a field in it, and the reason.
class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string field, std::string reason)
      : std::runtime_error(format(file, field, reason)),
        file_(std::move(file)), field_(std::move(field)), reason_(std::move(reason)) {}
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }
  const std::string& reason() const { return reason_; }

 private:
  static std::string format(const std::string& file, const std::string& field, const std::string& reason) {
    std::string s = file.empty() ? std::string("<scene>") : file;
    if (!field.empty()) s += ": " + field;
    return s + ": " + reason;
  }
  std::string file_, field_, reason_;
};

// A simulation that cannot go on: unstable time step, a blow-up during the run.
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace raycloth
