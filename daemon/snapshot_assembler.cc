#include "daemon/snapshot_assembler.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <stdexcept>

namespace tsc {
namespace {

// Finite, and small enough that a squared distance over kMaxDims of them stays finite (a
// descriptor holds normalised image statistics, far below this).
bool AllBounded(const std::vector<float>& v) {
  for (float x : v) {
    if (!std::isfinite(x) || std::abs(x) > SnapshotAssembler::kMaxDescriptorValue) return false;
  }
  return true;
}

// A body's member views as the memory keeps them. Precondition: CheckPlace(m) passed (else
// std::invalid_argument).
CompactViews ViewsOf(const learned_place_v2_t& m) {
  std::vector<int16_t> values;
  values.reserve(static_cast<size_t>(m.num_samples) * static_cast<size_t>(m.view_dims));
  for (const std::vector<int16_t>& col : m.samples)
    values.insert(values.end(), col.begin(), col.end());
  return CompactViews(m.view_dims, m.num_samples, m.view_shift, std::move(values));
}

// Whether views of `shift` stay within kMaxDescriptorValue (every |value| is below 2¹⁵).
bool ShiftBounded(int shift) {
  return std::ldexp(32768.0, -shift) <= SnapshotAssembler::kMaxDescriptorValue;
}

// Why one place of a portion cannot be right, or "".
// (A memory may hold places of other robots once it has merged theirs.)
std::string CheckPlace(const learned_place_v2_t& p) {
  if (p.dims <= 0 || p.dims > SnapshotAssembler::kMaxDims) return "bad descriptor dimension";
  if (p.mean.size() != static_cast<size_t>(p.dims)) return "mean of the wrong size";
  if (!AllBounded(p.mean)) return "non-finite or out-of-range mean";
  if (p.num_samples < 0 || p.samples.size() != static_cast<size_t>(p.num_samples)) {
    return "bad sample count";
  }
  if (p.view_dims <= 0 || p.view_dims > SnapshotAssembler::kMaxDims) return "bad view dimension";
  int largest = 0;
  for (const auto& s : p.samples) {
    if (s.size() != static_cast<size_t>(p.view_dims)) return "bad sample";
    for (int16_t v : s) largest = std::max(largest, std::abs(static_cast<int>(v)));
  }
  if (!ShiftBounded(p.view_shift)) return "out-of-range member views";
  if (!CompactViews::IsEncoding(p.view_shift, largest)) {
    return "member views that are no 16-bit encoding";
  }
  if (p.member_count < 1) return "place without members";
  if (p.id.robot <= 0 || p.id.local <= 0) return "bad place id";
  return "";
}

std::string CheckEntry(const place_entry_t& e) {
  if (e.id.robot <= 0 || e.id.local <= 0) return "bad place id";
  if (!std::isfinite(e.slink_lambda)) return "non-finite SLINK height";
  return "";
}

PlaceId IdOf(const place_ref_t& r) {
  return PlaceId{static_cast<uint32_t>(r.robot), static_cast<uint32_t>(r.local)};
}

std::vector<PlaceId> SortedSourcesOf(const learned_place_v2_t& m) {
  std::vector<PlaceId> sources;
  sources.reserve(m.sources.size());
  for (const place_ref_t& s : m.sources) sources.push_back(IdOf(s));
  std::sort(sources.begin(), sources.end());
  return sources;
}

}  // namespace

PlaceMemory ToPlaceMemory(PeerSnapshot snapshot, const PlaceMemoryOptions& options, int threads) {
  if (snapshot.unloaded != 0) throw std::invalid_argument("place bodies not loaded");
  if (snapshot.view_basis != ViewBasisId(options.view_basis.get())) {
    throw std::invalid_argument("robot " + std::to_string(snapshot.robot) +
                                " keeps member views in another view basis (memory.view_basis)");
  }
  std::vector<LearnedPlace> places;
  std::vector<int> pi;
  std::vector<double> lambda;
  places.reserve(snapshot.places.size());
  // The bodies are let go a batch at a time, not each after its place. tscd decodes them on
  // its event loop, and glibc's per-thread cache hands the small blocks this thread frees to
  // its next allocations of their size: freeing body i before building place i+1 put place
  // i+1's small blocks among the loop's bodies, each pinning a page of them once all were freed
  // (RSS 15 s after a merge 233 MB, 190 MB with that cache off; tscd_footprint --peer-merged
  // 1, session 86). Freed a batch at once, at most the cache's few blocks of a size go astray.
  constexpr size_t kReleaseBatch = 256;
  size_t unreleased = 0;
  for (size_t i = 0; i < snapshot.places.size(); ++i) {
    const learned_place_v2_t& m = *snapshot.places[i];
    LearnedPlace p;
    p.id = IdOf(m.id);
    p.mean = Eigen::Map<const Eigen::VectorXf>(m.mean.data(), m.dims);
    p.member_count = m.member_count;
    p.samples = ViewsOf(m);
    p.sources = SortedSourcesOf(m);
    places.push_back(std::move(p));
    if (i + 1 - unreleased == kReleaseBatch || i + 1 == snapshot.places.size()) {
      for (; unreleased <= i; ++unreleased) snapshot.places[unreleased].reset();
    }
    const place_entry_t& e = snapshot.entries[i];
    pi.push_back(e.slink_pi);
    lambda.push_back(e.slink_lambda < 0 ? Slink::kInfinity : e.slink_lambda);
  }
  return PlaceMemory::Restore(static_cast<uint32_t>(snapshot.robot), options, std::move(places),
                              Slink(std::move(pi), std::move(lambda)),
                              static_cast<uint32_t>(snapshot.next_local), {}, {}, threads);
}

std::optional<std::vector<LearnedPlace>> PlaceNamesOf(const PeerSnapshot& snapshot,
                                                      const PlaceMemory& ours,
                                                      const KeptPlaceNames* kept) {
  if (snapshot.view_basis != ViewBasisId(ours.options().view_basis.get())) return std::nullopt;
  std::vector<LearnedPlace> names(snapshot.places.size());
  for (size_t i = 0; i < names.size(); ++i) {
    const learned_place_v2_t* m = snapshot.places[i].get();
    if (m == nullptr) {  // left unloaded by Take: named by `kept`
      const auto name = kept ? kept->Find(snapshot.entries[i].body_digest) : std::nullopt;
      if (!name) return std::nullopt;
      if (!ours.empty() && kept->dims() != ours.places().front().mean.size()) return std::nullopt;
      names[i].id = name->id;
      names[i].sources.assign(name->sources.begin(), name->sources.end());
      continue;
    }
    if (!ours.empty() && m->dims != ours.places().front().mean.size()) return std::nullopt;
    names[i].id = IdOf(m->id);
    names[i].sources = SortedSourcesOf(*m);
  }
  return names;
}

bool LoadKeptBodies(PeerSnapshot& snapshot, const BodyLoader& load, std::string* reason) {
  if (snapshot.unloaded == 0) return true;
  const auto fail = [&](const std::string& why) {
    if (reason != nullptr) *reason = why;
    return false;
  };
  std::vector<int64_t> wanted;
  std::optional<int32_t> dims;
  for (size_t i = 0; i < snapshot.places.size(); ++i) {
    if (!snapshot.places[i]) {
      wanted.push_back(snapshot.entries[i].body_digest);
    } else if (!dims) {
      dims = snapshot.places[i]->dims;
    }
  }
  const PlaceBodies loaded = load ? load(KnownDigests(std::move(wanted))) : PlaceBodies{};
  for (size_t i = 0; i < snapshot.places.size(); ++i) {
    if (snapshot.places[i]) continue;
    const place_entry_t& e = snapshot.entries[i];
    const auto it = loaded.find(e.body_digest);
    if (it == loaded.end() || !it->second) {
      return fail("a place body kept from an earlier version is no longer kept");
    }
    if (IdOf(it->second->id) != IdOf(e.id)) return fail("a place body of another place");
    if (!dims) dims = it->second->dims;
    if (it->second->dims != *dims) return fail("places of different dimensions");
    snapshot.places[i] = it->second;
  }
  snapshot.unloaded = 0;
  return true;
}

KeptPlaceNames NamesOfBodies(const PeerSnapshot& snapshot, const KeptPlaceNames* earlier) {
  std::vector<KeptPlaceNames::Named> named;
  named.reserve(snapshot.places.size());
  int32_t dims = 0;
  for (size_t i = 0; i < snapshot.places.size(); ++i) {
    const int64_t digest = snapshot.entries[i].body_digest;
    if (const learned_place_v2_t* m = snapshot.places[i].get()) {
      dims = m->dims;
      named.push_back({digest, IdOf(m->id), SortedSourcesOf(*m)});
    } else if (const auto name = earlier ? earlier->Find(digest) : std::nullopt) {
      dims = earlier->dims();
      named.push_back({digest, name->id, {name->sources.begin(), name->sources.end()}});
    }
  }
  return KeptPlaceNames(dims, std::move(named));
}

TopologicalMap ToTopologicalMap(const PeerSnapshot& snapshot) {
  TopologicalMap map;
  for (const place_entry_t& e : snapshot.entries) map.AddPlace(IdOf(e.id));
  for (const map_edge_t& e : snapshot.edges) {
    if (IdOf(e.a) == IdOf(e.b)) throw std::invalid_argument("map edge from a place to itself");
    MapEdge edge;
    edge.a = std::min(IdOf(e.a), IdOf(e.b));
    edge.b = std::max(IdOf(e.a), IdOf(e.b));
    edge.traversals = e.traversals;
    map.RestoreEdge(std::move(edge));
  }
  return map;
}

template <typename F>
void SnapshotAssembler::ForEachEntry(F f) const {
  for (const auto& [index, portion] : structure_) {
    for (int32_t k = 0; k < portion.num_entries; ++k) {
      f(static_cast<size_t>(portion.first_place + k), portion.entries[static_cast<size_t>(k)]);
    }
  }
}

KnownDigests SnapshotAssembler::Named() const {
  std::vector<int64_t> digests;
  ForEachEntry([&](size_t, const place_entry_t& e) { digests.push_back(e.body_digest); });
  return KnownDigests(std::move(digests));
}

void SnapshotAssembler::Reset() {
  carried_.clear();
  Restart();
}

void SnapshotAssembler::Restart() {
  version_ = -1;
  count_ = 0;
  structure_portions_ = 0;
  structure_.clear();
  bodies_.clear();
  received_.clear();
  kept_.clear();
  digests_.clear();
  bodies_present_ = 0;
  received_bodies_ = 0;
}

SnapshotAssembler::Result SnapshotAssembler::Accept(const memory_portion_v2_t& p) {
  auto reject = [](std::string why) { return Result{Verdict::kRejected, std::move(why)}; };
  if (p.robot != robot_) return reject("portion of robot " + std::to_string(p.robot));
  if (p.count < 1 || p.count > kMaxPortions) return reject("impossible portion count");
  if (p.index < 0 || p.index >= p.count) return reject("portion index out of range");
  if (p.total_places < 0 || p.total_places > kMaxPlaces || p.total_nodes < 0 ||
      p.total_nodes > 2 * kMaxPlaces || p.total_edges < 0) {
    return reject("impossible totals");
  }
  if (p.structure_portions < 1 || p.count - p.structure_portions != p.total_places) {
    return reject("bodies and places disagree");
  }
  if (p.num_entries != static_cast<int32_t>(p.entries.size()) ||
      p.num_places != static_cast<int32_t>(p.places.size()) ||
      p.num_nodes != static_cast<int32_t>(p.nodes.size()) ||
      p.num_edges != static_cast<int32_t>(p.edges.size())) {
    return reject("array lengths disagree");
  }
  if (p.index < p.structure_portions) {
    if (p.num_places != 0) return reject("a body in the structure");
    if (p.first_place < 0 || p.first_place + p.num_entries > p.total_places) {
      return reject("places outside the snapshot");
    }
    for (const place_entry_t& e : p.entries) {
      const std::string why = CheckEntry(e);
      if (!why.empty()) return reject(why);
    }
    for (const memory_node_t& n : p.nodes) {
      if (n.index < 0 || n.index >= p.total_nodes || !std::isfinite(n.height) ||
          n.num_children != static_cast<int32_t>(n.children.size())) {
        return reject("bad tree node");
      }
    }
  } else {
    if (p.num_places != 1 || p.num_entries != 0 || p.num_nodes != 0 || p.num_edges != 0 ||
        p.first_place != p.index - p.structure_portions) {
      return reject("a body portion that is not one place");
    }
    const std::string why = CheckPlace(p.places.front());
    if (!why.empty()) return reject(why);
  }

  if (started() && p.version < version_) return {Verdict::kStale, "older version"};
  if (!started() || p.version > version_) {
    Carry();
    Restart();
    version_ = p.version;
    boot_id_ = p.boot_id;
    digest_ = p.digest;
    view_basis_ = p.view_basis;
    count_ = p.count;
    structure_portions_ = p.structure_portions;
    total_places_ = p.total_places;
    total_nodes_ = p.total_nodes;
    total_edges_ = p.total_edges;
    bodies_.assign(static_cast<size_t>(total_places_), nullptr);
    received_.assign(static_cast<size_t>(total_places_), false);
    kept_.assign(static_cast<size_t>(total_places_), false);
    digests_.assign(static_cast<size_t>(total_places_), 0);
  }
  if (p.count != count_ || p.structure_portions != structure_portions_ || p.digest != digest_ ||
      p.total_places != total_places_ || p.total_nodes != total_nodes_ ||
      p.total_edges != total_edges_ || p.boot_id != boot_id_ || p.view_basis != view_basis_) {
    return reject("disagrees with the other portions of version " + std::to_string(version_));
  }
  return Keep(p);
}

SnapshotAssembler::Result SnapshotAssembler::Keep(const memory_portion_v2_t& p) {
  if (p.index >= structure_portions_) {
    const auto i = static_cast<size_t>(p.first_place);
    if (received_[i]) return {Verdict::kDuplicate, ""};
    // A body that came anyway replaces a known one: its digest is checked against the entry.
    if (!bodies_[i] && !kept_[i]) ++bodies_present_;
    kept_[i] = false;
    bodies_[i] = std::make_shared<const learned_place_v2_t>(p.places.front());
    received_[i] = true;
    ++received_bodies_;
    return {Verdict::kAccepted, ""};
  }
  if (structure_.count(p.index)) return {Verdict::kDuplicate, ""};
  memory_portion_v2_t kept = p;
  kept.hmac_size = 0;  // the tag was checked by the caller; the digest covers unsigned portions
  kept.hmac.clear();
  structure_.emplace(p.index, std::move(kept));
  if (structure_complete()) FillKnownBodies();
  return {Verdict::kAccepted, ""};
}

bool SnapshotAssembler::knows_bodies() const {
  return (known_ && !known_->empty()) || !carried_.empty();
}

void SnapshotAssembler::FillKnownBodies() {
  if (!knows_bodies()) return;
  ForEachEntry([&](size_t i, const place_entry_t& e) {
    if (bodies_[i]) return;
    // One carried is at hand; a known one is loaded by Take.
    if (const auto it = carried_.find(e.body_digest); it != carried_.end()) {
      bodies_[i] = it->second;
    } else if (known_ && known_->contains(e.body_digest)) {
      kept_[i] = true;
    } else {
      return;
    }
    digests_[i] = e.body_digest;
    ++bodies_present_;
  });
  carried_.clear();  // what this version uses is in bodies_ now, and carried again from there
}

void SnapshotAssembler::Carry() {
  // A peer whose memory changes faster than a whole copy of it arrives would otherwise restart
  // us from nothing at each change: the bodies of the version given up are kept for the next,
  // each under the digest of its content (computed for the ones received, so they need no
  // further check), until a whole structure has named what it still uses.
  for (size_t i = 0; i < bodies_.size(); ++i) {
    if (!bodies_[i]) continue;
    carried_.emplace(received_[i] ? BodyDigest(*bodies_[i]) : digests_[i], bodies_[i]);
  }
  // Versions that never showed a whole structure cannot pile up without bound.
  if (carried_.size() > static_cast<size_t>(kMaxPlaces)) carried_.clear();
}

std::vector<int32_t> SnapshotAssembler::Missing() const {
  std::vector<int32_t> missing;
  for (int32_t i = 0; i < structure_portions_; ++i) {
    if (!structure_.count(i)) missing.push_back(i);
  }
  // Known bodies are matched only once the structure names the digests.
  if (!structure_complete() && knows_bodies()) return missing;
  for (int32_t i = 0; i < total_places_; ++i) {
    const auto k = static_cast<size_t>(i);
    if (!bodies_[k] && !kept_[k]) missing.push_back(structure_portions_ + i);
  }
  return missing;
}

std::optional<PeerSnapshot> SnapshotAssembler::Take(std::string* reason, const BodyLoader& load,
                                                    const KeptPlaceNames* names) {
  auto fail = [&](const std::string& why) -> std::optional<PeerSnapshot> {
    if (reason != nullptr) *reason = why;
    Reset();
    return std::nullopt;
  };
  if (!complete()) return fail("incomplete");
  bool by_name = names != nullptr;  // every known body named
  for (size_t i = 0; i < kept_.size() && by_name; ++i) {
    by_name = !kept_[i] || names->Find(digests_[i]).has_value();
  }
  std::vector<memory_portion_v2_t> ordered;
  ordered.reserve(structure_.size());
  for (const auto& [index, portion] : structure_) ordered.push_back(portion);
  if (SnapshotDigest(ordered) != digest_) return fail("digest mismatch");

  PeerSnapshot snap;
  snap.robot = robot_;
  snap.boot_id = boot_id_;
  snap.version = version_;
  snap.digest = digest_;
  snap.view_basis = view_basis_;
  for (auto& [index, portion] : structure_) {
    snap.next_local = portion.next_local;
    if (!portion.entries.empty() &&
        portion.first_place != static_cast<int32_t>(snap.entries.size())) {
      return fail("places out of order");
    }
    for (auto& e : portion.entries) snap.entries.push_back(std::move(e));
    for (auto& n : portion.nodes) snap.nodes.push_back(std::move(n));
    for (auto& e : portion.edges) snap.edges.push_back(std::move(e));
  }
  if (snap.entries.size() != static_cast<size_t>(total_places_) ||
      snap.nodes.size() != static_cast<size_t>(total_nodes_) ||
      snap.edges.size() != static_cast<size_t>(total_edges_)) {
    return fail("totals not reached");
  }
  // The known bodies are null here: loaded now, unless their names do.
  snap.places = std::move(bodies_);
  snap.unloaded = static_cast<int32_t>(std::count(kept_.begin(), kept_.end(), true));
  if (!by_name) {
    std::string why;
    if (!LoadKeptBodies(snap, load, &why)) return fail(why);
  }
  const int32_t n = static_cast<int32_t>(snap.entries.size());
  for (int32_t i = 0; i < n; ++i) {
    const place_entry_t& e = snap.entries[static_cast<size_t>(i)];
    if (!snap.places[static_cast<size_t>(i)]) {  // kept, and known by its name alone
      if (names->Find(digests_[static_cast<size_t>(i)])->id != IdOf(e.id)) {
        return fail("a place body of another place");
      }
      continue;
    }
    const learned_place_v2_t& body = *snap.places[static_cast<size_t>(i)];
    // Known bodies were checked when they came; a received one is checked here.
    if (received_[static_cast<size_t>(i)] && BodyDigest(body) != e.body_digest) {
      return fail("a place body does not match its digest");
    }
    if (body.id.robot != e.id.robot || body.id.local != e.id.local) {
      return fail("a place body of another place");
    }
  }
  const auto dims_of = [&](size_t i) {
    return snap.places[i] ? snap.places[i]->dims : names->dims();
  };
  const int32_t dims = snap.places.empty() ? 0 : dims_of(0);
  std::set<std::pair<int32_t, int32_t>> ids;
  for (int32_t i = 0; i < n; ++i) {
    const place_entry_t& e = snap.entries[static_cast<size_t>(i)];
    if (dims_of(static_cast<size_t>(i)) != dims) {
      return fail("places of different dimensions");
    }
    if (!ids.insert({e.id.robot, e.id.local}).second) return fail("duplicate place id");
    // SLINK pointer representation: π(i) > i for all but the last, whose λ is ∞ (−1 here).
    if (i + 1 < n && (e.slink_pi <= i || e.slink_pi >= n || e.slink_lambda < 0)) {
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
