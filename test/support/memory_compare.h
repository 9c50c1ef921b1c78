#pragma once
// Structural comparison of two robots' memories as stored: every learned place (id, mean and
// representative samples bit for bit, member count, detected places, member base points,
// absorbed source ids), the tree (nodes with parent, children, place, height, leaf range, set
// key), the discriminants of the tree's nodes, the topological map (places, edges with
// endpoints, traversal counts and transition regions) and the peers merged (robot, version,
// digest). Used by the crash tests to show that the memory after a restart IS the last
// committed one, not merely as large.

#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "store/store.h"

namespace tsc::testing_support {

/// A memory as a restarted tscd would see it.
struct Knowledge {
  StoredState state;
  std::map<uint32_t, PeerMerge> peers;
};

/// Opens `db` and loads it (a crash image is recovered from its WAL as tscd would) with the
/// memory options tscd runs with by default (its views in the builtin basis).
/// Throws StoreError.
inline Knowledge LoadKnowledge(const std::filesystem::path& db, uint32_t robot,
                               const PlaceMemoryOptions& options = PipelineOptions{}.memory) {
  Store store = Store::Open(db);
  Knowledge k{store.Load(robot, options), store.LoadPeers()};
  return k;
}

/// Copies a database as a crash leaves it (the file and its -wal and -shm companions, byte for
/// byte, while nothing writes it) to `to`, which then opens as the crashed process's would.
inline void CopyCrashImage(const std::filesystem::path& db, const std::filesystem::path& to) {
  namespace fs = std::filesystem;
  for (const char* suffix : {"", "-wal", "-shm"}) {
    const fs::path from = db.string() + suffix;
    const fs::path dest = to.string() + suffix;
    fs::remove(dest);
    if (fs::exists(from)) fs::copy_file(from, dest);
  }
}

namespace detail {

inline bool BitwiseEqual(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 ||
          std::memcmp(a.data(), b.data(), static_cast<size_t>(a.size()) * sizeof(float)) == 0);
}

inline bool BitwiseEqual(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
  return a.size() == b.size() &&
         (a.size() == 0 ||
          std::memcmp(a.data(), b.data(), static_cast<size_t>(a.size()) * sizeof(float)) == 0);
}

template <typename T>
std::string Count(const char* what, const T& a, const T& b) {
  return std::string(what) + " " + std::to_string(a.size()) + " vs " + std::to_string(b.size());
}

}  // namespace detail

