// Merging two place memories (DESIGN §8: two memories of 10⁴ places each, bar ≤ 1 s) and the
// reference ratio merge ÷ one-by-one relearning of the peer's places (recognise each against
// our memory; update on recognition, learn otherwise), the relearning cost extrapolated from
// a sample of the peer's places. Synthetic places on the descriptor scale (dimension 1200, the
// default features').

#include <benchmark/benchmark.h>
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "core/memory/builtin_view_basis.h"
#include "core/merge/merge.h"
#include "core/merge/merge_cases.h"
#include "daemon/memory_snapshot.h"
#include "settings/daemon_options.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

constexpr int kDim = 1200;
constexpr int kMembers = 12;
constexpr int kRelearnSample = 64;
constexpr int kLarge = testing_support::kLargeMemory;

// Places of a world of `sites` sites (test/support/synthetic_places.h; 64 unless given):
// place p of world w is its site's centre perturbed by 20 %, members by another 2 %. A robot
// sees place (w, p) with its own member noise (its id is the visit).
constexpr int kSites = 64;

// Base points of a place's visits and how many visits it holds, for `caps` 0: kMembers views
// (the fixture of the first benchmarks); 1: the 32 views a place seen once keeps (the default
// memory.max_samples_per_place; its visit has more base points than that); 2: the 64 of a place
// seen twice (memory.sample_visits 2), what a long-lived memory's places reach.
std::pair<int, int> PlaceCaps(int caps) {
  switch (caps) {
    case 0:
      return {kMembers, 1};
    case 1:
      return {48, 1};
    case 2:
      return {96, 2};
    default:
      throw std::invalid_argument("caps " + std::to_string(caps));
  }
}
class World {
 public:
  // `near`: the places made to lie as near the builtin view basis as real descriptors do
  // (BM_Learn/*/2's residual: the real loop keeps ~99 % of its energy in the basis; left
  // alone, the noise spreads 90 % of it outside).
  World(uint32_t world, int sites, bool near) : places_(world, kDim, sites, 0.02f, world) {
    if (near) places_.LieIn(BuiltinViewBasis(), 0.033f);
  }
  const testing_support::SyntheticPlaces& places() const { return places_; }

 private:
  testing_support::SyntheticPlaces places_;
};

// Robot `robot`'s memory of `n` places: places [first, first + n) of `world`; with `basis`,
// its member views kept in tscd's builtin view basis (core/memory/builtin_view_basis.h), as
// tscd keeps them, else as descriptors.
// `caps`: the views a place keeps (PlaceCaps).
PlaceMemory BuildMemory(uint32_t robot, const World& world, int first, int n, bool basis,
                        int caps) {
  PlaceMemoryOptions options;
  if (basis) options.view_basis = BuiltinViewBasis();
  const auto [views, visits] = PlaceCaps(caps);
  // 10⁵ places (issue 23): built at once, the SLINK tree over the means in the basis
  // (test/support/synthetic_places.h); n² descriptor distances would take hours.
  if (n >= kLarge) {
    return testing_support::LargeSyntheticMemory(robot, world.places(), first, n, views, options,
                                                 visits);
  }
  return testing_support::SyntheticMemory(robot, world.places(), first, n, views, options, visits);
}

// Pairs built once per (n, shared %, basis): robot 1 sees places [0, n) of world 1; robot 2
// sees `shared` % of the same places (its own member noise) and the rest from places [n, ...)
// — or, with shared = 0, places of another world.
const std::pair<PlaceMemory, PlaceMemory>& Pair(int n, int shared, bool basis, int sites = kSites,
                                                bool near = false, int caps = 0) {
  static std::map<std::tuple<int, int, bool, int, bool, int>,
                  std::unique_ptr<std::pair<PlaceMemory, PlaceMemory>>>
      cache;
  auto& slot = cache[{n, shared, basis, sites, near, caps}];
  if (!slot) {
    const World one(1, sites, near), two(2, sites, near);
    const int overlap = n * shared / 100;
    PlaceMemory a = BuildMemory(1, one, 0, n, basis, caps);
    PlaceMemory b =
        shared == 0 ? BuildMemory(2, two, 0, n, basis, caps)
                    : BuildMemory(2, one, n - overlap, n, basis, caps);  // last `overlap` of a's
    slot = std::make_unique<std::pair<PlaceMemory, PlaceMemory>>(std::move(a), std::move(b));
  }
  return *slot;
}

