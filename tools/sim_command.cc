#include "tools/sim_command.h"

#include <boost/program_options.hpp>
#include <cstdint>
#include <exception>
#include <iostream>
#include <stdexcept>

#include "drivers/world/dataset_writer.h"
#include "tools/command_line.h"

namespace tsc {
namespace {

namespace po = boost::program_options;

constexpr const char* kSimHelp =
    R"(usage: tsc sim --out DIR --seed N [--route-seed M] [--world office|corridors|outdoor]
               [--robots K] [--revisit-fraction F] [--lighting day|dim|flicker|mixed] [--depth]
               [--size WxH] [--hfov DEG] [--frames-per-room N] [--step-m M]
               [--turn-step-deg D] [--scan-step-deg D] [--sweep-views K] [--sweep-deg D]
               [--sweep-world-aligned] [--png] [--max-frames N] [--every N]

Writes a simulated dataset (DESIGN §7.1): frames rendered from a generated floor plan along a
scripted route that tours every room and revisits some of them, camera.json, groundtruth.csv
(frame,place,x,y,heading; place "" in doorways), world.json (the floor plan) and, with
--depth, depth/<stem>.png (16-bit, mm). With --robots K > 1 every robot gets DIR/robots/<id>/
(id = 1..K) with routes that share some rooms. The same seed gives the same bytes. DIR must
not exist or be empty. --lighting mixed lights first visits by day and revisits dim.
--route-seed walks the same world (--seed) along another route with other camera noise; the
same seeds with another --lighting give the same poses. --sweep-views K > 1 gives the robot a
pan-tilt camera that sweeps K views (--sweep-deg apart in all, counter-clockwise from straight
ahead) at every frame, as tscd's Axis camera does in sweep mode: each image holds the K views
side by side and camera.json says so; the pipeline accumulates them into one bubble surface.
--sweep-world-aligned takes the views at fixed world headings (a sweep started from the
robot's heading estimate), so turning on the spot does not move them.

Options)";

void ParseSize(const std::string& text, int* width, int* height) {
  const size_t x = text.find_first_of("xX");
  try {
    if (x == std::string::npos) throw std::invalid_argument(text);
    size_t used_w = 0, used_h = 0;
    const std::string w = text.substr(0, x), h = text.substr(x + 1);
    *width = std::stoi(w, &used_w);
    *height = std::stoi(h, &used_h);
    if (used_w != w.size() || used_h != h.size()) throw std::invalid_argument(text);
  } catch (const std::logic_error&) {
    throw UsageError("--size '" + text + "' is not WxH (e.g. 640x480)");
  }
}

int Sim(const std::vector<std::string>& args) {
  po::options_description desc(kSimHelp);
  desc.add_options()("help,h", "show this help")(
      "out", po::value<std::string>()->required()->value_name("DIR"),
      "output dataset folder (created)")("seed",
                                         po::value<long long>()->required()->value_name("N"),
                                         "random seed of the world, routes and noise")(
      "route-seed", po::value<long long>()->value_name("M"),
      "seed of the routes and noise only: the same world (--seed) along another route")(
      "world", po::value<std::string>()->default_value("office")->value_name("KIND"),
      "office (rooms off a corridor), corridors, or outdoor (street, square, two rooms)")(
      "robots", po::value<int>()->default_value(1)->value_name("K"), "number of robots, 1..64")(
      "revisit-fraction", po::value<double>()->default_value(0.5, "0.5")->value_name("F"),
      "fraction of the rooms revisited after the first tour, in [0, 1]")(
      "lighting", po::value<std::string>()->default_value("day")->value_name("L"),
      "day, dim (night), flicker (per-frame brightness), mixed (revisits dim)")(
      "depth", "also write depth/<stem>.png (16-bit, millimetres)")(
      "size", po::value<std::string>()->default_value("640x480")->value_name("WxH"),
      "image size in pixels")("hfov",
                              po::value<double>()->default_value(58.0, "58")->value_name("DEG"),
                              "the camera's horizontal field of view, degrees in (0, 180)")(
      "frames-per-room", po::value<int>()->default_value(72)->value_name("N"),
      "frames looking around at each visited room's centre")(
      "step-m", po::value<double>()->default_value(0.15, "0.15")->value_name("M"),
      "walking between frames, metres in (0, 2] (0.15: ~3 frames a second at 0.5 m/s; a "
      "denser camera takes smaller steps and turn steps with them)")(
      "turn-step-deg", po::value<double>()->default_value(30.0, "30")->value_name("D"),
      "turning towards the next waypoint between frames, degrees")(
      "scan-step-deg", po::value<double>()->default_value(5.0, "5")->value_name("D"),
      "turning between frames while looking around at a room's centre, degrees")(
      "every", po::value<int>()->default_value(1)->value_name("N"),
      "a camera with N times fewer frames on the same route (a slower frame rate): every N-th "
      "route frame; camera.json's spacing_m is N route steps")(
      "sweep-views", po::value<int>()->default_value(1)->value_name("K"),
      "views of a pan sweep per frame, written side by side (1 = forward camera only)")(
      "sweep-deg", po::value<double>()->default_value(360.0, "360")->value_name("D"),
      "pan covered by a sweep, degrees in (0, 360]")(
      "sweep-world-aligned",
      "take the sweep's views at fixed world headings, not relative to "
      "the robot")("png", "write PNG frames instead of JPEG (quality 90)")(
      "max-frames", po::value<int>()->default_value(0)->value_name("N"),
      "cut each robot's route after N frames (0 = whole route)");
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }

