#pragma once
// Reading a number out of a tool's JSON output in tests, without a JSON library: the value
// after the first "key": at or after `from`.

#include <cmath>
#include <string>

namespace tsc::testing_support {

/// NaN when the key is absent or its value is null (a figure with nothing to count).
inline double JsonNumberAt(const std::string& json, const std::string& key, size_t from = 0) {
  const size_t at = json.find("\"" + key + "\":", from);
  if (at == std::string::npos) return std::nan("");
  const size_t value = at + key.size() + 3;
  if (json.compare(value, 4, "null") == 0) return std::nan("");
  return std::stod(json.substr(value));
}

}  // namespace tsc::testing_support
