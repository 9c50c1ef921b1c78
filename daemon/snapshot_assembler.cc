#include "daemon/snapshot_assembler.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace tsc {
namespace {

bool AllFinite(const std::vector<float>& v) {
  for (float x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

// Why one place of a portion cannot be right, or "".
// (A memory may hold places of other robots once it has merged theirs.)
std::string CheckPlace(const learned_place_t& p) {
  if (p.dims <= 0 || p.dims > SnapshotAssembler::kMaxDims) return "bad descriptor dimension";
  if (p.mean.size() != static_cast<size_t>(p.dims)) return "mean of the wrong size";
  if (!AllFinite(p.mean)) return "non-finite mean";
  if (p.num_samples < 0 || p.samples.size() != static_cast<size_t>(p.num_samples)) {
    return "bad sample count";
  }
  for (const auto& s : p.samples) {
    if (s.size() != static_cast<size_t>(p.dims) || !AllFinite(s)) return "bad sample";
  }
  if (p.member_count < 1) return "place without members";
  if (p.id.robot <= 0 || p.id.local <= 0) return "bad place id";
  if (!std::isfinite(p.slink_lambda)) return "non-finite SLINK height";
  return "";
}

}  // namespace

PlaceMemory ToPlaceMemory(const PeerSnapshot& snapshot, const PlaceMemoryOptions& options) {
  std::vector<LearnedPlace> places;
  std::vector<int> pi;
  std::vector<double> lambda;
  places.reserve(snapshot.places.size());
  for (const learned_place_t& m : snapshot.places) {
    LearnedPlace p;
    p.id = PlaceId{static_cast<uint32_t>(m.id.robot), static_cast<uint32_t>(m.id.local)};
    p.mean = Eigen::Map<const Eigen::VectorXf>(m.mean.data(), m.dims);
    p.member_count = m.member_count;
    p.samples.resize(m.dims, m.num_samples);
    for (int j = 0; j < m.num_samples; ++j) {
      p.samples.col(j) =
          Eigen::Map<const Eigen::VectorXf>(m.samples[static_cast<size_t>(j)].data(), m.dims);
    }
    for (const place_ref_t& s : m.sources) {
      p.sources.push_back(PlaceId{static_cast<uint32_t>(s.robot), static_cast<uint32_t>(s.local)});
    }
    std::sort(p.sources.begin(), p.sources.end());
    places.push_back(std::move(p));
    pi.push_back(m.slink_pi);
    lambda.push_back(m.slink_lambda < 0 ? Slink::kInfinity : m.slink_lambda);
  }
  return PlaceMemory::Restore(static_cast<uint32_t>(snapshot.robot), options, std::move(places),
                              Slink(std::move(pi), std::move(lambda)),
                              static_cast<uint32_t>(snapshot.next_local), {});
}

TopologicalMap ToTopologicalMap(const PeerSnapshot& snapshot) {
  TopologicalMap map;
  auto id = [](const place_ref_t& r) {
    return PlaceId{static_cast<uint32_t>(r.robot), static_cast<uint32_t>(r.local)};
  };
  for (const learned_place_t& p : snapshot.places) map.AddPlace(id(p.id));
  for (const map_edge_t& e : snapshot.edges) {
    if (id(e.a) == id(e.b)) throw std::invalid_argument("map edge from a place to itself");
    MapEdge edge;
    edge.a = std::min(id(e.a), id(e.b));
    edge.b = std::max(id(e.a), id(e.b));
    edge.traversals = e.traversals;
    map.RestoreEdge(std::move(edge));
  }
  return map;
}

void SnapshotAssembler::Reset() {
  version_ = -1;
  count_ = 0;
  portions_.clear();
}

SnapshotAssembler::Result SnapshotAssembler::Accept(const memory_portion_t& p) {
  auto reject = [](std::string why) { return Result{Verdict::kRejected, std::move(why)}; };
  if (p.robot != robot_) return reject("portion of robot " + std::to_string(p.robot));
  if (p.count < 1 || p.count > kMaxPortions) return reject("impossible portion count");
  if (p.index < 0 || p.index >= p.count) return reject("portion index out of range");
  if (p.total_places < 0 || p.total_places > kMaxPlaces || p.total_nodes < 0 ||
      p.total_nodes > 2 * kMaxPlaces || p.total_edges < 0) {
    return reject("impossible totals");
  }
  if (p.num_places != static_cast<int32_t>(p.places.size()) ||
      p.num_nodes != static_cast<int32_t>(p.nodes.size()) ||
      p.num_edges != static_cast<int32_t>(p.edges.size())) {
    return reject("array lengths disagree");
  }
  if (p.first_place < 0 || p.first_place + p.num_places > p.total_places) {
    return reject("places outside the snapshot");
  }
  for (const learned_place_t& place : p.places) {
    const std::string why = CheckPlace(place);
    if (!why.empty()) return reject(why);
  }
  for (const memory_node_t& n : p.nodes) {
    if (n.index < 0 || n.index >= p.total_nodes || !std::isfinite(n.height) ||
        n.num_children != static_cast<int32_t>(n.children.size())) {
      return reject("bad tree node");
    }
  }

  if (started() && p.version < version_) return {Verdict::kStale, "older version"};
  if (!started() || p.version > version_) {
    Reset();
    version_ = p.version;
    boot_id_ = p.boot_id;
    digest_ = p.digest;
    count_ = p.count;
    total_places_ = p.total_places;
    total_nodes_ = p.total_nodes;
    total_edges_ = p.total_edges;
  }
  if (p.count != count_ || p.digest != digest_ || p.total_places != total_places_ ||
      p.total_nodes != total_nodes_ || p.total_edges != total_edges_ || p.boot_id != boot_id_) {
    return reject("disagrees with the other portions of version " + std::to_string(version_));
  }
  if (portions_.count(p.index)) return {Verdict::kDuplicate, ""};
  memory_portion_t kept = p;
  kept.hmac_size = 0;  // the tag was checked by the caller; the digest covers unsigned portions
  kept.hmac.clear();
  portions_.emplace(p.index, std::move(kept));
  return {Verdict::kAccepted, ""};
}

std::vector<int32_t> SnapshotAssembler::Missing() const {
  std::vector<int32_t> missing;
  for (int32_t i = 0; i < count_; ++i) {
    if (!portions_.count(i)) missing.push_back(i);
  }
  return missing;
}

std::optional<PeerSnapshot> SnapshotAssembler::Take(std::string* reason) {
  auto fail = [&](const std::string& why) -> std::optional<PeerSnapshot> {
    if (reason != nullptr) *reason = why;
    Reset();
    return std::nullopt;
  };
  if (!complete()) return fail("incomplete");
  std::vector<memory_portion_t> ordered;
  ordered.reserve(portions_.size());
  for (const auto& [index, portion] : portions_) ordered.push_back(portion);
  if (SnapshotDigest(ordered) != digest_) return fail("digest mismatch");

  PeerSnapshot snap;
  snap.robot = robot_;
  snap.boot_id = boot_id_;
  snap.version = version_;
  snap.digest = digest_;
  for (auto& [index, portion] : portions_) {
    snap.next_local = portion.next_local;
    if (!portion.places.empty() &&
        portion.first_place != static_cast<int32_t>(snap.places.size())) {
      return fail("places out of order");
    }
    for (auto& p : portion.places) snap.places.push_back(std::move(p));
    for (auto& n : portion.nodes) snap.nodes.push_back(std::move(n));
    for (auto& e : portion.edges) snap.edges.push_back(std::move(e));
  }
  if (snap.places.size() != static_cast<size_t>(total_places_) ||
      snap.nodes.size() != static_cast<size_t>(total_nodes_) ||
      snap.edges.size() != static_cast<size_t>(total_edges_)) {
    return fail("totals not reached");
  }
  const int32_t dims = snap.places.empty() ? 0 : snap.places.front().dims;
  std::set<std::pair<int32_t, int32_t>> ids;
  const int32_t n = static_cast<int32_t>(snap.places.size());
  for (int32_t i = 0; i < n; ++i) {
    const learned_place_t& p = snap.places[static_cast<size_t>(i)];
    if (p.dims != dims) return fail("places of different dimensions");
    if (!ids.insert({p.id.robot, p.id.local}).second) return fail("duplicate place id");
    // SLINK pointer representation: π(i) > i for all but the last, whose λ is ∞ (−1 here).
    if (i + 1 < n && (p.slink_pi <= i || p.slink_pi >= n || p.slink_lambda < 0)) {
      return fail("inconsistent SLINK pointers");
    }
  }
  for (size_t i = 0; i < snap.nodes.size(); ++i) {
    const memory_node_t& node = snap.nodes[i];
    if (node.index != static_cast<int32_t>(i)) return fail("tree nodes out of order");
    if (node.parent < -1 || node.parent >= total_nodes_) return fail("bad tree parent");
    if (node.place < -1 || node.place >= n) return fail("tree node names no place");
    for (int32_t c : node.children) {
      if (c < 0 || c >= total_nodes_ || snap.nodes[static_cast<size_t>(c)].parent != node.index) {
        return fail("inconsistent tree");
      }
    }
  }
  for (const map_edge_t& e : snap.edges) {
    if (!ids.count({e.a.robot, e.a.local}) || !ids.count({e.b.robot, e.b.local})) {
      return fail("map edge between unknown places");
    }
  }
  Reset();
  return snap;
}

}  // namespace tsc
