#include "daemon/memory_snapshot.h"

#include <openssl/evp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "daemon/lcm_bus.h"

namespace tsc {
namespace {

place_ref_t Ref(PlaceId id) {
  place_ref_t r;
  r.robot = static_cast<int32_t>(id.robot);
  r.local = static_cast<int32_t>(id.local);
  return r;
}

learned_place_v2_t ToMessage(const LearnedPlace& p) {
  learned_place_v2_t m;
  m.id = Ref(p.id);
  m.member_count = p.member_count;
  m.dims = static_cast<int32_t>(p.mean.size());
  m.mean.assign(p.mean.data(), p.mean.data() + p.mean.size());
  m.num_samples = static_cast<int32_t>(p.samples.cols());
  m.view_dims = static_cast<int32_t>(p.samples.rows());
  m.view_shift = static_cast<int16_t>(p.samples.shift());
  m.samples.resize(static_cast<size_t>(m.num_samples));
  for (int j = 0; j < m.num_samples; ++j) {
    std::vector<int16_t>& col = m.samples[static_cast<size_t>(j)];
    col.reserve(static_cast<size_t>(m.view_dims));
    for (int r = 0; r < m.view_dims; ++r) col.push_back(p.samples.WideAt(r, j));
  }
  for (const PlaceId& s : p.sources) m.sources.push_back(Ref(s));
  m.num_sources = static_cast<int32_t>(m.sources.size());
  return m;
}

// Whether `m` is the body ToMessage(p) gives, compared value by value (bit for bit: a place
// whose floats or views changed in any way is encoded again).
bool SameBody(const LearnedPlace& p, const learned_place_v2_t& m) {
  const auto same_floats = [](const float* a, const float* b, size_t n) {
    return n == 0 || std::memcmp(a, b, n * sizeof(float)) == 0;
  };
  if (m.id.robot != static_cast<int32_t>(p.id.robot) ||
      m.id.local != static_cast<int32_t>(p.id.local) || m.member_count != p.member_count ||
      m.dims != p.mean.size() || m.num_samples != p.samples.cols() ||
      m.view_dims != p.samples.rows() || m.view_shift != p.samples.shift() ||
      m.sources.size() != p.sources.size() ||
      !same_floats(m.mean.data(), p.mean.data(), m.mean.size())) {
    return false;
  }
  for (int j = 0; j < m.num_samples; ++j) {
    const std::vector<int16_t>& col = m.samples[static_cast<size_t>(j)];
    if (col.size() != static_cast<size_t>(m.view_dims)) return false;
    for (int r = 0; r < m.view_dims; ++r) {
      if (col[static_cast<size_t>(r)] != p.samples.WideAt(r, j)) return false;
    }
  }
  for (size_t k = 0; k < p.sources.size(); ++k) {
    if (m.sources[k].robot != static_cast<int32_t>(p.sources[k].robot) ||
        m.sources[k].local != static_cast<int32_t>(p.sources[k].local)) {
      return false;
    }
  }
  return true;
}

// The bodies of `previous` by place id, for places whose index moved (after a merge).
class PreviousBodies {
 public:
  explicit PreviousBodies(const MemorySnapshot* previous) : previous_(previous) {}

  // The index in `previous` of the body of place `id`, expected at `hint`; -1 when none.
  int Find(PlaceId id, size_t hint) {
    if (previous_ == nullptr) return -1;
    const auto& bodies = previous_->bodies;
    const auto is = [&](size_t i) {
      return bodies[i]->id.robot == static_cast<int32_t>(id.robot) &&
             bodies[i]->id.local == static_cast<int32_t>(id.local);
    };
    if (hint < bodies.size() && is(hint)) return static_cast<int>(hint);
    if (by_id_.empty()) {
      for (size_t i = 0; i < bodies.size(); ++i) {
        by_id_.emplace(Key(bodies[i]->id.robot, bodies[i]->id.local), static_cast<int>(i));
      }
    }
    const auto it =
        by_id_.find(Key(static_cast<int32_t>(id.robot), static_cast<int32_t>(id.local)));
    return it == by_id_.end() ? -1 : it->second;
  }

 private:
  static uint64_t Key(int32_t robot, int32_t local) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(robot)) << 32) |
           static_cast<uint32_t>(local);
  }
  const MemorySnapshot* previous_;
  std::unordered_map<uint64_t, int> by_id_;
};

place_entry_t ToEntry(PlaceId id, int64_t digest, int pi, double lambda) {
  place_entry_t e;
  e.id = Ref(id);
  e.body_digest = digest;
  e.slink_pi = pi;
  e.slink_lambda = std::isinf(lambda) ? -1.0 : lambda;
  return e;
}

