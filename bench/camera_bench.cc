// The Axis camera's per-frame work outside the pipeline: cutting the MJPEG stream into parts
// (MultipartParser, fed in 16 KiB reads) and decoding one 640x480 JPEG part into the BGR frame
// the pipeline takes. Reported as MB/s and frames/s; at 30 fps both must stay a small fraction
// of the daemon's budget (DESIGN §8: ≤ 25 % of one core in all).

#include <benchmark/benchmark.h>

#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/bubble/camera.h"
#include "drivers/camera/frame_convert.h"
#include "drivers/camera/multipart_parser.h"
#include "drivers/world/renderer.h"
#include "drivers/world/routes.h"
#include "drivers/world/world.h"

namespace tsc {
namespace {

// A rendered 640x480 frame of the office world as an Axis-like JPEG (compression 30).
std::string SampleJpeg() {
  std::mt19937 rng(7);
  const sim::World world = sim::World::Generate(sim::WorldKind::kOffice, rng);
  const sim::Renderer renderer(world, sim::RenderOptions{}, 11);
  const sim::Room& room = world.rooms().front();
  cv::Mat bgr;
  renderer.Render({room.cx(), room.cy(), 0.3}, &bgr, nullptr);
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 70});
  return std::string(jpeg.begin(), jpeg.end());
}

void BM_MultipartParser(benchmark::State& state) {
  const std::string jpeg = SampleJpeg();
  std::string stream;
  for (int i = 0; i < 30; ++i) {
    stream += "--myboundary\r\nContent-Type: image/jpeg\r\n";
    if (state.range(0) != 0) stream += "Content-Length: " + std::to_string(jpeg.size()) + "\r\n";
    stream += "\r\n" + jpeg + "\r\n";
  }
  stream += "--myboundary\r\n";
  std::vector<MultipartPart> parts;
  for (auto _ : state) {
    MultipartParser parser("myboundary");
    parts.clear();
    for (size_t at = 0; at < stream.size(); at += 16384) {
      parser.Feed(std::string_view(stream).substr(at, 16384), &parts);
    }
    benchmark::DoNotOptimize(parts.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * stream.size()));
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * 30), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MultipartParser)->Arg(1)->Arg(0)->ArgName("content_length");

void BM_JpegToFrame_640x480(benchmark::State& state) {
  const std::string jpeg = SampleJpeg();
  const CameraIntrinsics intrinsics = CameraIntrinsics::FromHorizontalFov(640, 480, 60.0);
  for (auto _ : state) {
    const cv::Mat raw = cv::imdecode(
        cv::Mat(1, static_cast<int>(jpeg.size()), CV_8U, const_cast<char*>(jpeg.data())),
        cv::IMREAD_COLOR);
    cv::Mat bgr = ToBgrOfSize(raw, intrinsics);
    benchmark::DoNotOptimize(bgr.data);
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_JpegToFrame_640x480)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tsc
