// Scene files: parse_scene on arbitrary text (pattern outlines, once scenes hold them, too).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    raycloth::parse_scene(text, "fuzz.json");
  } catch (const raycloth::InputError& e) {
    raycloth_fuzz::check_message(e.what(), "fuzz.json: ", text);
  }
  return 0;  // any other exception escapes and libFuzzer reports it
}
