// Recognition and learning time against the number of learned places (DESIGN §8):
// synthetic places on the descriptor scale (dimension 1200, the default features' 12 blocks of
// 100, core/bubble/features.h FeatureSet::Recognition), grouped in
// sites so the tree has structure, as a robot's memory would.

#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/memory/compact_views.h"
#include "core/memory/member_views.h"
#include "core/memory/place_memory.h"
#include "core/memory/simd.h"
#include "core/memory/view_index.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

constexpr int kDim = 1200;
constexpr int kMembers = 12;
// Base points per place at the default caps: a place keeps max_samples_per_place = 32 member
// views and D gives max_vote_points = 32 vote points (kMembers = 12 measures 12 x 12).
constexpr int kCappedMembers = 48;
constexpr int kLearnIterations = 10;

// 64 sites, members 2 % apart (test/support/synthetic_places.h); a place's visit 0 is learned,
// visit 1 is a revisit.
const testing_support::SyntheticPlaces& World() {
  static const testing_support::SyntheticPlaces places(1, kDim, 64, 0.02f);
  return places;
}
DetectedPlace Place(int p, uint32_t visit = 0, int members = kMembers) {
  return World().Visit(p, visit, members, members);
}
// The same sites with every descriptor in the builtin basis's span but for ~1 % of its
// distance from it (residual 0.033 of a world whose distances lie 90 % outside), as the real
// loop's steps (0.8-1.2 % outside): what learning's bounds from the basis rest on.
const testing_support::SyntheticPlaces& WorldInBasis() {
  static const testing_support::SyntheticPlaces places = [] {
    testing_support::SyntheticPlaces w = World();
    w.LieIn(BuiltinViewBasis(), 0.033f);
    return w;
  }();
  return places;
}

// From 10⁵ places (issue 23) a memory is built at once (test/support/synthetic_places.h:
// LargeSyntheticMemory, its SLINK tree over the means in the basis), its places learned from
// visit 2; n Learn()s would take hours.
constexpr int kLarge = testing_support::kLargeMemory;

// Memories are built once per size, place size and space of views, and shared by the
// benchmarks. `basis`: member views in tscd's builtin view basis (128 dimensions, what tscd
// runs with since session 27), else the descriptors themselves. The synthetic places are not
// low-dimensional as real descriptors are (their per-feature noise spreads over every
// dimension), so in the basis they lie nearer each other than real places would: the times
// hold, the recognised fractions are the synthetic data's.
// `in_basis`: places of WorldInBasis() (with `basis` only).
const PlaceMemory& MemoryOf(int n, int members = kMembers, bool basis = false,
                            bool in_basis = false) {
  static std::map<std::tuple<int, int, bool, bool>, std::unique_ptr<PlaceMemory>> cache;
  auto& slot = cache[{n, members, basis, in_basis}];
  if (!slot) {
    PlaceMemoryOptions options;
    if (basis) options.view_basis = BuiltinViewBasis();
    const testing_support::SyntheticPlaces& world = in_basis ? WorldInBasis() : World();
    if (n >= kLarge) {
      slot = std::make_unique<PlaceMemory>(
          testing_support::LargeSyntheticMemory(2, world, 0, n, members, options));
    } else {
      slot = std::make_unique<PlaceMemory>(1, options);
      for (int p = 0; p < n; ++p) slot->Learn(world.Visit(p, 0, members, members));
    }
  }
  return *slot;
}

// The fraction of `queries` recognised as by the same places with options changed by
// `reference` (a copy restored with them). Computed once per memory and reference (Google
// Benchmark runs a benchmark several times, and the references take seconds at 10⁴ places).
double AgreementWith(const char* name, void (*reference)(PlaceMemoryOptions&),
                     const PlaceMemory& memory, const std::vector<DetectedPlace>& queries) {
  static std::map<std::pair<const PlaceMemory*, std::string>, double> cache;
  auto it = cache.find({&memory, name});
  if (it != cache.end()) return it->second;
  PlaceMemoryOptions options = memory.options();
  reference(options);
  const PlaceMemory other = PlaceMemory::Restore(memory.robot(), options, memory.places(),
                                                 memory.slink(), memory.next_local_id(), {});
  int agree = 0;
  for (const DetectedPlace& q : queries)
    agree += memory.Recognize(q).place == other.Recognize(q).place;
  return cache[{&memory, name}] = static_cast<double>(agree) / static_cast<double>(queries.size());
}