// First 8 bytes (big endian) of a finished SHA-256.
int64_t Prefix(EVP_MD_CTX* sha) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int md_size = 0;
  EVP_DigestFinal_ex(sha, md, &md_size);
  uint64_t digest = 0;
  for (int i = 0; i < 8; ++i) digest = (digest << 8) | md[i];
  return static_cast<int64_t>(digest);
}

memory_node_t ToMessage(const MemoryNode& n, int index) {
  memory_node_t m;
  m.index = index;
  m.parent = n.parent;
  m.place = n.place;
  m.height = n.height;
  m.num_children = static_cast<int32_t>(n.children.size());
  m.children.assign(n.children.begin(), n.children.end());
  return m;
}

map_edge_t ToMessage(const MapEdge& e) {
  map_edge_t m;
  m.a = Ref(e.a);
  m.b = Ref(e.b);
  m.traversals = e.traversals;
  return m;
}

// The rest of `snap` around the bodies chosen (snap.bodies, snap.body_digests, one per place).
void Cut(const PlaceMemory& memory, const TopologicalMap& map, const SnapshotHeader& header,
         int portion_bytes, MemorySnapshot& snap) {
  snap.version = header.version;
  snap.places = static_cast<int32_t>(memory.places().size());
  snap.view_basis = ViewBasisId(memory.view_basis());
  snap.edges = static_cast<int32_t>(map.edges().size());

  memory_portion_v2_t blank;
  blank.utime = header.utime;
  blank.robot = header.robot;
  blank.boot_id = header.boot_id;
  blank.version = header.version;
  blank.total_places = snap.places;
  blank.total_nodes = static_cast<int32_t>(memory.nodes().size());
  blank.total_edges = snap.edges;
  blank.next_local = static_cast<int32_t>(memory.next_local_id());
  blank.view_basis = ViewBasisId(memory.view_basis());
  blank.first_place = 0;
  blank.index = blank.count = blank.structure_portions = 0;
  blank.digest = 0;
  blank.num_entries = blank.num_places = blank.num_nodes = blank.num_edges = 0;
  blank.hmac_size = 0;
  // Room left for the HMAC the exchange adds later (issue: merging).
  const int64_t budget = portion_bytes - 64;
  const int64_t empty_size = blank.getEncodedSize();

  std::vector<place_entry_t> entries;
  entries.reserve(memory.places().size());
  const auto& pi = memory.slink().pi();
  const auto& lambda = memory.slink().lambda();
  for (size_t i = 0; i < memory.places().size(); ++i) {
    entries.push_back(ToEntry(memory.places()[i].id, snap.body_digests[i], pi[i], lambda[i]));
  }

  memory_portion_v2_t current = blank;
  int64_t size = empty_size;
  auto flush = [&] {
    current.num_entries = static_cast<int32_t>(current.entries.size());
    current.num_nodes = static_cast<int32_t>(current.nodes.size());
    current.num_edges = static_cast<int32_t>(current.edges.size());
    snap.structure.push_back(std::move(current));
    current = blank;
    size = empty_size;
  };
  auto room_for = [&](int64_t item) {
    if (size + item > budget && size > empty_size) flush();
    size += item;
  };
  for (size_t i = 0; i < entries.size(); ++i) {
    room_for(entries[i]._getEncodedSizeNoHash());
    if (current.entries.empty()) current.first_place = static_cast<int32_t>(i);
    current.entries.push_back(std::move(entries[i]));
  }
  for (size_t i = 0; i < memory.nodes().size(); ++i) {
    memory_node_t n = ToMessage(memory.nodes()[i], static_cast<int>(i));
    room_for(n._getEncodedSizeNoHash());
    current.nodes.push_back(std::move(n));
  }
  for (const auto& [key, edge] : map.edges()) {
    map_edge_t e = ToMessage(edge);
    room_for(e._getEncodedSizeNoHash());
    current.edges.push_back(std::move(e));
  }
  flush();  // the last (or only, for an empty memory) structure portion

  snap.structure_portions = static_cast<int32_t>(snap.structure.size());
  const int32_t count = snap.count();
  for (int32_t i = 0; i < snap.structure_portions; ++i) {
    memory_portion_v2_t& p = snap.structure[static_cast<size_t>(i)];
    p.index = i;
    p.count = count;
    p.structure_portions = snap.structure_portions;
  }
  snap.digest = SnapshotDigest(snap.structure);
  for (auto& p : snap.structure) p.digest = snap.digest;
  snap.body_header = blank;
  snap.body_header.count = count;
  snap.body_header.structure_portions = snap.structure_portions;
  snap.body_header.digest = snap.digest;
  snap.body_header.num_places = 1;
}

}  // namespace

