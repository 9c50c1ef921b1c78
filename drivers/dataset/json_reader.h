#pragma once
// A small reader for plain JSON (objects, arrays, strings, numbers, true/false/null; escapes are
// kept as the escaped character, \u is not decoded; nesting up to 64). Enough for camera.json
// and world.json; no dependency.

#include <string>
#include <vector>

namespace tsc {

struct JsonValue {
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };
  Kind kind = Kind::kNull;
  double number = 0.0;
  bool boolean = false;
  std::string text;
  std::vector<JsonValue> items;   ///< array elements or object values
  std::vector<std::string> keys;  ///< object keys, parallel to items

  /// The value of `key` in an object, or nullptr.
  const JsonValue* Find(const std::string& key) const;
};

/// Parses `text`. Throws std::runtime_error("invalid JSON at byte N: ...").
JsonValue ParseJson(const std::string& text);

}  // namespace tsc