void BM_MergeMemories(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), shared = static_cast<int>(state.range(1));
  // 0: both memories given up; 1: both copied; 2: tscd's: the peer's given up, ours handed
  // over once the merge changes it (MergeMemories' give_up_ours).
  const int form = static_cast<int>(state.range(2));
  const bool copying = form == 1;
  const bool basis = state.range(3) != 0;
  const int places_per_site = state.range(4) > 0 ? static_cast<int>(state.range(4)) : 0;
  const int sites = places_per_site > 0 ? n / places_per_site : kSites;
  const bool near = state.range(5) != 0;
  const int caps = state.range(6) > 0 ? static_cast<int>(state.range(6)) : 0;
  const int threads = state.range(7) > 0 ? static_cast<int>(state.range(7)) : 1;
  const auto& [ours, peer] = Pair(n, shared, basis, sites, near, caps);
  double merge_s = 0.0;
  MergeCase merge_case = MergeCase::kNothingNew;
  size_t absorbed = 0, added = 0;
  int retrained = 0;
  // One iteration (see BENCHMARK below). The giving-up forms take copies made before the
  // timed loop: tscd's gives up the peer's memory (built from the snapshot) and hands its own
  // over once the merge knows it changes it (Pipeline::GiveUpMemory); the copying form
  // (tools, tests) reads the shared pair. The result is freed after the loop, so neither
  // making the inputs nor freeing the result is timed.
  std::optional<PlaceMemory> ours_copy, peer_copy;
  if (form != 1) ours_copy.emplace(ours);
  if (form != 1) peer_copy.emplace(peer);
  std::optional<MemoryMerge> m;
  for (auto _ : state) {
    // tscd trims the heap right before it merges (PipelineWorker::MergePeer), so the pages its
    // merge writes are fresh from the system, ~10 µs a fault on the CI machine. Without the
    // trim a repetition would reuse the pages the one before freed and read ~0.15 s faster
    // than tscd at 10⁴ places (docs/results.md, session 73).
    if (form == 2) malloc_trim(0);
    const auto t0 = std::chrono::steady_clock::now();
    if (copying) {
      m.emplace(MergeMemories(ours, peer, threads));
    } else if (form == 2) {
      m.emplace(MergeMemories(*ours_copy, std::move(*peer_copy), threads, [&ours_copy] {
        PlaceMemory given = std::move(*ours_copy);
        ours_copy.emplace(given.robot(), given.options());
        return given;
      }));
    } else {
      m.emplace(MergeMemories(std::move(*ours_copy), std::move(*peer_copy), threads));
    }
    merge_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    merge_case = m->merge_case;
    absorbed = m->absorbed.size();
    added = m->added.size();
    retrained = m->retrained;
  }
  m.reset();
  merge_s /= static_cast<double>(state.iterations());
  state.counters["merge_s"] = merge_s;
  state.counters["case"] = static_cast<double>(merge_case);
  state.counters["absorbed"] = static_cast<double>(absorbed);
  state.counters["added"] = static_cast<double>(added);
  state.counters["retrained"] = retrained;
  state.counters["sites"] = sites;
  state.counters["views_per_place"] = static_cast<double>(ours.places().front().samples.cols());
  state.counters["threads"] = threads;
  state.SetLabel(std::string(ToString(merge_case)) +
                 (copying     ? " copying"
                  : form == 2 ? " tscd's form"
                              : " moving") +
                 (basis ? ", views in the builtin basis" : ", views as descriptors"));
  // Reference: recognise-then-update-or-learn the peer's places one by one into a copy of
  // ours, on an evenly spaced sample, extrapolated to all of them (after the timed loop). The
  // peer's views are relearned as descriptors, so only without a basis.
  if (basis) return;
  PlaceMemory relearner = ours;
  const int sample = std::min<int>(kRelearnSample, static_cast<int>(peer.places().size()));
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < sample; ++k) {
    const LearnedPlace& p =
        peer.places()[static_cast<size_t>(k) * peer.places().size() / static_cast<size_t>(sample)];
    DetectedPlace d;
    d.index = k + 1;
    d.descriptors = p.samples.Decoded();
    d.members.assign(static_cast<size_t>(p.samples.cols()), 0);
    const Recognition r = relearner.Recognize(d);
    if (r.place) {
      relearner.Update(*r.place, d);
    } else {
      relearner.Learn(d);
    }
  }
  const double per_place =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / sample;
  const double relearn_s = per_place * static_cast<double>(peer.places().size());
  state.counters["relearn_s_extrapolated"] = relearn_s;
  state.counters["merge_over_relearn"] = merge_s / relearn_s;
}
// Args: places per memory, % of the peer's places shared with ours, the form (0 both memories
// given up, 1 both copied, 2 tscd's: the peer's given up, ours handed over once it changes),
// 1 = member views in the builtin basis (what tscd runs with; session 27), places per site
// (0: 64 sites whatever the size, so at 10⁵ a site holds ~1560 places, one room learned 1560
// times; 2: the ≤ 2 places per room issue 23 asks of a long-lived memory, a flat tree whose
// root has thousands of hyper-terminals below it), 1 = places as near the basis as real
// descriptors (see World), the views a place keeps (PlaceCaps: 0 the first fixtures' 12, 1 the
// 32 of a place seen once, 2 the 64 of a place seen twice), the threads recognition runs on
// (absent: 1; tscd uses every core, daemon.merge_threads).
BENCHMARK(BM_MergeMemories)
    ->Args({1000, 0, 0, 0, 0, 0, 0, 0})
    ->Args({1000, 50, 0, 0, 0, 0, 0, 0})
    ->Args({10000, 0, 0, 0, 0, 0, 0, 0})
    ->Args({10000, 50, 0, 0, 0, 0, 0, 0})
    ->Args({10000, 50, 1, 0, 0, 0, 0, 0})
    ->Args({1000, 50, 0, 1, 0, 0, 0, 0})
    ->Args({10000, 0, 0, 1, 0, 0, 0, 0})
    ->Args({10000, 50, 0, 1, 0, 0, 0, 0})
    ->Args({10000, 0, 0, 1, 2, 0, 0, 0})
    ->Args({10000, 50, 0, 1, 2, 0, 0, 0})
    ->Args({10000, 0, 0, 1, 2, 1, 0, 0})
    ->Args({10000, 50, 0, 1, 2, 1, 0, 0})
    ->Args({10000, 0, 0, 1, 0, 0, 1, 0})
    ->Args({10000, 50, 0, 1, 0, 0, 1, 0})
    ->Args({10000, 0, 0, 1, 0, 0, 1, 2})
    ->Args({10000, 50, 0, 1, 0, 0, 1, 2})
    ->Args({10000, 50, 2, 1, 0, 0, 1, 2})  // what tscd runs (ours handed over, the peer's moved)
    ->Args({10000, 0, 0, 1, 0, 0, 2, 0})
    ->Args({10000, 50, 0, 1, 0, 0, 2, 0})
    ->Args({kLarge, 0, 0, 1, 0, 0, 0, 0})
    ->Args({kLarge, 50, 0, 1, 0, 0, 0, 0})
    ->Args({kLarge, 0, 0, 1, 0, 0, 0, 2})
    ->Args({kLarge, 50, 0, 1, 0, 0, 0, 2})
    ->Args({kLarge, 50, 2, 1, 0, 0, 0, 2})
    // CPU: every thread's (recognition runs on `threads`); merge_s is the wall-clock time.
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);  // the giving-up form consumes its inputs

