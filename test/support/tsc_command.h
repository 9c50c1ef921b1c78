#pragma once
// Running the `tsc` tool from a test, as a user would from a shell, and reading what it wrote.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace tsc::testing_support {

/// The whole of a text file ("" when it cannot be read).
inline std::string ReadFile(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `s` as one single-quoted shell word.
inline std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct TscOutcome {
  int code = -1;  ///< exit code, −1 when killed by a signal
  std::string out;
  std::string err;
};

/// Runs `tsc ARGS` (ARGS already quoted as the shell needs) with stdin closed and stdout and
/// stderr captured through files in `scratch`.
inline TscOutcome RunTsc(const std::filesystem::path& scratch, const std::string& args) {
  const std::filesystem::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  const std::string cmd = Quote(std::string(TSCD_BIN_DIR) + "/tsc") + " " + args + " >" +
                          Quote(out.string()) + " 2>" + Quote(err.string()) + " </dev/null";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ReadFile(out), ReadFile(err)};
}

}  // namespace tsc::testing_support
