#include "tools/merge_command.h"

#include <boost/program_options.hpp>
#include <exception>
#include <filesystem>
#include <iostream>
#include <optional>
#include <stdexcept>

#include "core/merge/merge.h"
#include "core/merge/merge_maps.h"
#include "settings/settings.h"
#include "store/store.h"
#include "tools/command_line.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
namespace po = boost::program_options;

constexpr const char* kMergeHelp =
    R"(usage: tsc merge A.db B.db --out C.db [--force] [--config F] [--set section.key=value]...

Merges robot B's place memory and topological map into robot A's (thesis chapter 4): the
case of the root hyperspheres decides whether B's places are added as they are (disjoint,
contained) or recognised against A's best-overlapping hyper-terminals (tau_r) and merged
into the places they match; map nodes of merged places collapse, edges are united. The
smaller memory is merged into the larger, so A+B and B+A hold the same places. C.db is a
copy of A.db (robot A) with the merged memory and map; it must not exist unless --force is
given. Merging the same B again changes nothing. The configuration's memory keys (tau_r,
max_samples_per_place, discriminant) apply.

Options)";

StoredState LoadStore(const fs::path& path, const PlaceMemoryOptions& options, int threads,
                      uint32_t* robot) {
  if (!fs::is_regular_file(path)) throw std::runtime_error(path.string() + ": no such store");
  Store store = Store::Open(path);
  const std::optional<uint32_t> id = store.robot();
  if (!id) throw std::runtime_error(path.string() + ": the store records no robot id (empty)");
  *robot = *id;
  return store.Load(*id, options, threads);
}

int Merge(const std::vector<std::string>& args) {
  po::options_description desc(kMergeHelp);
  desc.add_options()("help,h", "show this help")(
      "out", po::value<std::string>()->value_name("C.db"), "merged store to write")(
      "force", "overwrite C.db if it exists");
  AddConfigOptions(desc);
  po::options_description hidden;
  hidden.add_options()("stores", po::value<std::vector<std::string>>(), "A.db B.db");
  po::options_description all;
  all.add(desc).add(hidden);
  po::positional_options_description positional;
  positional.add("stores", -1);
  const po::variables_map vm = ParseCommandLine(args, all, &positional);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const std::vector<std::string> stores =
      vm.count("stores") ? vm["stores"].as<std::vector<std::string>>() : std::vector<std::string>{};
  if (stores.size() != 2) {
    throw UsageError("expected two stores A.db B.db, got " + std::to_string(stores.size()));
  }
  if (!vm.count("out")) throw UsageError("--out C.db is required");
  const fs::path a_path = stores[0], b_path = stores[1], out = vm["out"].as<std::string>();

  const Settings settings = SettingsFromCommandLine(vm);  // ConfigError → 78
  const PipelineOptions& options = settings.pipeline;

  if (fs::exists(out)) {
    if (!vm.count("force")) {
      throw std::runtime_error(out.string() + ": exists (use --force to overwrite it)");
    }
    for (const fs::path& input : {a_path, b_path}) {
      if (fs::exists(input) && fs::equivalent(out, input)) {
        throw std::runtime_error(out.string() + ": is one of the input stores");
      }
    }
  }
  uint32_t a_robot = 0, b_robot = 0;
  // Loaded and merged on daemon.merge_threads, as tscd does.
  const int threads = settings.daemon.MergeThreads();
  const StoredState a = LoadStore(a_path, options.memory, threads, &a_robot);
  const StoredState b = LoadStore(b_path, options.memory, threads, &b_robot);
  if (a_robot == b_robot) {
    throw std::runtime_error(b_path.string() + ": belongs to robot " + std::to_string(b_robot) +
                             " like " + a_path.string() + "; merging needs two robots");
  }
  const MemoryMerge merged = MergeMemories(a.memory, b.memory, threads);
  const TopologicalMap map = MergeMaps(a.map, b.map, merged.memory);

  if (vm.count("force")) {
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(out.string() + suffix);
  }
  Store::Open(a_path).CopyTo(out);
  Store::Open(out).ReplaceKnowledge(merged.memory, map);

  std::cout << "tsc merge: robot " << a_robot << " (" << a.memory.places().size() << " places, "
            << a.map.edges().size() << " edges) + robot " << b_robot << " ("
            << b.memory.places().size() << " places, " << b.map.edges().size() << " edges)\n"
            << "  case       " << ToString(merged.merge_case) << " ("
            << (merged.peer_into_ours ? "B merged into A" : "A merged into B") << ")\n"
            << "  absorbed   " << merged.absorbed.size() << "\n"
            << "  added      " << merged.added.size() << "\n"
            << "  known      " << merged.known.size() << " (merged before)\n"
            << "  retrained  " << merged.retrained << " discriminants\n"
            << "  result     " << merged.memory.places().size() << " places, " << map.edges().size()
            << " edges, written to " << out.string() << "\n";
  for (const Absorption& x : merged.absorbed) {
    std::cout << "  merged     " << x.source.ToString() << " -> " << x.target.ToString()
              << " (g = " << x.cost << ")\n";
  }
  return kExitOk;
}

}  // namespace

int RunMergeCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("merge", [&] { return Merge(args); });
}

}  // namespace tsc