void RecognizeWith(benchmark::State& state, int members) {
  const int n = static_cast<int>(state.range(0));
  const bool basis = state.range(1) != 0;
  const PlaceMemory& memory = MemoryOf(n, members, basis);
  std::vector<DetectedPlace> queries;
  for (int q = 0; q < 16; ++q) queries.push_back(Place((q * 37) % n, 1, members));
  size_t i = 0, recognised = 0;
  for (auto _ : state) {
    const Recognition r = memory.Recognize(queries[i++ % queries.size()]);
    recognised += r.place.has_value();
    benchmark::DoNotOptimize(r);
  }
  state.counters["recognised_fraction"] =
      static_cast<double>(recognised) / static_cast<double>(state.iterations());
  state.counters["tree_depth"] = memory.Depth();
  // (Not at 10⁵: a second, exhaustive copy of the memory and its recognitions, minutes.)
  // The shortlist's cost in quality: against measuring every place.
  if (n < kLarge) {
    state.counters["agrees_with_exhaustive"] = AgreementWith(
        "exhaustive", [](PlaceMemoryOptions& o) { o.shortlist = 0; }, memory, queries);
  }
  // The view index's cells' (from ViewIndex::kCellsFrom places): against reading every key.
  if (n >= ViewIndex::kCellsFrom) {
    state.counters["agrees_with_exact_index"] = AgreementWith(
        "exact index", [](PlaceMemoryOptions& o) { o.view_cells = false; }, memory, queries);
  }
  state.SetLabel(basis ? "views in the builtin basis" : "views as descriptors");
}

// Places of kMembers = 12 base points: 12 views per place, 12 vote points.
void BM_Recognize(benchmark::State& state) { RecognizeWith(state, kMembers); }
// Args: places, 1 = member views in the builtin basis.
BENCHMARK(BM_Recognize)
    ->ArgsProduct({{10, 100, 1000, 10000}, {0, 1}})
    ->Args({kLarge, 1})
    ->Unit(benchmark::kMicrosecond);

// The same at the default caps, what a robot's recognition measures: places of 48 base points
// keep 32 views, D gives 32 vote points (7x the products of BM_Recognize). The memory of 10⁴
// places holds 1.5 GB of views.
void BM_RecognizeAtDefaultCaps(benchmark::State& state) { RecognizeWith(state, kCappedMembers); }
BENCHMARK(BM_RecognizeAtDefaultCaps)
    ->ArgsProduct({{1000, 10000}, {0, 1}})
    ->Args({kLarge, 1})
    ->Unit(benchmark::kMicrosecond);