// The first step of every merge, figure 4.4's case from the two memories' root spheres (and,
// for a contained case, the larger memory's hyper-terminals): it reads every place of both.
// Args: places per memory, % shared (as BM_MergeMemories), the views a place keeps
// (PlaceCaps), threads. Views in the builtin basis, places near it, as tscd runs.
void BM_CaseOfRootSpheres(benchmark::State& state) {
  const auto& [ours, peer] =
      Pair(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), true, kSites, true,
           static_cast<int>(state.range(2)));
  const double tau_r = ours.options().tau_r;
  MergeCase found = MergeCase::kNothingNew;
  for (auto _ : state) {
    RootSpheres s = CaseOfRootSpheres(ours, peer, tau_r, static_cast<int>(state.range(3)));
    found = s.merge_case;
    benchmark::DoNotOptimize(s);
  }
  state.SetLabel(std::string(ToString(found)));
}
BENCHMARK(BM_CaseOfRootSpheres)
    ->Args({10000, 50, 1, 1})
    ->Args({10000, 50, 2, 1})
    ->Args({10000, 50, 1, 2})
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Bytes on the wire per place: the LCM encodings of the snapshot portions a robot publishes
// (daemon/memory_snapshot: places with mean and samples, tree nodes; empty map here) at the
// default portion size, divided by the places. Without the HMAC (32 bytes per portion).
void BM_SnapshotBytesPerPlace(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const PlaceMemory& memory = Pair(n, 50, true).second;
  const TopologicalMap map;
  MemorySnapshot s;
  for (auto _ : state) {
    s = BuildSnapshot(memory, map, SnapshotHeader{2, 1, 1, 0}, BusOptions{}.portion_bytes);
  }
  int64_t bytes = 0;  // counted once, untimed: each body portion is assembled to encode it
  for (int32_t i = 0; i < s.count(); ++i) bytes += s.Portion(i).getEncodedSize();
  const size_t portions = static_cast<size_t>(s.count());
  state.counters["bytes_per_place"] = static_cast<double>(bytes) / n;
  state.counters["portions"] = static_cast<double>(portions);
  state.counters["dim"] = kDim;
  state.counters["view_dim"] = static_cast<double>(memory.places().front().samples.rows());
  state.counters["samples_per_place"] = PlaceMemoryOptions{}.max_samples_per_place;
}
BENCHMARK(BM_SnapshotBytesPerPlace)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);

