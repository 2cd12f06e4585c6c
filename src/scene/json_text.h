// nlohmann_json prefixes its messages with a tag ("[json.exception.parse_error.101] "); users get the
// message without it, whether it comes from the scene reader or through tinygltf.
#pragma once
#include <string>

namespace raycloth {

inline std::string without_json_exception_tags(std::string text) {
  for (auto at = text.find("[json.exception."); at != std::string::npos; at = text.find("[json.exception.", at)) {
    const auto close = text.find("] ", at);
    if (close == std::string::npos) break;
    text.erase(at, close + 2 - at);
  }
  return text;
}

}  // namespace raycloth