/// Every difference between `a` and `b` (empty when they are the same memory), each naming the
/// place, node, edge or peer. `with_peers` = false leaves the peers table out.
inline std::vector<std::string> Differences(const Knowledge& a, const Knowledge& b,
                                            bool with_peers = true) {
  using detail::BitwiseEqual;
  std::vector<std::string> out;
  const PlaceMemory& ma = a.state.memory;
  const PlaceMemory& mb = b.state.memory;
  if (ma.places().size() != mb.places().size()) {
    out.push_back(detail::Count("learned places", ma.places(), mb.places()));
  }
  for (size_t i = 0; i < std::min(ma.places().size(), mb.places().size()); ++i) {
    const LearnedPlace& p = ma.places()[i];
    const LearnedPlace& q = mb.places()[i];
    const std::string at = "place at position " + std::to_string(i) + " (" + p.id.ToString() + ")";
    if (!(p.id == q.id)) out.push_back(at + ": id " + q.id.ToString());
    if (!BitwiseEqual(p.mean, q.mean)) out.push_back(at + ": mean differs");
    if (!(p.samples == q.samples)) out.push_back(at + ": samples differ");
    if (p.member_count != q.member_count) out.push_back(at + ": member count differs");
    if (p.detected != q.detected) out.push_back(at + ": detected places differ");
    if (p.members != q.members) out.push_back(at + ": members differ");
    if (p.sources != q.sources) out.push_back(at + ": absorbed source ids differ");
  }
  if (ma.nodes().size() != mb.nodes().size()) {
    out.push_back(detail::Count("tree nodes", ma.nodes(), mb.nodes()));
  } else {
    for (size_t i = 0; i < ma.nodes().size(); ++i) {
      const MemoryNode& n = ma.nodes()[i];
      const MemoryNode& o = mb.nodes()[i];
      if (n.parent != o.parent || n.children != o.children || n.place != o.place ||
          std::memcmp(&n.height, &o.height, sizeof n.height) != 0 || n.first_leaf != o.first_leaf ||
          n.end_leaf != o.end_leaf || n.set_key != o.set_key) {
        out.push_back("tree node " + std::to_string(i) + " differs (parent " +
                      std::to_string(n.parent) + " vs " + std::to_string(o.parent) + ")");
      }
      const OneClassDiscriminant& d = ma.discriminants()[i];
      const OneClassDiscriminant& e = mb.discriminants()[i];
      if (d.trained() != e.trained() ||
          (d.trained() &&
           (!BitwiseEqual(d.support(), e.support()) || !BitwiseEqual(d.coef(), e.coef()) ||
            d.rho() != e.rho() || d.gamma() != e.gamma()))) {
        out.push_back("discriminant of tree node " + std::to_string(i) + " differs");
      }
    }
  }
  if (ma.leaf_order() != mb.leaf_order()) out.push_back("leaf order differs");
  if (ma.slink().pi() != mb.slink().pi() || ma.slink().lambda() != mb.slink().lambda()) {
    out.push_back("SLINK pointer representation differs");
  }
  if (ma.next_local_id() != mb.next_local_id()) out.push_back("next local id differs");

  const TopologicalMap& ga = a.state.map;
  const TopologicalMap& gb = b.state.map;
  if (ga.places() != gb.places())
    out.push_back(detail::Count("map places", ga.places(), gb.places()));
  for (const auto& [key, e] : ga.edges()) {
    const std::string name = "map edge " + e.a.ToString() + "-" + e.b.ToString();
    const auto it = gb.edges().find(key);
    if (it == gb.edges().end()) {
      out.push_back(name + " missing from the second");
      continue;
    }
    if (e.traversals != it->second.traversals) out.push_back(name + ": traversals differ");
    bool same = e.transitions.size() == it->second.transitions.size();
    for (size_t i = 0; same && i < e.transitions.size(); ++i) {
      same = e.transitions[i].first == it->second.transitions[i].first &&
             e.transitions[i].last == it->second.transitions[i].last;
    }
    if (!same) out.push_back(name + ": transition regions differ");
  }
  for (const auto& [key, e] : gb.edges()) {
    if (!ga.edges().contains(key)) {
      out.push_back("map edge " + e.a.ToString() + "-" + e.b.ToString() +
                    " missing from the first");
    }
  }
  if (with_peers) {
    for (const auto& [robot, p] : a.peers) {
      const auto it = b.peers.find(robot);
      if (it == b.peers.end()) {
        out.push_back("peer " + std::to_string(robot) + " merged only in the first");
      } else if (p.version != it->second.version || p.digest != it->second.digest) {
        out.push_back("peer " + std::to_string(robot) + ": merged version or digest differs");
      }
    }
    for (const auto& [robot, p] : b.peers) {
      if (!a.peers.contains(robot)) {
        out.push_back("peer " + std::to_string(robot) + " merged only in the second");
      }
    }
  }
  return out;
}

/// "" when equal, else the first differences, one a line (for test messages).
inline std::string DescribeDifferences(const Knowledge& a, const Knowledge& b,
                                       bool with_peers = true) {
  std::string s;
  const std::vector<std::string> d = Differences(a, b, with_peers);
  for (size_t i = 0; i < d.size() && i < 20; ++i) s += d[i] + "\n";
  if (d.size() > 20) s += "... " + std::to_string(d.size() - 20) + " more\n";
  return s;
}

}  // namespace tsc::testing_support
