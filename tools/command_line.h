#pragma once
// What every `tsc` subcommand shares on its command line: the exit codes, the usage error,
// the parser and the one place where what a subcommand throws becomes an exit code.

#include <boost/program_options.hpp>
#include <filesystem>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/memory/descriptor_space_mismatch.h"
#include "settings/settings.h"

namespace tsc {

/// Exit codes of every tsc subcommand (DESIGN §7.2).
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitConfig = 78;  // EX_CONFIG of sysexits.h

/// Bad command line; the message is printed after "tsc: " with a pointer to --help.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses `args` against `desc` (and `positional`). Required options are checked unless
/// --help was given; any parse error becomes a UsageError.
inline boost::program_options::variables_map ParseCommandLine(
    const std::vector<std::string>& args, const boost::program_options::options_description& desc,
    const boost::program_options::positional_options_description* positional = nullptr) {
  namespace po = boost::program_options;
  po::variables_map vm;
  try {
    po::command_line_parser parser(args);
    parser.options(desc);
    if (positional != nullptr) parser.positional(*positional);
    po::store(parser.run(), vm);
    if (vm.count("help") == 0) po::notify(vm);
  } catch (const po::error& e) {
    throw UsageError(e.what());
  }
  return vm;
}

/// A FROM:TO:STEP option value (a sweep, a grid) as its three numbers; a UsageError naming
/// `option` and showing `example` otherwise. Their ranges are the caller's to check.
struct FromToStep {
  double from = 0.0, to = 0.0, step = 0.0;
};
inline FromToStep ParseFromToStep(const std::string& option, const std::string& text,
                                  const std::string& example) {
  double v[3];
  size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const size_t colon = text.find(':', start);
    if ((i < 2) != (colon != std::string::npos)) {
      throw UsageError(option + " " + text + ": expected FROM:TO:STEP, e.g. " + example);
    }
    const std::string part = text.substr(start, i < 2 ? colon - start : std::string::npos);
    size_t used = 0;
    try {
      v[i] = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != part.size()) {
      throw UsageError(option + " " + text + ": '" + part + "' is not a number");
    }
    start = colon + 1;
  }
  return {v[0], v[1], v[2]};
}

/// Adds the configuration options every pipeline subcommand takes: --config F and the
/// repeatable --set KEY=VALUE.
inline void AddConfigOptions(boost::program_options::options_description& desc,
                             const char* config_help =
                                 "configuration file (INI; 'tsc config' "
                                 "lists the keys)") {
  namespace po = boost::program_options;
  desc.add_options()("config", po::value<std::string>()->value_name("F"), config_help)(
      "set", po::value<std::vector<std::string>>()->composing()->value_name("KEY=VALUE"),
      "override one configuration key, e.g. --set memory.tau_r=1.5 (repeatable)");
}

/// The settings those options select: defaults, then --config, then each --set in order, then
/// `more_overrides` (so they win). Throws ConfigError naming the file or key at fault.
inline Settings SettingsFromCommandLine(const boost::program_options::variables_map& vm,
                                        const std::vector<std::string>& more_overrides = {}) {
  std::optional<std::filesystem::path> file;
  if (vm.count("config")) file = vm["config"].as<std::string>();
  std::vector<std::string> overrides;
  if (vm.count("set")) overrides = vm["set"].as<std::vector<std::string>>();
  overrides.insert(overrides.end(), more_overrides.begin(), more_overrides.end());
  return LoadSettings(file, overrides);
}

/// SettingsFromCommandLine, with a subcommand's --robot ID (where it has one) applied last as
/// robot.id, so it wins and is checked like every other key.
inline Settings SettingsWithRobotOption(const boost::program_options::variables_map& vm) {
  if (vm.count("robot"))
    return SettingsFromCommandLine(vm, {"robot.id=" + vm["robot"].as<std::string>()});
  return SettingsFromCommandLine(vm);
}

/// Runs subcommand `name` and turns what it throws into one line on stderr and an exit code:
/// UsageError → kExitUsage (with a pointer to its --help), ConfigError and
/// DescriptorSpaceMismatch → kExitConfig, any other exception → kExitFailure. Subcommands
/// throw; only `tsc`'s dispatcher (and tests that call a subcommand directly) come through here.
template <typename Body>
int RunReportingErrors(const std::string& name, Body&& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << "tsc: " << e.what() << " (try 'tsc " << name << " --help')\n";
    return kExitUsage;
  } catch (const ConfigError& e) {
    std::cerr << "tsc: " << e.what() << "\n";
    return kExitConfig;
  } catch (const DescriptorSpaceMismatch& e) {  // a store learned under another configuration
    std::cerr << "tsc: configuration error: " << e.what() << "\n";
    return kExitConfig;
  } catch (const std::exception& e) {  // DatasetError, StoreError, I/O, ...
    std::cerr << "tsc: " << e.what() << "\n";
    return kExitFailure;
  }
}

}  // namespace tsc
