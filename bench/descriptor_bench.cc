// Descriptor time against its bar (DESIGN §8): one 640x480 BGR frame, the default feature set
// (FeatureSet::Recognition), Observe + Compute on one core, and the same figure as a ratio to
// OpenCV ORB extraction of 500 keypoints on that frame (bar: ratio <= 0.5). Holds the main() of
// tsc_bench.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/bubble/descriptor.h"
#include "core/bubble/surface.h"

namespace tsc {
namespace {

constexpr int kWidth = 640, kHeight = 480;
constexpr double kHfovDeg = 54.0;  // ≈ 30 x 30 px per 2.5° patch at 640x480 (DESIGN §3.1)

struct Frame {
  cv::Mat bgr;   // 640x480 CV_8UC3
  cv::Mat grey;  // the same frame in grey, the input of the ORB reference
};

const Frame& BenchFrame() {
  static const Frame frame = [] {
    const std::string path = std::string(TSCD_DATA_DIR) + "/rtabmap-loop/1.jpg";
    const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
    if (image.empty()) throw std::runtime_error("cannot read " + path);
    Frame f;
    cv::resize(image, f.bgr, cv::Size(kWidth, kHeight), 0, 0, cv::INTER_LINEAR);
    cv::cvtColor(f.bgr, f.grey, cv::COLOR_BGR2GRAY);
    return f;
  }();
  return frame;
}

// What the pipeline does per frame: a fresh base point, one view, one descriptor.
class DescriptorJob {
 public:
  DescriptorJob()
      : surface_(FeatureSet::Recognition(),
                 CameraIntrinsics::FromHorizontalFov(kWidth, kHeight, kHfovDeg)),
        computer_(surface_.grid()),
        observation_{BenchFrame().bgr, cv::Mat(), PanTilt{}} {}
  Descriptor Run() {
    surface_.Reset();
    surface_.Observe(observation_);
    return computer_.Compute(surface_);
  }

 private:
  BubbleSurface surface_;
  DescriptorComputer computer_;
  Observation observation_;
};

class OrbJob {
 public:
  OrbJob() : orb_(cv::ORB::create(500)) {}
  int Run() {
    orb_->detectAndCompute(BenchFrame().grey, cv::noArray(), keypoints_, descriptors_);
    return static_cast<int>(keypoints_.size());
  }

 private:
  cv::Ptr<cv::ORB> orb_;
  std::vector<cv::KeyPoint> keypoints_;
  cv::Mat descriptors_;
};

void BM_Descriptor_640x480(benchmark::State& state) {
  DescriptorJob job;
  for (auto _ : state) {
    Descriptor d = job.Run();
    benchmark::DoNotOptimize(d);
  }
}
BENCHMARK(BM_Descriptor_640x480)->Unit(benchmark::kMillisecond);

void BM_OrbReference_500(benchmark::State& state) {
  OrbJob job;
  int keypoints = 0;
  for (auto _ : state) keypoints = job.Run();
  state.counters["keypoints"] = keypoints;
}
BENCHMARK(BM_OrbReference_500)->Unit(benchmark::kMillisecond);

// Console output as usual, plus the mean real time per benchmark (ms) for the summary.
class RecordingReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.run_type == Run::RT_Iteration && !r.error_occurred) {
        ms_[r.benchmark_name()] =
            r.GetAdjustedRealTime() / benchmark::GetTimeUnitMultiplier(r.time_unit) * 1e3;
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  const std::map<std::string, double>& ms() const { return ms_; }

 private:
  std::map<std::string, double> ms_;
};

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Medians of `n` interleaved runs of each job, so that load on the shared machine hits both.
void PrintReferenceRatio(int n) {
  DescriptorJob descriptor;
  OrbJob orb;
  descriptor.Run();  // warm-up: allocations, caches, OpenCV thread pool
  orb.Run();
  std::vector<double> d_ms, o_ms;
  using Clock = std::chrono::steady_clock;
  for (int k = 0; k < n; ++k) {
    Clock::time_point t0 = Clock::now();
    benchmark::DoNotOptimize(descriptor.Run());
    Clock::time_point t1 = Clock::now();
    benchmark::DoNotOptimize(orb.Run());
    Clock::time_point t2 = Clock::now();
    d_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    o_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  const double d = Median(d_ms), o = Median(o_ms);
  std::printf(
      "descriptor 640x480, default features: %.3f ms (bar <= 2 ms), ORB 500: %.3f ms (median of "
      "%d)\n",
      d, o, n);
  std::printf("descriptor/orb ratio: %.3f (bar <= 0.5)\n", d / o);
}

}  // namespace
}  // namespace tsc

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  cv::setNumThreads(1);  // the bars are for one core; OpenCV would otherwise spread out
  tsc::RecordingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const auto& ms = reporter.ms();
  const auto d = ms.find("BM_Descriptor_640x480");
  const auto o = ms.find("BM_OrbReference_500");
  if (d != ms.end() && o != ms.end()) {
    std::printf("descriptor/orb ratio (benchmark means): %.3f\n", d->second / o->second);
  }
  // The reference ratio of DESIGN §8, unless the descriptor benchmarks were filtered out.
  if (d != ms.end() || o != ms.end()) tsc::PrintReferenceRatio(50);
  benchmark::Shutdown();
  return 0;
}