  sim::SimOptions options;
  try {
    options.world = sim::ParseWorldKind(vm["world"].as<std::string>());
    options.sweep = PanSweep(vm["sweep-views"].as<int>(), vm["sweep-deg"].as<double>());
    options.lighting = sim::ParseLightingMode(vm["lighting"].as<std::string>());
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const long long seed = vm["seed"].as<long long>();
  if (seed < 0 || seed > 4294967295LL) {
    throw UsageError("--seed " + std::to_string(seed) + " must be in [0, 4294967295]");
  }
  options.seed = static_cast<std::uint32_t>(seed);
  if (vm.count("route-seed")) {
    const long long route_seed = vm["route-seed"].as<long long>();
    if (route_seed < 0 || route_seed > 4294967295LL) {
      throw UsageError("--route-seed " + std::to_string(route_seed) +
                       " must be in [0, 4294967295]");
    }
    options.route_seed = static_cast<std::uint32_t>(route_seed);
  }
  options.robots = vm["robots"].as<int>();
  options.route.revisit_fraction = vm["revisit-fraction"].as<double>();
  options.route.dwell_frames = vm["frames-per-room"].as<int>();
  options.route.step_m = vm["step-m"].as<double>();
  options.route.turn_step_deg = vm["turn-step-deg"].as<double>();
  options.route.scan_step_deg = vm["scan-step-deg"].as<double>();
  options.frame_every = vm["every"].as<int>();
  options.depth = vm.count("depth") > 0;
  options.png = vm.count("png") > 0;
  options.sweep_world_aligned = vm.count("sweep-world-aligned") > 0;
  options.max_frames = vm["max-frames"].as<int>();
  ParseSize(vm["size"].as<std::string>(), &options.render.width, &options.render.height);
  options.render.hfov_deg = vm["hfov"].as<double>();
  try {
    options.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }

  const sim::SimSummary summary = sim::WriteSimulatedDataset(vm["out"].as<std::string>(), options);
  int total = 0;
  for (int f : summary.frames) total += f;
  std::cout << "tsc sim: wrote " << total << " frames of a " << sim::WorldKindName(options.world)
            << " world with " << summary.labels.size() << " places for " << options.robots
            << (options.robots == 1 ? " robot" : " robots") << " to " << vm["out"].as<std::string>()
            << "\n";
  return kExitOk;
}

}  // namespace

int RunSimCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("sim", [&] { return Sim(args); });
}

}  // namespace tsc
