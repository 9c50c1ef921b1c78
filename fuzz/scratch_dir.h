#pragma once
// A folder of scratch files for one fuzzing process, named by its fixed-width pid (so runs
// of one seed take the same paths, fuzz/short_run.sh), emptied when made and removed when the
// process exits.

#include <filesystem>
#include <string>
#include <system_error>

#include "fuzz/fuzz_target.h"

namespace tsc::fuzz {

class ScratchDir {
 public:
  explicit ScratchDir(const std::string& prefix)
      : path_(std::filesystem::temp_directory_path() / (prefix + "-" + FixedWidthPid())) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace tsc::fuzz
