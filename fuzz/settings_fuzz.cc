// Fuzz target: a configuration file (settings/settings.h), as tscd and tsc read it with --config.
// Any input must either load and validate or be refused with a ConfigError.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "fuzz/fuzz_target.h"
#include "settings/settings.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The parser reads files: one per process, rewritten for every input, removed at exit.
  struct Scratch {
    std::filesystem::path file = std::filesystem::temp_directory_path() /
                                 ("tscd-settings-fuzz-" + tsc::fuzz::FixedWidthPid() + ".ini");
    ~Scratch() {
      std::error_code ec;
      std::filesystem::remove(file, ec);
    }
  };
  static const Scratch scratch;
  const std::filesystem::path& file = scratch.file;
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    (void)tsc::LoadSettings(file, {});
  } catch (const tsc::ConfigError&) {
  }
  // The same text as --set overrides, one per line, applied in order to one Settings as a
  // command line's are.
  std::string text(reinterpret_cast<const char*>(data), size);
  tsc::Settings settings;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t end = std::min(text.find('\n', start), text.size());
    try {
      tsc::ApplyOverride(text.substr(start, end - start), settings);
    } catch (const tsc::ConfigError&) {
    }
    start = end + 1;
  }
  return 0;
}
