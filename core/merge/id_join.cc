#include "core/merge/id_join.h"

#include <algorithm>
#include <unordered_set>

#include "core/memory/member_views.h"

namespace tsc {
namespace {

// The canonical id of a merged place (docs/decisions.md, "Merging": canonical ids): the
// smallest id of its group, its own id and every source. Which memory was the base decides
// which place absorbs which, so without it one settled team held 1:1{2:7,3:1} and
// 2:7{1:1,3:1} for one place. Returns the id it carried before (itself when unchanged).
PlaceId TakeSmallestId(LearnedPlace& p) {
  const PlaceId before = p.id;
  if (p.sources.empty() || !(p.sources.front() < p.id)) return before;
  p.id = p.sources.front();
  p.sources.erase(p.sources.begin());
  p.sources.insert(std::lower_bound(p.sources.begin(), p.sources.end(), before), before);
  return before;
}

}  // namespace

KnownIds KnownToBase(const PlaceMemory& base, std::span<const LearnedPlace> incoming) {
  KnownIds k;
  k.holder.reserve(base.places().size());
  for (size_t b = 0; b < base.places().size(); ++b) {
    k.holder.emplace(base.places()[b].id, static_cast<int>(b));
  }
  for (size_t b = 0; b < base.places().size(); ++b) {
    for (PlaceId s : base.places()[b].sources) k.holder.emplace(s, static_cast<int>(b));
  }
  k.is_new.assign(incoming.size(), 0);
  for (size_t i = 0; i < incoming.size(); ++i) {
    const PlaceId id = incoming[i].id;
    if (k.holder.contains(id)) {
      k.known.push_back(id);
    } else {
      k.is_new[i] = 1;
    }
  }
  k.anything_new = std::find(k.is_new.begin(), k.is_new.end(), 1) != k.is_new.end();
  return k;
}

FreshPlaces FreshBasePlaces(const PlaceMemory& base, std::span<const LearnedPlace> incoming) {
  FreshPlaces f;
  std::unordered_set<PlaceId, PlaceIdHash> seen;
  for (const LearnedPlace& p : incoming) {
    seen.insert(p.id);
    seen.insert(p.sources.begin(), p.sources.end());
  }
  for (size_t b = 0; b < base.places().size(); ++b) {
    const LearnedPlace& p = base.places()[b];
    if (!seen.contains(p.id)) f.places.push_back(static_cast<int>(b));
    f.base_knows_more = f.base_knows_more || !seen.contains(p.id) ||
                        !std::all_of(p.sources.begin(), p.sources.end(),
                                     [&seen](PlaceId id) { return seen.contains(id); });
  }
  return f;
}

int PlaceUnion::Find(int x) {
  while (holder_[static_cast<size_t>(x)] != x) {
    x = holder_[static_cast<size_t>(x)] =
        holder_[static_cast<size_t>(holder_[static_cast<size_t>(x)])];
  }
  return x;
}

void PlaceUnion::Unite(int a, int b) {
  a = Find(a);
  b = Find(b);
  if (a == b) return;
  if (b < a) std::swap(a, b);
  holder_[static_cast<size_t>(b)] = a;
  united_ = true;
}

std::vector<int> PlaceUnion::Holders() {
  std::vector<int> out(holder_.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = Find(static_cast<int>(i));
  return out;
}

IdJoin JoinByIds(const PlaceMemory& base, std::span<const LearnedPlace> incoming,
                 const std::unordered_map<PlaceId, int, PlaceIdHash>& known) {
  IdJoin j{PlaceUnion(base.places().size()), std::vector<int>(incoming.size(), -1), {}};
  for (size_t i = 0; i < incoming.size(); ++i) {
    const LearnedPlace& p = incoming[i];
    const auto own = known.find(p.id);
    int h = own == known.end() ? -1 : own->second;
    for (PlaceId s : p.sources) {
      const auto k = known.find(s);
      if (k == known.end()) {
        if (own != known.end()) j.learned.emplace_back(own->second, s);
      } else if (h < 0) {
        h = k->second;
      } else {
        j.places.Unite(h, k->second);
      }
    }
    if (own == known.end() && h >= 0) j.linked[i] = h;
  }
  return j;
}

std::vector<int> ResolveHolders(IdJoin& join, std::vector<int>& targets) {
  const std::vector<int> holder = join.places.Holders();
  for (int& t : targets) {
    if (t >= 0) t = holder[static_cast<size_t>(t)];
  }
  for (auto& [b, unused] : join.learned) b = holder[static_cast<size_t>(b)];
  return holder;
}

void AddSource(LearnedPlace& target, PlaceId id) {
  if (id == target.id) return;
  auto it = std::lower_bound(target.sources.begin(), target.sources.end(), id);
  if (it == target.sources.end() || *it != id) target.sources.insert(it, id);
}

bool CarriesSmallestId(const LearnedPlace& p) {
  return p.sources.empty() || p.id < p.sources.front();
}

void Absorb(LearnedPlace& target, const LearnedPlace& p, const PlaceMemoryOptions& options) {
  const auto n = static_cast<float>(target.member_count), m = static_cast<float>(p.member_count);
  target.mean = (target.mean * n + p.mean * m) / (n + m);
  target.member_count += p.member_count;  // both within kMaxMemberCount: no overflow
  HoldWithinBounds(target);
  AddSource(target, p.id);
  for (PlaceId s : p.sources) AddSource(target, s);
  const int max_samples = options.SampleCap(target);
  const Eigen::Index kept = target.samples.cols(), pooled = kept + p.samples.cols();
  if (pooled <= max_samples) {
    // Nothing to thin (ThinViews would return the pool as it is): p's views are appended in
    // place. Pooling into a new matrix and copying it out again was a quarter of a 10⁴ + 10⁴
    // merge, most of it faulting in fresh pages for the two copies.
    target.samples.Append(p.samples);
  } else {
    Eigen::MatrixXf both(target.samples.rows(), pooled);
    both << target.samples.Decoded(), p.samples.Decoded();
    target.samples.Encode(ThinViews(both, max_samples));
  }
}

void Fold(LearnedPlace& target, const LearnedPlace& b, const PlaceMemoryOptions& options) {
  if (target.id.robot == b.id.robot) {
    target.members.insert(target.members.end(), b.members.begin(), b.members.end());
    std::sort(target.members.begin(), target.members.end());
    target.detected.insert(target.detected.end(), b.detected.begin(), b.detected.end());
    std::sort(target.detected.begin(), target.detected.end());
  }
  Absorb(target, b, options);
}

void TakeSmallestIds(std::vector<LearnedPlace>& places, std::vector<Absorption>& absorbed) {
  std::unordered_map<PlaceId, PlaceId, PlaceIdHash> renamed;
  for (LearnedPlace& p : places) {
    if (const PlaceId before = TakeSmallestId(p); before != p.id) renamed.emplace(before, p.id);
  }
  if (renamed.empty()) return;
  for (Absorption& a : absorbed) {
    const auto it = renamed.find(a.target);
    if (it == renamed.end()) continue;
    if (a.source == it->second) a.source = a.target;
    a.target = it->second;
  }
}

uint32_t NextLocalId(const std::vector<LearnedPlace>& places, uint32_t robot, uint32_t next_local) {
  // A robot whose store was wiped gets its old places back from a peer: its new places are
  // numbered after every id of its own the team still holds, so no id is given twice (issue 21
  // item 5).
  uint32_t next = next_local;
  for (const LearnedPlace& p : places) {
    if (p.id.robot == robot) next = std::max(next, p.id.local + 1);
    for (const PlaceId& s : p.sources) {
      if (s.robot == robot) next = std::max(next, s.local + 1);
    }
  }
  return next;
}

}  // namespace tsc
