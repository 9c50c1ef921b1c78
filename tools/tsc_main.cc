// tsc — the offline tool's dispatcher: each command is a Run*Command of its own file
// (tools/*_command.h: run, eval, sim, team, soak, merge, basis, classify, axis-sim, jaguar-sim,
// teleop); the two short ones, `tsc inspect` (what a store learned) and `tsc config` (the
// configuration keys), are here.
// Exit codes (DESIGN §7.2): 0 ok, 1 runtime failure, 2 usage error, 78 configuration error.

#include <boost/program_options.hpp>
#include <iostream>
#include <string>
#include <vector>

#include "settings/settings.h"
#include "tools/axis_sim_command.h"
#include "tools/basis_command.h"
#include "tools/classify_command.h"
#include "tools/command_line.h"
#include "tools/eval_command.h"
#include "tools/inspect.h"
#include "tools/jaguar_commands.h"
#include "tools/merge_command.h"
#include "tools/run_command.h"
#include "tools/sim_command.h"
#include "tools/soak_command.h"
#include "tools/team_command.h"

namespace tsc {
namespace {
namespace po = boost::program_options;

constexpr const char* kMainHelp =
    R"(usage: tsc <command> [options]

Topological spatial cognition, offline. Commands:
  run      run the TSC pipeline over a dataset folder, storing what it learns
  eval     run the pipeline on a fresh memory and score it against the ground truth
           (JSON figures, PR curve over tau_r, PNG plots)
  inspect  summarise a store; export its place memory and map as JSON, DOT or PNG
  config   print the configuration keys with units, ranges and values as an INI file
  sim      write a simulated dataset (frames and ground truth) from a generated world
  team     run N tscd robots in a private network namespace on the simulated world
  soak     soak and load: a team under packet loss and restarts for minutes; RSS, CPU,
           merges and message rates to soak.csv and soak.png; judges growth
  merge    merge two robots' stores (place memories and maps) into a new store
  basis    fit the principal basis member views are kept in, on datasets' descriptors
  axis-sim a simulated Axis PTZ camera (VAPIX MJPEG and PTZ over HTTP) on 127.0.0.1
  classify supervised place classification (chapter 2): train, test or cross-validate a
           multi-class SVM on labelled RGB-D datasets (ImageCLEF score, PR curve over tau)
  jaguar-sim  a simulated Jaguar motor board on 127.0.0.1 (V2 binary/UDP and ASCII/TCP)
  teleop   drive a robot from the keyboard (JAGUAR_CMD_<robot>, dead-man rule)

'tsc <command> --help' describes each command; 'tsc --version' prints the version.

Exit codes: 0 ok, 1 runtime failure (dataset, store, I/O), 2 usage error,
78 configuration error. Every error names the file, key or frame at fault.
)";

constexpr const char* kInspectHelp =
    R"(usage: tsc inspect FILE [--json] [--dot PATH] [--png PATH] [--robot ID]
                   [--config F] [--set section.key=value]...

Prints what a store holds: robot, base points (good / uninformative / incoherent), detected
places, learned places with their member counts, the descriptor space they were learned in,
the depth of the place memory tree and the size of the topological map. --json prints the same
as one JSON object.

--dot and --png write ONE Graphviz graph with two clusters: "place memory" (the tree, root
on top, terminals = learned places) and "topological map" (places and their edges, labelled
with traversal counts). --png runs Graphviz's `dot` command (package graphviz).
The configuration only matters for how discriminants missing from the store are retrained
and the view basis the member views are read in; a store learned with other features (such
as config/sweep.ini's) is read in its own space, and the summary says so.

Options)";

constexpr const char* kConfigHelp =
    R"(usage: tsc config [--config F] [--set section.key=value]...

Prints the configuration as a commented INI file: every key with its meaning, unit, valid
range and built-in default, set to the value F and the overrides give (the defaults without
them). 'tsc config > my.ini' starts a configuration file.

Options)";

int Inspect(const std::vector<std::string>& args) {
  po::options_description desc(kInspectHelp);
  desc.add_options()("help,h", "show this help")(
      "db", po::value<std::string>()->required()->value_name("FILE"),
      "SQLite store to read (also the first positional argument: tsc inspect memory.db)")(
      "json", "print the summary as one JSON object")(
      "dot", po::value<std::string>()->value_name("PATH"), "write the Graphviz DOT file")(
      "png", po::value<std::string>()->value_name("PATH"), "render the graph to PNG with `dot`")(
      "robot", po::value<std::string>()->value_name("ID"),
      "robot whose memory to read (default: the store's)");
  AddConfigOptions(desc);
  po::positional_options_description pos;
  pos.add("db", 1);
  const po::variables_map vm = ParseCommandLine(args, desc, &pos);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const Settings settings = SettingsWithRobotOption(vm);
  const PipelineOptions& options = settings.pipeline;
  std::optional<uint32_t> robot;
  if (vm.count("robot")) robot = options.robot;
  // Restored on daemon.merge_threads, as tscd loads the same store.
  const InspectedStore st = InspectStore(vm["db"].as<std::string>(), options.memory, robot,
                                         settings.daemon.MergeThreads());
  if (vm.count("json")) {
    PrintSummaryJson(std::cout, st.summary);
  } else {
    PrintSummary(std::cout, st.summary);
  }
  if (vm.count("dot") || vm.count("png")) {
    const std::string dot = ToDot(st.memory, st.map);
    if (vm.count("dot")) WriteTextFile(vm["dot"].as<std::string>(), dot);
    if (vm.count("png")) RenderPng(dot, vm["png"].as<std::string>());
  }
  return kExitOk;
}

int Config(const std::vector<std::string>& args) {
  po::options_description desc(kConfigHelp);
  desc.add_options()("help,h", "show this help");
  AddConfigOptions(desc);
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  std::cout << DumpConfig(SettingsWithRobotOption(vm));
  return kExitOk;
}

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kMainHelp;
    return kExitUsage;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    std::cout << kMainHelp;
    return kExitOk;
  }
  if (command == "--version" || command == "version") {
    std::cout << "tsc " << TSCD_VERSION << "\n";
    return kExitOk;
  }
  using Command = int (*)(const std::vector<std::string>&);
  Command fn = nullptr;
  if (command == "run") fn = RunPipelineCommand;
  if (command == "eval") fn = RunEvalCommand;
  if (command == "inspect") fn = Inspect;
  if (command == "config") fn = Config;
  if (command == "sim") fn = RunSimCommand;
  if (command == "team") fn = RunTeamCommand;
  if (command == "soak") fn = RunSoakCommand;
  if (command == "merge") fn = RunMergeCommand;
  if (command == "basis") fn = RunBasisCommand;
  if (command == "axis-sim") fn = RunAxisSimCommand;
  if (command == "classify") fn = RunClassifyCommand;
  if (command == "jaguar-sim") fn = RunJaguarSimCommand;
  if (command == "teleop") fn = RunTeleopCommand;
  if (fn == nullptr) {
    std::cerr << "tsc: unknown command '" << command << "' (try 'tsc --help')\n";
    return kExitUsage;
  }
  const std::vector<std::string> args(argv + 2, argv + argc);
  return RunReportingErrors(command, [&] { return fn(args); });
}

}  // namespace
}  // namespace tsc

int main(int argc, char** argv) { return tsc::Main(argc, argv); }
