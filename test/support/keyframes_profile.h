#pragma once
// The shipped parameter set for sparse keyframe sequences (config/keyframes.ini): the real
// loop and the tests' small hand-made datasets, whose places span a handful of frames.

#include <filesystem>

#include "daemon/settings.h"

namespace tsc::testing_support {

inline std::filesystem::path KeyframesConfig() {
  return std::filesystem::path(TSCD_SOURCE_DIR) / "config" / "keyframes.ini";
}

inline PipelineOptions KeyframesProfile() { return LoadPipelineOptions(KeyframesConfig(), {}); }

}  // namespace tsc::testing_support
