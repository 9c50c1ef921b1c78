#include "tools/inspect.h"

#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "core/memory/descriptor_space_mismatch.h"
#include "store/store.h"
#include "tools/events_json.h"

namespace tsc {
namespace fs = std::filesystem;

namespace {

// Read-only queries the Store API does not offer (counts per base point status, the robot
// recorded in the database). Kept here, next to the one tool that needs them.
class ReadOnlyDb {
 public:
  explicit ReadOnlyDb(const fs::path& path) : path_(path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw InspectError(path.string() + ": cannot open database: " + why);
    }
    sqlite3_busy_timeout(db_, 2000);
  }
  ~ReadOnlyDb() { sqlite3_close(db_); }
  ReadOnlyDb(const ReadOnlyDb&) = delete;
  ReadOnlyDb& operator=(const ReadOnlyDb&) = delete;

  bool HasTable(const std::string& name) const {
    return Int("SELECT count(*) FROM sqlite_master WHERE type='table' AND name='" + name + "'")
               .value_or(0) > 0;
  }
  /// The first column of the first row as an integer; nullopt when there is no row or NULL.
  std::optional<int64_t> Int(const std::string& sql) const {
    sqlite3_stmt* stmt = nullptr;
    const int prepared = sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt, nullptr);
    if (prepared == SQLITE_NOTADB) throw InspectError(path_.string() + ": not a SQLite database");
    if (prepared != SQLITE_OK) {
      const std::string why = sqlite3_errmsg(db_);
      throw InspectError(path_.string() + ": query failed (" + why + "): " + sql);
    }
    std::optional<int64_t> out;
    const int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW && sqlite3_column_type(stmt, 0) != SQLITE_NULL) {
      out = sqlite3_column_int64(stmt, 0);
    }
    sqlite3_finalize(stmt);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
      throw InspectError(path_.string() + ": query failed (" + sqlite3_errstr(rc) + "): " + sql);
    }
    return out;
  }

 private:
  fs::path path_;
  sqlite3* db_ = nullptr;
};

std::string DotId(const PlaceId& id) {
  return "p" + std::to_string(id.robot) + "_" + std::to_string(id.local);
}

