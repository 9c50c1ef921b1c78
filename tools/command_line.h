#pragma once
// What every `tsc` subcommand shares on its command line: the usage error and the parser.

#include <boost/program_options.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsc {

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

}  // namespace tsc
