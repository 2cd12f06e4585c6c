// What every harness checks: a bad input ends in an InputError whose message reads
// "FILE: FIELD: REASON" in the project's words, never another exception or a library's own text.
#pragma once
#include <cstdio>
#include <cstdlib>
#include <string>

namespace raycloth_fuzz {

// `input` is the text read: a tag that it holds itself may come back quoted in a message.
inline void check_message(const std::string& message, const std::string& prefix, const std::string& input) {
  const char* bad = nullptr;
  if (message.rfind(prefix, 0) != 0) bad = "does not start with the file name";
  // Internal texts of the libraries the readers use.
  for (const char* tag : {"[json.exception", "basic_string", "std::", "vector::", "stoi", "stod", "bad_alloc"})
    if (message.find(tag) != std::string::npos && input.find(tag) == std::string::npos) bad = "contains a library's internal text";
  if (bad) {
    std::fprintf(stderr, "bad error message (%s): %s\n", bad, message.c_str());
    std::abort();
  }
}

}  // namespace raycloth_fuzz
