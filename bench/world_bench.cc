// Speed of the world simulator's renderer (drivers/world): one 640x480 frame rendered by ray
// casting, then lit with sensor noise; reported as frames/s (target ≥ 100 on one core).

#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "drivers/world/renderer.h"
#include "drivers/world/routes.h"
#include "drivers/world/world.h"

namespace tsc {
namespace {

void BM_WorldRender(benchmark::State& state) {
  std::mt19937 rng(7);
  const sim::World world = sim::World::Generate(sim::WorldKind::kOffice, rng);
  const sim::RouteOptions route_options;
  const std::vector<sim::RouteFrame> route =
      sim::FollowRooms(world, sim::SingleRobotTargets(world, route_options, rng), route_options);
  sim::RenderOptions options;
  options.width = static_cast<int>(state.range(0));
  options.height = static_cast<int>(state.range(1));
  const sim::Renderer renderer(world, options, 11);
  const bool with_depth = state.range(2) != 0;
  cv::Mat bgr, depth;
  size_t i = 0;
  for (auto _ : state) {
    renderer.Render(route[i % route.size()].pose, &bgr, with_depth ? &depth : nullptr);
    renderer.ApplyLighting(sim::Lighting::Day(), rng, &bgr);
    benchmark::DoNotOptimize(bgr.data);
    i += 7;
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_WorldRender)
    ->Args({640, 480, 0})
    ->Args({640, 480, 1})
    ->ArgNames({"w", "h", "depth"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tsc
