// tscd — the per-robot TSC daemon. Usage: tscd --help.
// Exit codes: 0 ok, 1 runtime failure, 2 usage error, 78 configuration error (EX_CONFIG).

#include <malloc.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <boost/program_options.hpp>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/descriptor_space_mismatch.h"
#include "daemon/daemon.h"
#include "drivers/camera/make_camera.h"
#include "drivers/motor/make_motor.h"

namespace po = boost::program_options;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
constexpr int kExitConfig = 78;

constexpr const char* kUsageLine =
    "Usage: tscd [--config FILE] [--robot ID] [--state-dir DIR] [--set section.key=value]...\n";

constexpr const char* kUsage =
    "tscd: topological spatial cognition daemon for one robot.\n"
    "Reads its camera, detects, recognises and learns places, maps how they connect, keeps\n"
    "its memory in STATE_DIR/memory.db and exchanges it with its team over LCM.\n"
    "Channels: publishes TSC_ANNOUNCE (every lcm.announce_period_s), TSC_EVENT_<robot>\n"
    "(place events), TSC_MEMORY_<robot> (its memory in portions), TSC_STATS_<robot>\n"
    "(counters), JAGUAR_STATE_<robot> (odometry, 10 Hz) and TSC_REQUEST_<peer> (to fetch a\n"
    "peer's memory); reads TSC_ANNOUNCE and TSC_MEMORY_* of its peers, TSC_REQUEST_<robot>\n"
    "(a peer asking for its memory) and JAGUAR_CMD_<robot> (motor commands).\n\n"
    "Usage: tscd [--config FILE] [--robot ID] [--state-dir DIR] [--set section.key=value]...\n"
    "       tscd --print-config | --version | --help\n\n"
    "Signals: SIGTERM/SIGINT stop cleanly (final commit), SIGHUP reloads the configuration.\n"
    "Every key: `tsc config`. Exit codes: 0 ok, 1 failure (also: stopped with results the\n"
    "store did not take; see the log), 2 usage, 78 configuration error.\n\n"
    "Options";

// glibc raises its mmap threshold to the size of every large block freed (up to 32 MB), so
// after a merge's large temporaries, later ones of their size are carved from the heap and
// leave holes between the places built beside them. Held at 4 MB (a camera frame of up to
// 1280x1024 BGR still comes from the heap, not a fresh mapping each time): RSS 15 s after a
// 10⁴ + 10⁴ merge 204-206 → 198 MB, the merge's time and the frames' page faults unchanged
// (tscd_footprint --peer-places 10000; docs/results.md, session 84). At glibc's initial 128 KB
// every 640x480 frame was mapped anew: 8x the page faults. A threshold set through the
// environment is left as it is.
void HoldMmapThreshold() {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (std::getenv("MALLOC_MMAP_THRESHOLD_") != nullptr ||
      (tunables != nullptr && std::strstr(tunables, "mmap_threshold") != nullptr)) {
    return;
  }
  constexpr int kThresholdBytes = 4 << 20;
  mallopt(M_MMAP_THRESHOLD, kThresholdBytes);
}

void SetUpLogging(uint32_t robot, const std::string& level) {
  auto logger = spdlog::stderr_logger_mt("tscd");
  // Under systemd the journal adds the time and the unit; elsewhere we do.
  if (std::getenv("JOURNAL_STREAM") != nullptr) {
    logger->set_pattern("<%l> %v");
  } else {
    logger->set_pattern("%H:%M:%S.%e tscd[" + std::to_string(robot) + "] %l: %v");
  }
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
  spdlog::flush_on(spdlog::level::info);
}

}  // namespace

