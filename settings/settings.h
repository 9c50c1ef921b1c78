#pragma once
// Configuration of tscd and the tools: an INI file (Boost.Program_options' config-file syntax,
// '#' comments, [section] headers) plus command-line overrides `--set section.key=value`.
// Every parameter is one named key of ConfigTable(), with its unit and valid range; the
// defaults are those of the Options structs (Settings{}), never repeated here.

#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "core/range.h"
#include "settings/daemon_options.h"

namespace tsc {

/// Everything a configuration file sets: the pipeline (the model's parameters) and the daemon
/// around it. The offline tools read the same files and use `pipeline`.
struct Settings {
  PipelineOptions pipeline;
  DaemonOptions daemon;
};

/// A bad configuration: unknown key, malformed or out-of-range value, unreadable file.
/// The message names the file (or "--set") and the key.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One row of the configuration table.
struct ConfigKey {
  enum class Kind { kInteger, kReal, kBool, kText };
  std::string key;          ///< "section.name"
  std::string description;  ///< what it sets, with the thesis symbol
  std::string unit;         ///< "" when dimensionless
  Kind kind = Kind::kReal;
  /// The model's parameters (read by the offline tools too) or the daemon's own.
  enum class Scope { kPipeline, kDaemon };
  Scope scope = Scope::kPipeline;
  /// Range of numeric keys: the Options struct's own declaration (e.g.
  /// DetectorOptions::kTauNRange, which its Validate() checks too) where it has one.
  Range range;
  std::string text_range;  ///< the accepted values of text keys
  /// Current value, formatted as the INI file would hold it.
  std::function<std::string(const Settings&)> get;
  /// Parses and checks `value`, then stores it. Throws std::invalid_argument with the reason.
  std::function<void(Settings&, const std::string& value)> set;

  /// "[0, 1]", "(0, 1]", "L1..L5 ...", "true|false".
  std::string RangeText() const;
};

/// Every configuration key, in file order. The single place keys are defined.
const std::vector<ConfigKey>& ConfigTable();
/// The row of `key` ("section.name"), or nullptr.
const ConfigKey* FindConfigKey(const std::string& key);

/// Applies an INI file on top of `options`. Throws ConfigError naming the file and key on an
/// unreadable file, a syntax error, an unknown or repeated key, or a bad value.
void ApplyConfigFile(const std::filesystem::path& file, Settings& settings);
/// Applies one `section.key=value` override. Throws ConfigError naming `origin` (the option
/// it came from: "--set", or "--robot" for the dedicated flag) and the key.
void ApplyOverride(const std::string& assignment, Settings& options,
                   const std::string& origin = "--set");

/// Defaults, then `file` when given, then the overrides in order; validates the result
/// (PipelineOptions::Validate, DaemonOptions::Validate) and throws ConfigError naming the
/// source on failure.
Settings LoadSettings(const std::optional<std::filesystem::path>& file,
                      const std::vector<std::string>& overrides);
/// LoadSettings(file, overrides).pipeline, for the offline tools.
PipelineOptions LoadPipelineOptions(const std::optional<std::filesystem::path>& file,
                                    const std::vector<std::string>& overrides);

/// `options` as a commented INI file: each key with its description, unit, range and the
/// built-in default. Loading the output gives back `options`.
std::string DumpConfig(const Settings& settings);

}  // namespace tsc
