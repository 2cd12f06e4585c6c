// Text of JSON shared by the readers (scene files, GarmentCode, glTF) and the batch: the JSON
// pointer token of a key, for the field names in messages, and nlohmann_json's messages without
// their tags.
#pragma once
#include <string>
#include <string_view>

namespace raycloth {

// A key as a JSON pointer token (RFC 6901): '~' -> "~0", '/' -> "~1".
inline std::string json_pointer_token(std::string_view key) {
  std::string s;
  for (char c : key) {
    if (c == '~') s += "~0";
    else if (c == '/') s += "~1";
    else s += c;
  }
  return s;
}

// nlohmann_json prefixes its messages with a tag ("[json.exception.parse_error.101] "); users get the
// message without it, whether it comes from the scene reader or through tinygltf.
inline std::string without_json_exception_tags(std::string text) {
  for (auto at = text.find("[json.exception."); at != std::string::npos; at = text.find("[json.exception.", at)) {
    const auto close = text.find("] ", at);
    if (close == std::string::npos) break;
    text.erase(at, close + 2 - at);
  }
  return text;
}

}  // namespace raycloth