// The same once every place was seen twice (memory.sample_visits 2): 64 views a place, what a
// long-lived memory's places reach (2x the products of BM_RecognizeAtDefaultCaps).
void BM_RecognizeAtSaturatedCaps(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  static std::map<int, std::unique_ptr<PlaceMemory>> cache;
  auto& slot = cache[n];
  if (!slot) {
    const PlaceMemory& once = MemoryOf(n, kCappedMembers, true);
    slot = std::make_unique<PlaceMemory>(PlaceMemory::Restore(
        once.robot(), once.options(), once.places(), once.slink(), once.next_local_id(), {}));
    for (int p = 0; p < n; ++p)
      slot->Update(p, World().Visit(p, 3, kCappedMembers, kCappedMembers));
  }
  std::vector<DetectedPlace> queries;
  for (int q = 0; q < 16; ++q) queries.push_back(Place((q * 37) % n, 1, kCappedMembers));
  size_t i = 0, recognised = 0;
  for (auto _ : state) {
    const Recognition r = slot->Recognize(queries[i++ % queries.size()]);
    recognised += r.place.has_value();
    benchmark::DoNotOptimize(r);
  }
  state.counters["recognised_fraction"] =
      static_cast<double>(recognised) / static_cast<double>(state.iterations());
  state.counters["views_per_place"] = static_cast<double>(slot->places().front().samples.cols());
}
BENCHMARK(BM_RecognizeAtSaturatedCaps)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The index's share of a recognition: estimating every place's distance to D's queries.
void BM_ViewIndexEstimate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  ViewIndex index;
  for (int p = 0; p < n; ++p) {
    const DetectedPlace d = Place(p);
    index.Set(p, d.Mean(), d.descriptors);
  }
  const Eigen::MatrixXf queries = Place(7, 1).descriptors.leftCols(5);
  for (auto _ : state) benchmark::DoNotOptimize(index.Estimate(queries));
}
BENCHMARK(BM_ViewIndexEstimate)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The shortlist of a merge's crowded N* (1500 places, 32 kept): estimates in random order
// (few enter after the first), and descending, each nearer than every one before (all enter).
void BM_Shortlist(benchmark::State& state) {
  const size_t n = 1500;
  std::vector<float> estimates(n);
  std::mt19937 rng(5);  // fixed: the same estimates every run
  std::uniform_real_distribution<float> spread(0.0f, 1.0f);
  for (size_t i = 0; i < n; ++i)
    estimates[i] = state.range(0) == 0 ? spread(rng) : static_cast<float>(n - i);
  for (auto _ : state) benchmark::DoNotOptimize(Shortlist(estimates, 32));
}
BENCHMARK(BM_Shortlist)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// What the products of a recognition at the default caps cost with the places' views in cache
// and out of it: 32 vote points against the 32 views of each of 32 places (the shortlist), on
// the AVX2 kernel. The argument is the places held: 32 gives the same 32 every time (hot);
// 2048 (300 MB, ten times the last-level cache) and 10⁴ (1.5 GB, as BM_RecognizeAtDefaultCaps)
// give 32 of them in a seeded random order, as a shortlist of a large memory falls (cold). The
// gap is what memory, not arithmetic, costs a recognition. Second argument: the kernel's
// lanes, 8 (AVX2) or 16 (AVX-512: the same results, core/memory/simd.h).
void BM_ViewProducts(benchmark::State& state) {
  const Lanes lanes = state.range(1) == 16 ? Lanes::k16 : Lanes::k8;
  if (FastestSimd() != Simd::kAvx2Fma || (lanes == Lanes::k16 && WidestLanes() != Lanes::k16)) {
    state.SkipWithError("no AVX2/FMA (or no AVX-512 for 16 lanes) on this machine");
    return;
  }
  constexpr int kVotes = 32, kViews = 32, kShortlist = 32;
  const int places = static_cast<int>(state.range(0));
  const bool cold = places > kShortlist;
  std::mt19937 rng(24);  // fixed: the same data and order on every run
  std::normal_distribution<float> normal;
  Eigen::MatrixXf votes(kDim, kVotes);
  for (Eigen::Index k = 0; k < votes.size(); ++k) votes.data()[k] = normal(rng);
  std::vector<Eigen::MatrixXf> views(static_cast<size_t>(places), Eigen::MatrixXf(kDim, kViews));
  for (Eigen::MatrixXf& v : views) {
    for (Eigen::Index k = 0; k < v.size(); ++k) v.data()[k] = normal(rng);
  }
  std::uniform_int_distribution<int> pick(0, places - 1);
  std::vector<float> out(kVotes * kViews), norms(kViews);
  std::vector<int> chosen(kShortlist);
  for (auto _ : state) {
    for (int c = 0; c < kShortlist; ++c) chosen[static_cast<size_t>(c)] = cold ? pick(rng) : c;
    for (int c = 0; c < kShortlist; ++c) {
      const Eigen::MatrixXf& v = views[static_cast<size_t>(chosen[static_cast<size_t>(c)])];
      const Eigen::MatrixXf* next =
          c + 1 < kShortlist ? &views[static_cast<size_t>(chosen[static_cast<size_t>(c + 1)])]
                             : nullptr;
      avx2::ColumnDots(votes.data(), kVotes, v.data(), kViews, kDim, out.data(), norms.data(),
                       next != nullptr ? next->data() : nullptr, next != nullptr ? next->size() : 0,
                       lanes);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["multiply_adds"] = static_cast<double>(kVotes) * kViews * kDim * kShortlist;
  state.SetLabel(cold ? "cold: 32 of them at random" : "hot: the same 32");
}
BENCHMARK(BM_ViewProducts)
    ->ArgsProduct({{32, 2048, 10000}, {8, 16}})
    ->Unit(benchmark::kMicrosecond);

// A place's member views read back from their 16-bit form (the store, messages): tscd
// loading a 10⁵-place store does this 10⁵ times, once a place. 128 axes x 64 views, the cap of a
// place seen twice, of falling magnitude as a principal basis' axes are.
void BM_ViewsFromSixteenBits(benchmark::State& state) {
  constexpr int kAxes = 128, kViews = 64;
  std::mt19937 rng(64);  // fixed: the same views on every run
  std::normal_distribution<float> normal;
  Eigen::MatrixXf views(kAxes, kViews);
  for (Eigen::Index c = 0; c < kViews; ++c) {
    for (Eigen::Index r = 0; r < kAxes; ++r)
      views(r, c) = normal(rng) * 0.05f / static_cast<float>(1 + r);
  }
  const CompactViews encoded(views);
  const std::vector<int16_t> wide = encoded.Wide();
  for (auto _ : state) {
    const CompactViews back(kAxes, kViews, encoded.shift(), wide);
    benchmark::DoNotOptimize(back.codes());
  }
}
BENCHMARK(BM_ViewsFromSixteenBits)->Unit(benchmark::kMicrosecond);

// A place's member views thinned: 64 views (the cap of a place seen twice, 128 axes of the
// builtin basis) to 2, the spread keys the view index files every place under (a 10⁴ + 10⁴
// merge thins 2·10⁴ places so), to 32, a merged place's own cap, and to 63, which is nearly
// all the pairwise distances' time. The views walk, as a robot's consecutive base points do,
// so each lies nearest its neighbours in time.
void BM_ThinViews(benchmark::State& state) {
  constexpr int kAxes = 128, kViews = 64;
  std::mt19937 rng(65);  // fixed: the same views on every run
  std::normal_distribution<float> normal;
  Eigen::MatrixXf views(kAxes, kViews);
  views.col(0).setZero();
  for (Eigen::Index c = 1; c < kViews; ++c) {
    for (Eigen::Index r = 0; r < kAxes; ++r) views(r, c) = views(r, c - 1) + normal(rng) * 0.01f;
  }
  const int cap = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const Eigen::MatrixXf thinned = ThinViews(views, cap);
    benchmark::DoNotOptimize(thinned.data());
  }
}
BENCHMARK(BM_ThinViews)->Arg(63)->Arg(2)->Arg(32)->Unit(benchmark::kMicrosecond);

// Args: places; 0 views as descriptors, 1 in the builtin basis, 2 in the basis with places of
// WorldInBasis(). Counter `gamma_measured`: the share of the distances γ learning measured
// (with a basis, bounds from it settle the rest: Slink::InsertBounded).
void BM_Learn(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const bool basis = state.range(1) != 0, in_basis = state.range(1) == 2;
  const testing_support::SyntheticPlaces& world = in_basis ? WorldInBasis() : World();
  std::vector<DetectedPlace> fresh;
  for (int k = 0; k < kLearnIterations; ++k)
    fresh.push_back(world.Visit(n + k, 0, kMembers, kMembers));
  // Iteration k learns place n+k+1 into one copy made before the timed loop, so nothing is
  // paused: a copy per iteration, paused, still left ~10-15 ms of its freeing at 10⁴ places in
  // Google Benchmark's CPU time (measured with CLOCK_THREAD_CPUTIME_ID around the calls).
  PlaceMemory memory = MemoryOf(n, kMembers, basis, in_basis);
  size_t k = 0;
  double measured = 0.0, asked = 0.0;
  for (auto _ : state) {
    asked += static_cast<double>(memory.places().size());
    benchmark::DoNotOptimize(memory.Learn(fresh[k++ % fresh.size()]));
    measured += basis ? memory.slink().measured() : static_cast<double>(memory.places().size() - 1);
  }
  state.counters["places_at_end"] = static_cast<double>(memory.places().size());
  state.counters["gamma_measured"] = asked > 0.0 ? measured / asked : 0.0;
  state.SetLabel(!basis     ? "views as descriptors"
                 : in_basis ? "views in the builtin basis, places near its span"
                            : "views in the builtin basis");
}
BENCHMARK(BM_Learn)
    ->ArgsProduct({{10, 100, 1000, 10000}, {0, 1, 2}})
    ->Args({kLarge, 1})
    ->Args({kLarge, 2})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kLearnIterations);

}  // namespace
}  // namespace tsc