learned_place_v2_t BodyOf(const LearnedPlace& place) { return ToMessage(place); }

MemorySnapshot BuildSnapshot(const PlaceMemory& memory, const TopologicalMap& map,
                             const SnapshotHeader& header, int portion_bytes,
                             const MemorySnapshot* previous) {
  MemorySnapshot snap;
  PreviousBodies before(previous);
  snap.bodies.reserve(memory.places().size());
  snap.body_digests.reserve(memory.places().size());
  for (size_t i = 0; i < memory.places().size(); ++i) {
    const LearnedPlace& place = memory.places()[i];
    const int old = before.Find(place.id, i);
    if (old >= 0 && SameBody(place, *previous->bodies[static_cast<size_t>(old)])) {
      snap.bodies.push_back(previous->bodies[static_cast<size_t>(old)]);
      snap.body_digests.push_back(previous->body_digests[static_cast<size_t>(old)]);
    } else {
      auto body = std::make_shared<const learned_place_v2_t>(ToMessage(place));
      snap.body_digests.push_back(BodyDigest(*body));
      snap.bodies.push_back(std::move(body));
    }
  }
  Cut(memory, map, header, portion_bytes, snap);
  return snap;
}

MemorySnapshot BuildSnapshotWithoutBodies(const PlaceMemory& memory, const TopologicalMap& map,
                                          const SnapshotHeader& header, int portion_bytes,
                                          const MemorySnapshot* previous,
                                          const std::unordered_set<int>& changed) {
  MemorySnapshot snap;
  const size_t n = memory.places().size();
  snap.bodies.resize(n);
  snap.body_digests.reserve(n);
  const size_t known = previous ? previous->body_digests.size() : 0;
  for (size_t i = 0; i < n; ++i) {
    snap.body_digests.push_back(i < known && !changed.count(static_cast<int>(i))
                                    ? previous->body_digests[i]
                                    : BodyDigest(ToMessage(memory.places()[i])));
  }
  Cut(memory, map, header, portion_bytes, snap);
  return snap;
}

const memory_portion_v2_t& MemorySnapshot::Portion(int32_t index, memory_portion_v2_t& scratch,
                                                   const learned_place_v2_t* body) const {
  if (index < 0 || index >= count()) {
    throw std::out_of_range("memory snapshot: no portion " + std::to_string(index) + " of " +
                            std::to_string(count()));
  }
  if (index < structure_portions) return structure[static_cast<size_t>(index)];
  scratch = body_header;
  scratch.index = index;
  scratch.first_place = index - structure_portions;
  if (body == nullptr) body = bodies[static_cast<size_t>(scratch.first_place)].get();
  if (body == nullptr) {
    throw std::logic_error("memory snapshot: body " + std::to_string(scratch.first_place) +
                           " is not held");
  }
  scratch.places.push_back(*body);
  return scratch;
}

memory_portion_v2_t MemorySnapshot::Portion(int32_t index) const {
  memory_portion_v2_t scratch;
  return Portion(index, scratch);
}

std::vector<memory_portion_v2_t> AllPortions(const MemorySnapshot& snapshot) {
  std::vector<memory_portion_v2_t> out;
  out.reserve(static_cast<size_t>(snapshot.count()));
  for (int32_t i = 0; i < snapshot.count(); ++i) out.push_back(snapshot.Portion(i));
  return out;
}

int64_t SnapshotDigest(const std::vector<memory_portion_v2_t>& portions) {
  EVP_MD_CTX* sha = EVP_MD_CTX_new();
  EVP_DigestInit_ex(sha, EVP_sha256(), nullptr);
  for (const memory_portion_v2_t& p : portions) {
    if (p.index >= p.structure_portions) continue;  // a body: named by its digest in the entries
    // Content only: the same memory republished under another version, boot or time keeps
    // its digest, so peers do not fetch it again.
    memory_portion_v2_t unsigned_portion = p;
    unsigned_portion.utime = 0;
    unsigned_portion.boot_id = 0;
    unsigned_portion.version = 0;
    unsigned_portion.digest = 0;
    unsigned_portion.hmac_size = 0;
    unsigned_portion.hmac.clear();
    const std::vector<uint8_t> bytes = LcmBus::Encode(unsigned_portion);
    EVP_DigestUpdate(sha, bytes.data(), bytes.size());
  }
  const int64_t digest = Prefix(sha);
  EVP_MD_CTX_free(sha);
  return digest;
}

namespace {

int64_t DigestOf(std::span<const uint8_t> bytes) {
  EVP_MD_CTX* sha = EVP_MD_CTX_new();
  EVP_DigestInit_ex(sha, EVP_sha256(), nullptr);
  EVP_DigestUpdate(sha, bytes.data(), bytes.size());
  const int64_t digest = Prefix(sha);
  EVP_MD_CTX_free(sha);
  return digest;
}

}  // namespace