// Issue 23: bytes a peer that holds the previous version is sent when one place of `n` is seen
// again (DESIGN §4 incremental exchange): the structure portions and the one changed body,
// against every portion of the snapshot. Timed: building the second snapshot on the first, as
// tscd does (unchanged bodies shared; BM_SnapshotBytesPerPlace times one built from scratch).
void BM_SnapshotDeltaBytes(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  PlaceMemory memory = Pair(n, 50, true).second;
  const TopologicalMap map;
  const int portion_bytes = BusOptions{}.portion_bytes;
  const MemorySnapshot before =
      BuildSnapshot(memory, map, SnapshotHeader{2, 1, 1, 0}, portion_bytes);
  DetectedPlace revisit;  // place n/2 seen again: four base points near its mean
  revisit.index = n + 1;
  const Eigen::VectorXf& mean = memory.places()[static_cast<size_t>(n / 2)].mean;
  revisit.descriptors = mean.replicate(1, 4);
  for (int j = 0; j < 4; ++j) revisit.descriptors(j, j) += 0.01f;
  revisit.members = {1, 2, 3, 4};
  memory.Update(n / 2, revisit);
  MemorySnapshot after;
  for (auto _ : state) {
    after = BuildSnapshot(memory, map, SnapshotHeader{2, 1, 2, 0}, portion_bytes, &before);
  }
  int64_t full = 0, delta = 0, structure = 0;  // counted once, untimed
  for (int32_t i = 0; i < after.count(); ++i) full += after.Portion(i).getEncodedSize();
  for (int32_t i :
       PortionsBeyond(after, {before.body_digests.begin(), before.body_digests.end()})) {
    const int64_t bytes = after.Portion(i).getEncodedSize();
    delta += bytes;
    if (i < after.structure_portions) structure += bytes;
  }
  state.counters["full_bytes"] = static_cast<double>(full);
  state.counters["delta_bytes"] = static_cast<double>(delta);
  state.counters["structure_bytes_per_place"] = static_cast<double>(structure) / n;
  state.counters["delta_percent"] = 100.0 * static_cast<double>(delta) / static_cast<double>(full);
}
BENCHMARK(BM_SnapshotDeltaBytes)
    ->Arg(100)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace tsc
