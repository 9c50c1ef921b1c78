#pragma once
// `tsc inspect`: what a store holds — base points by status, detected places, the place
// memory tree and the topological map — as text, JSON, Graphviz DOT or PNG.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"

namespace tsc {

/// A failure of inspection or rendering; the message names the file at fault.
class InspectError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LearnedPlaceSummary {
  PlaceId id;
  int64_t members = 0;          ///< base points averaged into the place
  int64_t detected_places = 0;  ///< detected places that compose it
};

struct StoreSummary {
  std::string db;
  int schema_version = 0;
  uint32_t robot = 0;
  int64_t base_points = 0;       ///< base point records kept (store.budget_mb thins the oldest)
  int64_t base_points_seen = 0;  ///< base points the robot has processed (meta next_base)
  int64_t good = 0;
  int64_t uninformative = 0;
  int64_t incoherent = 0;
  int64_t detected_places = 0;  ///< detected place records kept (thinned with base points)
  /// Indices the robot has given detected places (meta next_detected − 1): a place open when
  /// tscd stopped took one and was never closed.
  int64_t detected_places_numbered = 0;
  std::vector<LearnedPlaceSummary> learned_places;
  /// The space the places were learned in: their descriptors' dimension (0 without places)
  /// and the view basis their member views are read in ("none": as descriptors).
  int64_t descriptor_dimension = 0;
  std::string view_basis;
  /// True when the configuration given does not fit the store (other features or basis), so
  /// the memory was read in the space it was learned in.
  bool own_space = false;
  int tree_depth = 0;
  int64_t tree_nodes = 0;
  int64_t map_nodes = 0;
  int64_t map_edges = 0;
};

/// A store read back: the summary plus the memory and map it was computed from.
struct InspectedStore {
  StoreSummary summary;
  PlaceMemory memory;
  TopologicalMap map;
};

/// Reads an existing store (never creates one). `robot`: the robot whose memory to load;
/// by default the one recorded in the database. A store learned in another descriptor space
/// than `options` (DescriptorSpaceMismatch) is read in its own, with its views as stored.
/// Throws InspectError (missing file) or StoreError. The memory is restored on `threads` threads
/// (tsc inspect: daemon.merge_threads, as tscd loads it).
InspectedStore InspectStore(const std::filesystem::path& db, const PlaceMemoryOptions& options,
                            std::optional<uint32_t> robot = std::nullopt, int threads = 1);

/// Human-readable summary.
void PrintSummary(std::ostream& out, const StoreSummary& s);
/// The same as one JSON object: db, schema_version, robot, base_points, base_points_seen, good,
/// uninformative, incoherent, detected_places, detected_places_numbered, learned_places
/// (count), places ([{id, members, detected_places}]), tree_depth, tree_nodes, map_nodes,
/// map_edges.
void PrintSummaryJson(std::ostream& out, const StoreSummary& s);

/// One Graphviz digraph with two clusters: "place memory" (the tree, root at the top,
/// terminals labelled with place id and member count, inner nodes with their SLINK height)
/// and "topological map" (places joined by undirected edges labelled with traversals).
std::string ToDot(const PlaceMemory& memory, const TopologicalMap& map);

/// Writes `dot` to `path`. Throws InspectError naming the file.
void WriteTextFile(const std::filesystem::path& path, const std::string& text);
/// Renders `dot` to a PNG at `png` with Graphviz's `dot` command (found on PATH, run
/// without a shell). Throws InspectError when `dot` is missing or fails.
void RenderPng(const std::string& dot, const std::filesystem::path& png);

}  // namespace tsc