std::vector<uint8_t> EncodeBody(const learned_place_v2_t& body) {
  std::vector<uint8_t> bytes(static_cast<size_t>(body._getEncodedSizeNoHash()));
  body._encodeNoHash(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

int64_t BodyDigest(const learned_place_v2_t& body) { return DigestOf(EncodeBody(body)); }

std::optional<learned_place_v2_t> DecodeBody(std::span<const uint8_t> bytes, int64_t digest) {
  // Hashed first: bytes that are not what EncodeBody wrote are never decoded.
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max()) ||
      DigestOf(bytes) != digest) {
    return std::nullopt;
  }
  learned_place_v2_t body;
  const int size = static_cast<int>(bytes.size());
  if (body._decodeNoHash(bytes.data(), 0, size) != size) return std::nullopt;
  return body;
}

std::vector<int32_t> PortionsBelow(int32_t n) {
  std::vector<int32_t> indices(static_cast<size_t>(std::max(n, 0)));
  std::iota(indices.begin(), indices.end(), 0);
  return indices;
}

std::vector<int32_t> PortionsBeyond(const MemorySnapshot& snapshot,
                                    const std::unordered_set<int64_t>& known) {
  std::vector<int32_t> indices = PortionsBelow(snapshot.structure_portions);
  for (size_t i = 0; i < snapshot.body_digests.size(); ++i) {
    if (!known.count(snapshot.body_digests[i])) {
      indices.push_back(snapshot.structure_portions + static_cast<int32_t>(i));
    }
  }
  return indices;
}

void DescribeInAnnounce(const MemorySnapshot& snapshot, announce_t& a) {
  a.memory_version = snapshot.version;
  a.memory_digest = snapshot.digest;
  a.portions = snapshot.count();
  a.structure_portions = snapshot.structure_portions;
  a.view_basis = snapshot.view_basis;
}

void SnapshotBodies::Track(const std::shared_ptr<const MemorySnapshot>& snapshot) {
  Prune();
  tracked_.push_back(Tracked{snapshot, snapshot->places, {}});
}

void SnapshotBodies::BeforeUpdate(const PlaceMemory& memory, int place) {
  Prune();
  std::shared_ptr<const learned_place_v2_t> body;  // encoded once for every snapshot that needs it
  for (Tracked& t : tracked_) {
    if (place >= t.places || t.kept.count(place)) continue;
    if (!body) {
      body = std::make_shared<const learned_place_v2_t>(
          ToMessage(memory.places().at(static_cast<size_t>(place))));
    }
    t.kept.emplace(place, body);
  }
}

void SnapshotBodies::BeforeReplace() { tracked_.clear(); }

bool SnapshotBodies::Serves(const MemorySnapshot& snapshot) { return Find(snapshot) != nullptr; }

std::optional<std::unordered_set<int>> SnapshotBodies::ChangedSince(
    const MemorySnapshot& snapshot) {
  const Tracked* t = Find(snapshot);
  if (t == nullptr) return std::nullopt;
  std::unordered_set<int> changed;
  for (const auto& [place, body] : t->kept) changed.insert(place);
  return changed;
}

std::shared_ptr<const learned_place_v2_t> SnapshotBodies::Body(const MemorySnapshot& snapshot,
                                                               int place,
                                                               const PlaceMemory& memory) {
  const Tracked* t = Find(snapshot);
  if (t == nullptr) return nullptr;
  if (const auto kept = t->kept.find(place); kept != t->kept.end()) return kept->second;
  auto body = std::make_shared<const learned_place_v2_t>(
      ToMessage(memory.places().at(static_cast<size_t>(place))));
  // A place changed without BeforeUpdate would go out under its old body's digest, which every
  // peer refuses: refused here instead, where tscd can say so.
  if (BodyDigest(*body) != snapshot.body_digests.at(static_cast<size_t>(place))) return nullptr;
  return body;
}

size_t SnapshotBodies::tracked() {
  Prune();
  return tracked_.size();
}

SnapshotBodies::Tracked* SnapshotBodies::Find(const MemorySnapshot& snapshot) {
  for (Tracked& t : tracked_) {
    // Alive, so no other snapshot has its address.
    if (t.snapshot.lock().get() == &snapshot) return &t;
  }
  return nullptr;
}

void SnapshotBodies::Prune() {
  std::erase_if(tracked_, [](const Tracked& t) { return t.snapshot.expired(); });
}

int64_t ViewBasisId(const ViewBasis* basis) {
  return basis ? std::bit_cast<int64_t>(basis->id()) : 0;
}

}  // namespace tsc
