#include "tools/axis_sim_command.h"

#include <pthread.h>

#include <boost/program_options.hpp>
#include <csignal>
#include <exception>
#include <iostream>
#include <stdexcept>

#include "drivers/camera/axis_camera.h"
#include "tools/command_line.h"
#include "tools/simulators/axis_sim.h"

namespace tsc {
namespace {

namespace po = boost::program_options;

constexpr const char* kAxisSimHelp =
    R"(usage: tsc axis-sim [--port N] [--world SEED] [--world-kind office|corridors|outdoor]
                    [--pose X,Y,HEADING | --pose-file PATH] [--hfov-deg D]
                    [--auth none|basic|digest --user NAME --password-file FILE]
                    [--drop-after N] [--no-content-length] [--bomb-frame N] [--bomb-every N]

A simulated Axis PTZ network camera (VAPIX) on 127.0.0.1 only. Serves
  /axis-cgi/mjpg/video.cgi?resolution=WxH&fps=N&compression=C   multipart MJPEG
  /axis-cgi/jpg/image.cgi?resolution=WxH                          one JPEG
  /axis-cgi/com/ptz.cgi?pan=&tilt=&zoom= | rpan=&rtilt=&rzoom= | query=position
Frames are rendered from the simulated world of --world SEED at the robot's pose turned by the
current pan (Axis convention: degrees, clockwise). The pose is read for every frame from
--pose-file (one line "x y heading_rad", as `tsc jaguar-sim --pose-file` writes it), else fixed
by --pose (default: the centre of the world's first room, heading 0). Tilt is reported but the
rendering stays level. The password is read from a file that only its owner may read (0600).
--drop-after N closes every MJPEG stream after N frames (reconnection tests);
--no-content-length sends MJPEG parts without Content-Length;
--bomb-frame N makes frame N (0-based) of every MJPEG stream a JPEG whose header claims
20512x35225 pixels (a decompression bomb, for the bounded-decoding tests); --bomb-every N
makes every Nth frame one.

Prints "tsc axis-sim: serving http://127.0.0.1:PORT" once listening (--port 0 picks a free
port) and runs until SIGINT or SIGTERM.

Options)";

sim::Pose2 ParsePose(const std::string& text) {
  sim::Pose2 p;
  char c1 = 0, c2 = 0, tail = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c%lf%c", &p.x, &c1, &p.y, &c2, &p.heading, &tail) != 5 ||
      c1 != ',' || c2 != ',') {
    throw UsageError("--pose '" + text + "' is not X,Y,HEADING (metres, metres, radians)");
  }
  return p;
}

int AxisSimMain(const std::vector<std::string>& args) {
  po::options_description desc(kAxisSimHelp);
  desc.add_options()("help,h", "show this help")(
      "port", po::value<int>()->default_value(8080)->value_name("N"),
      "TCP port on 127.0.0.1; 0 = a free one")(
      "world", po::value<long long>()->default_value(1)->value_name("SEED"),
      "seed of the simulated world (as tsc sim --seed and sim.world_seed)")(
      "world-kind", po::value<std::string>()->default_value("office")->value_name("KIND"),
      "office, corridors or outdoor")("pose", po::value<std::string>()->value_name("X,Y,HEADING"),
                                      "fixed robot pose, metres and radians")(
      "pose-file", po::value<std::string>()->value_name("PATH"),
      "file holding the robot pose 'x y heading_rad', re-read for every frame")(
      "hfov-deg", po::value<double>()->default_value(60.0, "60")->value_name("D"),
      "horizontal field of view, degrees")(
      "auth", po::value<std::string>()->default_value("none")->value_name("MODE"),
      "none, basic or digest")("user", po::value<std::string>()->default_value("root"),
                               "user name for --auth")(
      "password-file", po::value<std::string>()->value_name("FILE"),
      "file holding the password (mode 0600 or 0400)")(
      "drop-after", po::value<int>()->default_value(0)->value_name("N"),
      "close every MJPEG stream after N frames; 0 = never")(
      "no-content-length", "MJPEG parts without Content-Length headers")(
      "bomb-frame", po::value<int>()->default_value(-1)->value_name("N"),
      "frame N of every MJPEG stream claims 20512x35225 pixels; -1 = never")(
      "bomb-every", po::value<int>()->default_value(0)->value_name("N"),
      "every Nth frame of every MJPEG stream claims 20512x35225 pixels; 0 = never");
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return 0;
  }
  AxisSimOptions options;
  options.port = vm["port"].as<int>();
  const long long seed = vm["world"].as<long long>();
  if (seed < 0 || seed > 4294967295LL) throw UsageError("--world must be in [0, 4294967295]");
  options.world_seed = static_cast<std::uint32_t>(seed);
  try {
    options.world = sim::ParseWorldKind(vm["world-kind"].as<std::string>());
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--world-kind: ") + e.what());
  }
  if (vm.count("pose")) options.pose = ParsePose(vm["pose"].as<std::string>());
  if (vm.count("pose-file")) options.pose_file = vm["pose-file"].as<std::string>();
  options.hfov_deg = vm["hfov-deg"].as<double>();
  options.auth = vm["auth"].as<std::string>();
  options.user = vm["user"].as<std::string>();
  options.drop_after_frames = vm["drop-after"].as<int>();
  options.omit_content_length = vm.count("no-content-length") > 0;
  options.bomb_frame = vm["bomb-frame"].as<int>();
  options.bomb_every = vm["bomb-every"].as<int>();
  if (options.auth != "none") {
    if (!vm.count("password-file"))
      throw UsageError("--auth " + options.auth + " needs --password-file");
    try {
      options.password = ReadPasswordFile(vm["password-file"].as<std::string>());
    } catch (const CameraError& e) {
      std::cerr << "tsc axis-sim: " << e.what() << "\n";
      return kExitConfig;
    }
  }
  try {
    options.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }

  // Signals are taken by sigwait on this thread; the server's threads inherit the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  AxisSim server(options);
  std::cout << "tsc axis-sim: serving http://127.0.0.1:" << server.port() << " (world "
            << options.world_seed << ", auth " << options.auth << ")" << std::endl;
  int received = 0;
  sigwait(&signals, &received);
  server.Stop();
  std::cout << "tsc axis-sim: stopped after " << server.frames_served() << " frames, "
            << server.streams_opened() << " streams";
  if (server.bombs_served() > 0) std::cout << ", " << server.bombs_served() << " bombs";
  std::cout << std::endl;
  return 0;
}

}  // namespace

int RunAxisSimCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("axis-sim", [&] { return AxisSimMain(args); });
}

}  // namespace tsc