int main(int argc, char** argv) {
  HoldMmapThreshold();  // before any thread starts
  po::options_description desc(kUsage);
  desc.add_options()("help,h", "show this help")("version", "print the version and exit")(
      "config,c", po::value<std::string>()->value_name("FILE"), "configuration file (INI)")(
      "robot,r", po::value<std::string>()->value_name("ID"), "robot id (robot.id)")(
      "state-dir,s", po::value<std::string>()->value_name("DIR"),
      "folder of memory.db (daemon.state_dir)")(
      "set", po::value<std::vector<std::string>>()->composing()->value_name("KEY=VALUE"),
      "override one configuration key (repeatable)")("print-config",
                                                     "print the effective configuration and exit");
  po::variables_map vm;
  try {
    const po::parsed_options parsed = po::command_line_parser(argc, argv).options(desc).run();
    // An argument that is no option (`tscd my.ini`) would otherwise be ignored and tscd would
    // run on its built-in defaults.
    const std::vector<std::string> extra =
        po::collect_unrecognized(parsed.options, po::include_positional);
    if (!extra.empty()) {
      std::cerr << "tscd: unexpected argument '" << extra.front()
                << "' (a configuration file is given with --config FILE)\n"
                << kUsageLine << "See tscd --help.\n";
      return kExitUsage;
    }
    po::store(parsed, vm);
    po::notify(vm);
  } catch (const po::error& e) {
    std::cerr << "tscd: " << e.what() << " (tscd --help)\n";
    return kExitUsage;
  }
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  if (vm.count("version")) {
    std::cout << "tscd " << TSCD_VERSION << "\n";
    return kExitOk;
  }

  tsc::SettingsSource source;
  if (vm.count("config")) source.file = vm["config"].as<std::string>();
  if (vm.count("set")) source.overrides = vm["set"].as<std::vector<std::string>>();
  // The dedicated flags are keys too, given last so they win; checked like every other key.
  // Each is checked on its own first, so an error names the flag (--robot), not --set.
  std::vector<std::pair<std::string, std::string>> flags;  // (flag, key=value)
  if (vm.count("robot")) flags.emplace_back("--robot", "robot.id=" + vm["robot"].as<std::string>());
  if (vm.count("state-dir")) {
    flags.emplace_back("--state-dir", "daemon.state_dir=" + vm["state-dir"].as<std::string>());
  }
  for (const auto& [flag, assignment] : flags) {
    try {
      tsc::Settings scratch;
      tsc::ApplyOverride(assignment, scratch, flag);
    } catch (const tsc::ConfigError& e) {
      std::cerr << "tscd: configuration error: " << e.what() << "\n";
      return kExitConfig;
    }
    source.overrides.push_back(assignment);
  }
  tsc::Settings settings;
  try {
    settings = tsc::LoadSettings(source.file, source.overrides);
  } catch (const tsc::ConfigError& e) {
    std::cerr << "tscd: configuration error: " << e.what() << "\n";
    return kExitConfig;
  }
  if (vm.count("print-config")) {
    std::cout << tsc::DumpConfig(settings);
    return kExitOk;
  }
  SetUpLogging(settings.pipeline.robot, settings.daemon.log_level);

  std::optional<tsc::TeamKey> team_key;
  if (!settings.daemon.bus.team_key_file.empty()) {
    try {
      team_key = tsc::TeamKey::Load(settings.daemon.bus.team_key_file);
    } catch (const tsc::TeamKeyError& e) {
      spdlog::critical("lcm.team_key_file: {}", e.what());
      return kExitConfig;
    }
  }
  std::unique_ptr<tsc::MotorBase> base;
  std::unique_ptr<tsc::CameraSource> camera;
  try {
    base = tsc::MakeMotor(settings.daemon.motor, settings.daemon.camera, settings.daemon.sim);
  } catch (const std::exception& e) {
    spdlog::critical("motor: {}", e.what());
    return kExitConfig;
  }
  try {
    camera = tsc::MakeCamera(settings.daemon.camera, settings.daemon.sim, base.get());
  } catch (const std::exception& e) {
    spdlog::critical("camera: {}", e.what());
    return kExitConfig;
  }
  try {
    tsc::Daemon daemon(std::move(settings), std::move(source), std::move(camera), std::move(base),
                       std::move(team_key));
    return daemon.Run();
  } catch (const tsc::DescriptorSpaceMismatch& e) {
    spdlog::critical("configuration error: {}", e.what());
    return kExitConfig;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return kExitFailure;
  }
}
