// Recognition and learning time against the number of learned places (DESIGN §8):
// synthetic places on the descriptor scale (dimension 700 = L2 + intensity), grouped in
// sites so the tree has structure, as a robot's memory would.

#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <random>

#include "core/memory/place_memory.h"

namespace tsc {
namespace {

constexpr int kDim = 700;
constexpr int kMembers = 12;
constexpr int kLearnIterations = 10;

class SyntheticPlaces {
 public:
  explicit SyntheticPlaces(uint32_t seed) : rng_(seed) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int s = 0; s < 64; ++s) {
      Eigen::VectorXf c(kDim);
      for (int i = 0; i < kDim; ++i) c[i] = u(rng_);
      sites_.push_back(c / c.sum());
    }
  }
  // Place p: its site's centre perturbed by 20 %, members by another 2 %.
  DetectedPlace Place(int p) {
    std::mt19937 local(static_cast<uint32_t>(p) * 7919u + 1u);
    std::normal_distribution<float> place_noise(0.0f, 0.2f), member_noise(0.0f, 0.02f);
    Eigen::VectorXf centre = sites_[p % sites_.size()];
    for (int i = 0; i < kDim; ++i) centre[i] *= std::max(0.0f, 1.0f + place_noise(local));
    DetectedPlace d;
    d.index = p + 1;
    d.descriptors.resize(kDim, kMembers);
    for (int j = 0; j < kMembers; ++j) {
      d.members.push_back(static_cast<BaseIndex>(p) * kMembers + j);
      for (int i = 0; i < kDim; ++i) {
        d.descriptors(i, j) = std::max(0.0f, centre[i] * (1.0f + member_noise(rng_)));
      }
    }
    return d;
  }

 private:
  std::mt19937 rng_;
  std::vector<Eigen::VectorXf> sites_;
};

// Memories are built once per size and shared by the benchmarks.
const PlaceMemory& MemoryOf(int n) {
  static std::map<int, std::unique_ptr<PlaceMemory>> cache;
  auto& slot = cache[n];
  if (!slot) {
    slot = std::make_unique<PlaceMemory>(1, PlaceMemoryOptions{});
    SyntheticPlaces places(1);
    for (int p = 0; p < n; ++p) slot->Learn(places.Place(p));
  }
  return *slot;
}

void BM_Recognize(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const PlaceMemory& memory = MemoryOf(n);
  SyntheticPlaces places(1);
  std::vector<DetectedPlace> queries;
  for (int q = 0; q < 16; ++q) queries.push_back(places.Place((q * 37) % n));
  size_t i = 0, recognised = 0;
  for (auto _ : state) {
    const Recognition r = memory.Recognize(queries[i++ % queries.size()]);
    recognised += r.place.has_value();
    benchmark::DoNotOptimize(r);
  }
  state.counters["recognised_fraction"] =
      static_cast<double>(recognised) / static_cast<double>(state.iterations());
  state.counters["tree_depth"] = memory.Depth();
  // The shortlist's cost in quality: the queries recognised as measuring every place does.
  PlaceMemoryOptions exhaustive_options = memory.options();
  exhaustive_options.shortlist = 0;
  const PlaceMemory exhaustive =
      PlaceMemory::Restore(memory.robot(), exhaustive_options, memory.places(), memory.slink(),
                           memory.next_local_id(), {});
  int agree = 0;
  for (const DetectedPlace& q : queries)
    agree += memory.Recognize(q).place == exhaustive.Recognize(q).place;
  state.counters["agrees_with_exhaustive"] =
      static_cast<double>(agree) / static_cast<double>(queries.size());
}
BENCHMARK(BM_Recognize)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The index's share of a recognition: estimating every place's distance to D's queries.
void BM_ViewIndexEstimate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  SyntheticPlaces places(1);
  ViewIndex index;
  for (int p = 0; p < n; ++p) {
    const DetectedPlace d = places.Place(p);
    LearnedPlace learned;
    learned.mean = d.Mean();
    learned.samples = d.descriptors;
    index.Set(p, learned);
  }
  const Eigen::MatrixXf queries = places.Place(7).descriptors.leftCols(5);
  for (auto _ : state) benchmark::DoNotOptimize(index.Estimate(queries));
}
BENCHMARK(BM_ViewIndexEstimate)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_Learn(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  SyntheticPlaces places(1);
  std::vector<DetectedPlace> fresh;
  for (int k = 0; k < kLearnIterations; ++k) fresh.push_back(places.Place(n + k));
  // Iteration k learns place n+k+1 into one copy made before the timed loop, so nothing is
  // paused: a copy per iteration, paused, still left ~10-15 ms of its freeing at 10⁴ places in
  // Google Benchmark's CPU time (measured with CLOCK_THREAD_CPUTIME_ID around the calls).
  PlaceMemory memory = MemoryOf(n);
  size_t k = 0;
  for (auto _ : state) benchmark::DoNotOptimize(memory.Learn(fresh[k++ % fresh.size()]));
  state.counters["places_at_end"] = static_cast<double>(memory.places().size());
}
BENCHMARK(BM_Learn)
    ->Arg(10)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kLearnIterations);

}  // namespace
}  // namespace tsc
