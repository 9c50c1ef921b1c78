#include "drivers/world/dataset_writer.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "drivers/world/scenario.h"

namespace tsc::sim {
namespace fs = std::filesystem;
namespace {

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string Stem(int frame_1based) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", frame_1based);
  return buf;
}

}  // namespace

int WriteRobotDataset(const fs::path& folder, const World& world,
                      const std::vector<RouteFrame>& route, const SimOptions& options,
                      std::mt19937& rng) {
  options.Validate();
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (options.depth) fs::create_directories(folder / "depth", ec);
  if (ec) throw std::runtime_error("cannot create " + folder.string() + ": " + ec.message());

  const RenderOptions& ro = options.render;
  std::string sweep;
  if (options.sweep.views() > 1) {
    sweep = ",\"sweep_views\":" + std::to_string(options.sweep.views()) +
            ",\"sweep_deg\":" + std::to_string(options.sweep.deg());
  }
  WriteText(folder / "camera.json",
            "{\"width\":" + std::to_string(ro.width) + ",\"height\":" + std::to_string(ro.height) +
                ",\"hfov_deg\":" + std::to_string(ro.hfov_deg) + sweep +
                // The route's walking step: the base-point spacing place detection counts its
                // shortest place with (Dataset::spacing).
                ",\"spacing_m\":" + std::to_string(options.route.step_m * options.frame_every) +
                "}\n");
  WriteText(folder / "world.json", world.ToJson());

  const Renderer renderer(world, ro, static_cast<std::uint32_t>(rng()));
  const int every = options.frame_every;
  const int taken = (static_cast<int>(route.size()) + every - 1) / every;
  const int n = options.max_frames > 0 ? std::min(options.max_frames, taken) : taken;
  std::ofstream gt(folder / "groundtruth.csv");
  gt << "frame,place,x,y,heading\n";
  gt.precision(6);
  const std::vector<int> jpeg = {cv::IMWRITE_JPEG_QUALITY, 90};
  cv::Mat bgr, depth, depth_mm;
  FrameDistributions draws;
  for (int i = 0; i < n; ++i) {
    const Pose2 pose =
        RenderRouteFrame(world, renderer, route[static_cast<size_t>(i) * every], options, rng,
                         draws, &bgr, options.depth ? &depth : nullptr);

    const std::string stem = Stem(i + 1);
    const fs::path image = folder / (stem + (options.png ? ".png" : ".jpg"));
    if (!cv::imwrite(image.string(), bgr, options.png ? std::vector<int>{} : jpeg)) {
      throw std::runtime_error("cannot write " + image.string());
    }
    if (options.depth) {
      depth.convertTo(depth_mm, CV_16U, 1000.0);
      const fs::path dpath = folder / "depth" / (stem + ".png");
      if (!cv::imwrite(dpath.string(), depth_mm)) {
        throw std::runtime_error("cannot write " + dpath.string());
      }
    }
    gt << (i + 1) << "," << world.LabelAt(pose.x, pose.y) << "," << pose.x << "," << pose.y << ","
       << pose.heading << "\n";
  }
  gt.flush();
  if (!gt) throw std::runtime_error("cannot write " + (folder / "groundtruth.csv").string());
  return n;
}

SimSummary WriteSimulatedDataset(const fs::path& out, const SimOptions& options) {
  options.Validate();
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_empty(out, ec)) {
    throw std::runtime_error("output folder " + out.string() + " is not empty");
  }
  fs::create_directories(out, ec);
  if (ec) throw std::runtime_error("cannot create " + out.string() + ": " + ec.message());

  const Scenario scenario = MakeScenario(options);
  std::mt19937 frame_rng(FrameSeed(options.RouteSeed()));
  SimSummary summary;
  for (const Room& r : scenario.world.rooms()) summary.labels.push_back(r.label);
  if (options.robots == 1) {
    summary.frames.push_back(
        WriteRobotDataset(out, scenario.world, scenario.routes.front(), options, frame_rng));
    summary.datasets.push_back(out);
    return summary;
  }
  WriteText(out / "world.json", scenario.world.ToJson());
  for (int k = 0; k < options.robots; ++k) {
    const fs::path folder = out / "robots" / std::to_string(k + 1);
    summary.frames.push_back(WriteRobotDataset(
        folder, scenario.world, scenario.routes[static_cast<size_t>(k)], options, frame_rng));
    summary.datasets.push_back(folder);
  }
  return summary;
}

}  // namespace tsc::sim
