// JSON text of a value for output (--json, provenance, manifests) that never fails on a string
// holding bytes that are not UTF-8 (a file's name as the file system gives it): each such byte
// becomes U+FFFD, the replacement character, where nlohmann's own dump would throw.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace basis {

// indent < 0: one line; otherwise that many spaces per level. For nlohmann::json and
// nlohmann::ordered_json alike.
template <typename Json>
std::string json_text(const Json& value, int indent = -1) {
  return value.dump(indent, ' ', false, Json::error_handler_t::replace);
}

// Whether JSON can hold `text` as itself (it is UTF-8): what files that must name other files
// exactly (manifests, capture recipes) check before writing.
inline bool json_holds_exactly(const std::string& text) {
  try {
    static_cast<void>(nlohmann::json(text).dump());
    return true;
  } catch (const nlohmann::json::type_error&) {
    return false;
  }
}

}  // namespace basis