// Merge heights are squared distances of normalised descriptors (often ~1e-5): 3 significant
// digits, not fixed decimals.
std::string Height(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

std::string Count(size_t n, const std::string& noun) {
  return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

std::optional<fs::path> FindOnPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path != nullptr && *path != '\0' ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / program;
    if (access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

}  // namespace

InspectedStore InspectStore(const fs::path& db, const PlaceMemoryOptions& options,
                            std::optional<uint32_t> robot, int threads) {
  std::error_code ec;
  if (!fs::exists(db, ec)) throw InspectError(db.string() + ": no such database");
  if (!fs::is_regular_file(db, ec)) throw InspectError(db.string() + ": not a database file");

  StoreSummary s;
  s.db = db.string();
  bool robot_recorded = false;
  {
    const ReadOnlyDb ro(db);
    if (!ro.HasTable("schema_version")) {
      throw InspectError(db.string() + ": not a tscd store (no schema_version table)");
    }
    if (ro.HasTable("meta")) {
      robot_recorded = ro.Int("SELECT count(*) FROM meta WHERE key='robot'").value_or(0) > 0;
    }
    if (!robot && robot_recorded) {
      if (auto r = ro.Int("SELECT value FROM meta WHERE key='robot'")) {
        robot = static_cast<uint32_t>(*r);
      }
    }
    if (ro.HasTable("base_points")) {
      s.base_points = ro.Int("SELECT count(*) FROM base_points").value_or(0);
      const auto count = [&](BaseStatus st) {
        return ro
            .Int("SELECT count(*) FROM base_points WHERE status=" +
                 std::to_string(static_cast<int>(st)))
            .value_or(0);
      };
      s.good = count(BaseStatus::kGood);
      s.uninformative = count(BaseStatus::kUninformative);
      s.incoherent = count(BaseStatus::kIncoherent);
    }
    if (ro.HasTable("detected_places")) {
      s.detected_places = ro.Int("SELECT count(*) FROM detected_places").value_or(0);
    }
  }

  Store store = Store::Open(db);
  s.schema_version = store.schema_version();
  s.robot = robot.value_or(1);
  // Load() records the robot in a store that has none yet; inspection must not write, so a
  // store nothing was committed to reads as empty.
  const auto load = [&](const PlaceMemoryOptions& o) {
    return robot_recorded ? store.Load(s.robot, o, threads)
                          : StoredState{PlaceMemory(s.robot, o), TopologicalMap{}, {}};
  };
  std::optional<StoredState> loaded;
  try {
    loaded = load(options);
  } catch (const DescriptorSpaceMismatch&) {
    // Learned with other features (a preset such as config/sweep.ini): a summary needs no
    // basis, so its views are read as they were stored.
    PlaceMemoryOptions own = options;
    own.view_basis = nullptr;
    loaded = load(own);
    s.own_space = true;
  }
  StoredState& state = *loaded;
  s.descriptor_dimension = state.memory.empty() ? 0 : state.memory.places().front().mean.size();
  s.view_basis = state.memory.view_basis() ? state.memory.view_basis()->name() : "none";
  for (const LearnedPlace& p : state.memory.places()) {
    s.learned_places.push_back({p.id, p.member_count, static_cast<int64_t>(p.detected.size())});
  }
  s.base_points_seen = state.pipeline.next_base;
  s.detected_places_numbered = state.pipeline.next_detected - 1;
  s.tree_depth = state.memory.empty() ? 0 : state.memory.Depth();
  s.tree_nodes = static_cast<int64_t>(state.memory.nodes().size());
  s.map_nodes = static_cast<int64_t>(state.map.places().size());
  s.map_edges = static_cast<int64_t>(state.map.edges().size());
  return InspectedStore{std::move(s), std::move(state.memory), std::move(state.map)};
}

void PrintSummary(std::ostream& out, const StoreSummary& s) {
  out << "store            " << s.db << " (schema " << s.schema_version << ")\n"
      << "robot            " << s.robot << "\n"
      << "base points      " << s.base_points
      << (s.base_points != s.base_points_seen
              ? " kept of " + std::to_string(s.base_points_seen) + " seen"
              : std::string())
      << " (good " << s.good << ", uninformative " << s.uninformative << ", incoherent "
      << s.incoherent << ")\n"
      << "detected places  " << s.detected_places
      << (s.detected_places != s.detected_places_numbered
              ? " (numbered up to " + std::to_string(s.detected_places_numbered) + ")"
              : std::string())
      << "\n"
      << "learned places   " << s.learned_places.size() << "\n";
  for (const LearnedPlaceSummary& p : s.learned_places) {
    out << "  " << p.id.ToString() << "  " << p.members << " base points from " << p.detected_places
        << " detected place" << (p.detected_places == 1 ? "" : "s") << "\n";
  }
  if (s.descriptor_dimension > 0) {
    out << "descriptors      dimension " << s.descriptor_dimension << ", member views "
        << (s.view_basis == "none" ? "as descriptors" : "in view basis " + s.view_basis)
        << (s.own_space ? " (not the configuration's: learned with other features)" : "") << "\n";
  }
  out << "memory tree      " << s.tree_nodes << " nodes, depth " << s.tree_depth << "\n"
      << "topological map  " << s.map_nodes << " nodes, " << s.map_edges << " edges\n";
}

void PrintSummaryJson(std::ostream& out, const StoreSummary& s) {
  out << "{\"db\":" << JsonString(s.db) << ",\"schema_version\":" << s.schema_version
      << ",\"robot\":" << s.robot << ",\"base_points\":" << s.base_points
      << ",\"base_points_seen\":" << s.base_points_seen << ",\"good\":" << s.good
      << ",\"uninformative\":" << s.uninformative << ",\"incoherent\":" << s.incoherent
      << ",\"detected_places\":" << s.detected_places
      << ",\"detected_places_numbered\":" << s.detected_places_numbered
      << ",\"learned_places\":" << s.learned_places.size() << ",\"places\":[";
  for (size_t i = 0; i < s.learned_places.size(); ++i) {
    const LearnedPlaceSummary& p = s.learned_places[i];
    out << (i ? "," : "") << "{\"id\":" << JsonString(p.id.ToString())
        << ",\"members\":" << p.members << ",\"detected_places\":" << p.detected_places << "}";
  }
  out << "],\"descriptor_dimension\":" << s.descriptor_dimension
      << ",\"view_basis\":" << JsonString(s.view_basis)
      << ",\"configuration_fits\":" << (s.own_space ? "false" : "true")
      << ",\"tree_depth\":" << s.tree_depth << ",\"tree_nodes\":" << s.tree_nodes
      << ",\"map_nodes\":" << s.map_nodes << ",\"map_edges\":" << s.map_edges << "}\n";
}

// Fill colour of a place as in the thesis' figures 4.9–4.19: one colour per robot (blue,
// green, red, then more), orange for a place that absorbed other robots' places by merging.
std::string PlaceColour(const LearnedPlace* p, PlaceId id) {
  static constexpr std::array<const char*, 8> kRobotColours = {
      "#9ecae1", "#a1d99b", "#fc9272", "#bcbddc", "#fdd0a2", "#c7e9c0", "#d9d9d9", "#f7b6d2"};
  if (p != nullptr && !p->sources.empty()) return "#fd8d3c";
  return kRobotColours[(id.robot + kRobotColours.size() - 1) % kRobotColours.size()];  // 1: blue
}

std::string ToDot(const PlaceMemory& memory, const TopologicalMap& map) {
  std::ostringstream d;
  d << "digraph tscd {\n"
       "  graph [fontname=\"Helvetica\", compound=true, rankdir=TB];\n"
       "  node [fontname=\"Helvetica\", fontsize=10];\n"
       "  edge [fontname=\"Helvetica\", fontsize=9];\n"
       "  subgraph cluster_memory {\n"
       "    label=\"place memory (robot "
    << memory.robot() << ", " << Count(memory.places().size(), "place") << ")\";\n";
  const auto& nodes = memory.nodes();
  for (size_t i = 0; i < nodes.size(); ++i) {
    const MemoryNode& n = nodes[i];
    d << "    n" << i << " [";
    if (n.terminal()) {
      const LearnedPlace& p = memory.places()[static_cast<size_t>(n.place)];
      d << "shape=box, style=filled, fillcolor=\"" << PlaceColour(&p, p.id) << "\", label=\""
        << p.id.ToString();
      for (const PlaceId& s : p.sources) d << " +" << s.ToString();
      d << "\\n" << p.member_count << " pts\"";
    } else if (static_cast<int>(i) == memory.root()) {
      d << "shape=doublecircle, label=\"root\\nh=" << Height(n.height) << "\"";
    } else {
      d << "shape=ellipse, label=\"h=" << Height(n.height) << "\"";
    }
    d << "];\n";
  }
  for (size_t i = 0; i < nodes.size(); ++i) {
    for (const int c : nodes[i].children) d << "    n" << i << " -> n" << c << ";\n";
  }
  d << "  }\n"
       "  subgraph cluster_map {\n"
       "    label=\"topological map ("
    << Count(map.places().size(), "place") << ", " << Count(map.edges().size(), "edge") << ")\";\n";
  std::unordered_map<PlaceId, const LearnedPlace*, PlaceIdHash> by_id;
  for (const LearnedPlace& p : memory.places()) by_id.emplace(p.id, &p);
  for (const PlaceId& p : map.places()) {
    const auto it = by_id.find(p);
    const LearnedPlace* place = it == by_id.end() ? nullptr : it->second;
    d << "    " << DotId(p) << " [shape=circle, style=filled, fillcolor=\"" << PlaceColour(place, p)
      << "\", label=\"" << p.ToString() << "\"];\n";
  }
  for (const auto& [key, e] : map.edges()) {
    d << "    " << DotId(e.a) << " -> " << DotId(e.b) << " [dir=none, label=\"" << e.traversals
      << "\"];\n";
  }
  d << "  }\n}\n";
  return d.str();
}

void WriteTextFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InspectError(path.string() + ": cannot write: " + std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw InspectError(path.string() + ": write failed");
}

void RenderPng(const std::string& dot, const fs::path& png) {
  const std::optional<fs::path> program = FindOnPath("dot");
  if (!program) {
    throw InspectError(png.string() +
                       ": cannot render: Graphviz's `dot` command is not on PATH (install the "
                       "graphviz package: scripts/bootstrap)");
  }
  // The DOT text goes through a temporary file, so a failing `dot` cannot SIGPIPE us.
  std::string tmpl = (fs::temp_directory_path() / "tsc-inspect-XXXXXX.dot").string();
  const int fd = mkstemps(tmpl.data(), 4);
  if (fd < 0) throw InspectError(tmpl + ": cannot create temporary file: " + std::strerror(errno));
  close(fd);
  const fs::path tmp = tmpl;
  struct Remove {
    fs::path p;
    ~Remove() {
      std::error_code ec;
      fs::remove(p, ec);
    }
  } remove_tmp{tmp};
  WriteTextFile(tmp, dot);

  const std::string exe = program->string(), out = png.string(), in = tmp.string();
  const pid_t pid = fork();
  if (pid < 0) throw InspectError(png.string() + ": fork failed: " + std::strerror(errno));
  if (pid == 0) {
    const char* argv[] = {"dot", "-Tpng", "-o", out.c_str(), in.c_str(), nullptr};
    execv(exe.c_str(), const_cast<char* const*>(argv));
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw InspectError(png.string() + ": waitpid failed");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw InspectError(png.string() + ": `" + exe + " -Tpng` failed (exit status " +
                       std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  }
}

}  // namespace tsc
