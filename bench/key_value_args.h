#pragma once
// The command line of the whole-program measurements (tscd_loop_latency, tscd_footprint):
// "--key value" pairs, each key one of those the program takes.

#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>
#include <string>

namespace tsc {

/// The pairs of `argv` by key (without the dashes); nullopt, after printing `usage` on stderr,
/// for a key not in `keys` or a key without a value.
inline std::optional<std::map<std::string, std::string>> KeyValueArgs(
    int argc, char** argv, const std::set<std::string>& keys, const char* usage) {
  std::map<std::string, std::string> values;
  for (int i = 1; i < argc; i += 2) {
    const std::string key = argv[i];
    if (i + 1 >= argc || key.rfind("--", 0) != 0 || !keys.count(key.substr(2))) {
      std::fprintf(stderr, "usage: %s %s\n", argv[0], usage);
      return std::nullopt;
    }
    values[key.substr(2)] = argv[i + 1];
  }
  return values;
}

/// The value of `key` as a number, or `fallback` when it was not given.
inline double NumberArg(const std::map<std::string, std::string>& values, const std::string& key,
                        double fallback) {
  const auto it = values.find(key);
  return it == values.end() ? fallback : std::atof(it->second.c_str());
}

}  // namespace tsc
