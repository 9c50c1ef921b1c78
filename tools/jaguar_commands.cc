#include "tools/jaguar_commands.h"

#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <boost/program_options.hpp>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>

#include "daemon/lcm_bus.h"
#include "drivers/camera/make_camera.h"
#include "jaguar/motor_command_t.hpp"
#include "settings/daemon_options.h"
#include "settings/settings.h"
#include "tools/command_line.h"
#include "tools/simulators/jaguar_sim.h"

namespace tsc {
namespace {

namespace po = boost::program_options;

constexpr const char* kJaguarSimHelp =
    R"(usage: tsc jaguar-sim [--udp-port N] [--tcp-port N] [--pose-file PATH]
                      [--world SEED [--world-kind K] [--team-size K] [--route R] | --start X,Y,H]
                      [--drop F] [--bad-crc F] [--silence AT:FOR] [--silence-stop-s S]
                      [--seed N] [--seconds S] [calibration options]

A simulated Jaguar motor board on 127.0.0.1 speaking both protocols: the V2/V4 binary
protocol on a UDP port (tscd motor.driver = jaguar-v2) and the 4x4/V6 ASCII protocol on a TCP
port (motor.driver = jaguar-ascii). Ports 0 (the default) are chosen by the system; the first
line on stdout says which: "jaguar-sim: udp 127.0.0.1:P tcp 127.0.0.1:Q".
It integrates the commanded side powers into a pose (skid steer) and streams encoders,
battery and temperatures back at 10 Hz. --pose-file PATH gets the true pose as one line
"x y heading_rad" (metres, radians), replaced atomically at 25 Hz (the Axis simulator reads
it). The pose starts at the first pose of route R in the simulated world SEED (as tscd's
sim.* keys) or at --start.
Faults: --drop F drops a fraction F of the frames/lines it sends, --bad-crc F corrupts them
(wrong CRC / garbled line), --silence AT:FOR makes the board deaf and mute from AT seconds
after start for FOR seconds. Its own safety: the motors stop when the PC was silent for
--silence-stop-s (default 1; 0 = never: a real V2 board documents no such watchdog) and
when the TCP client disconnects.
Stops on SIGTERM/SIGINT (or after --seconds) and prints a summary.

Options)";

constexpr const char* kTeleopHelp =
    R"(usage: tsc teleop --robot ID [--lcm-url URL] [--linear-mps V] [--angular-radps W]
                  [--hold-s S] [--rate-hz R]

Drives robot ID from the keyboard: publishes jaguar.motor_command_t on JAGUAR_CMD_<ID>.
Keys: w / up = forward, s / down = back, a / left = turn left, d / right = turn right,
space = stop, e = e-stop (held until r), r = release the e-stop, q = quit (sends a stop).
Dead man: a motion lasts only while its key keeps coming (hold the key: the terminal repeats
it); --hold-s after the last key (default 0.6 s, above the usual auto-repeat delay) teleop
sends stop and then stays quiet, and the robot's own watchdog (0.5 s) covers a teleop that
dies. On a terminal the keys are read raw; from a pipe every byte is a key, so a script can
drive it.

Options)";

std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int) { g_stop = true; }

void InstallStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
}

std::vector<double> ParseList(const std::string& text, size_t n, char sep, const char* option) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, sep)) {
    try {
      size_t used = 0;
      out.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::logic_error&) {
      throw UsageError(std::string(option) + " '" + text + "': '" + item + "' is not a number");
    }
  }
  if (out.size() != n) {
    throw UsageError(std::string(option) + " '" + text + "': expected " + std::to_string(n) +
                     " numbers separated by '" + sep + "'");
  }
  return out;
}

}  // namespace

int RunJaguarSimCommand(const std::vector<std::string>& args) {
  po::options_description desc(kJaguarSimHelp);
  JaguarSimOptions o;
  desc.add_options()("help,h", "show this help")(
      "udp-port", po::value<int>(&o.udp_port)->default_value(0)->value_name("N"),
      "UDP port of the V2/V4 binary protocol (0: any free port)")(
      "tcp-port", po::value<int>(&o.tcp_port)->default_value(0)->value_name("N"),
      "TCP port of the 4x4/V6 ASCII protocol (0: any free port)")(
      "pose-file", po::value<std::string>(&o.pose_file)->value_name("PATH"),
      "write the true pose 'x y heading_rad' here at 25 Hz (atomically)")(
      "world", po::value<uint32_t>()->value_name("SEED"),
      "start at route R's first pose in the simulated world SEED (tscd's sim.world_seed)")(
      "world-kind", po::value<std::string>()->default_value("office")->value_name("K"),
      "office|corridors|outdoor (sim.world)")(
      "team-size", po::value<int>()->default_value(1)->value_name("K"), "sim.team_size")(
      "route", po::value<int>()->default_value(0)->value_name("R"), "sim.route")(
      "start", po::value<std::string>()->value_name("X,Y,H"),
      "start pose: metres, metres, radians")(
      "drop", po::value<double>(&o.drop_fraction)->default_value(0.0, "0")->value_name("F"),
      "fraction of sent frames/lines dropped")(
      "bad-crc", po::value<double>(&o.bad_crc_fraction)->default_value(0.0, "0")->value_name("F"),
      "fraction of sent frames with a wrong CRC (ASCII: garbled lines)")(
      "silence", po::value<std::string>()->value_name("AT:FOR"),
      "deaf and mute from AT s after start for FOR s")(
      "silence-stop-s",
      po::value<double>(&o.silence_stop_s)->default_value(1.0, "1")->value_name("S"),
      "stop the motors when the PC was silent this long (0: never)")(
      "seed", po::value<uint32_t>(&o.seed)->default_value(1)->value_name("N"),
      "seed of the fault injection")(
      "full-power-mps", po::value<double>(&o.full_power_mps)->default_value(1.5, "1.5"),
      "side speed at full power, m/s")(
      "track-width-m", po::value<double>(&o.track_width_m)->default_value(0.52, "0.52"),
      "distance between the tracks, m")(
      "counts-per-metre", po::value<double>(&o.counts_per_metre)->default_value(640.0, "640"),
      "encoder counts per metre")("seconds",
                                  po::value<double>()->default_value(0.0, "0")->value_name("S"),
                                  "stop after S seconds (0: run until SIGTERM/SIGINT)");
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return 0;
  }
  if (vm.count("world") && vm.count("start")) throw UsageError("give --world or --start, not both");
  if (vm.count("start")) {
    const auto s = ParseList(vm["start"].as<std::string>(), 3, ',', "--start");
    o.start_x_m = s[0], o.start_y_m = s[1], o.start_heading_rad = s[2];
  }
  if (vm.count("world")) {
    SimOptions sim;
    sim.world_seed = vm["world"].as<uint32_t>();
    sim.world = vm["world-kind"].as<std::string>();
    sim.team_size = vm["team-size"].as<int>();
    sim.route = vm["route"].as<int>();
    try {
      const SimBaseOptions start = ToSimBaseOptions(sim);
      o.start_x_m = start.start_x_m, o.start_y_m = start.start_y_m;
      o.start_heading_rad = start.start_heading_rad;
    } catch (const std::exception& e) {
      throw UsageError(std::string("--world: ") + e.what());
    }
  }
  if (vm.count("silence")) {
    const auto s = ParseList(vm["silence"].as<std::string>(), 2, ':', "--silence");
    o.silence_at_s = s[0], o.silence_for_s = s[1];
  }
  try {
    o.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  InstallStopHandlers();
  JaguarSim sim(o);
  std::cout << "jaguar-sim: udp 127.0.0.1:" << sim.udp_port() << " tcp 127.0.0.1:" << sim.tcp_port()
            << std::endl;
  const double seconds = vm["seconds"].as<double>();
  const auto start = std::chrono::steady_clock::now();
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (seconds > 0 &&
        std::chrono::steady_clock::now() - start >= std::chrono::duration<double>(seconds)) {
      break;
    }
  }
  const JaguarSimState s = sim.state();
  std::printf(
      "jaguar-sim: pose %.3f %.3f %.3f, %s; frames in %lld (rejected %lld), lines in %lld, "
      "sent %lld (dropped %lld, corrupted %lld), tcp clients %lld\n",
      s.x, s.y, s.heading,
      s.moving ? "moving"
               : ("stopped" + (s.stopped_by.empty() ? "" : " by " + s.stopped_by)).c_str(),
      static_cast<long long>(s.frames_in), static_cast<long long>(s.frames_rejected_in),
      static_cast<long long>(s.lines_in), static_cast<long long>(s.sent),
      static_cast<long long>(s.dropped), static_cast<long long>(s.corrupted),
      static_cast<long long>(s.tcp_clients));
  return 0;
}

namespace {

/// Raw keys on a terminal for as long as it lives; nothing on a pipe.
class RawTerminal {
 public:
  RawTerminal() {
    if (!::isatty(STDIN_FILENO) || ::tcgetattr(STDIN_FILENO, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = ::tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
  }
  ~RawTerminal() {
    if (active_) ::tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  RawTerminal(const RawTerminal&) = delete;
  RawTerminal& operator=(const RawTerminal&) = delete;

 private:
  termios saved_{};
  bool active_ = false;
};

using Steady = std::chrono::steady_clock;

// What the keys ask of the base: w/a/s/d or the arrows move while held (a motion lasts `hold`
// after its last key: the dead man), space stops, e latches the e-stop, r releases it, q quits.
class TeleopKeys {
 public:
  struct Command {
    double linear_mps = 0.0, angular_radps = 0.0;
    bool estop = false;
  };

  TeleopKeys(double linear, double angular, Steady::duration hold)
      : linear_(linear), angular_(angular), hold_(hold) {}

  void Key(char c, Steady::time_point now) {
    if (!escape_.empty() || c == '\x1b') {  // ESC [ A..D
      escape_ += c;
      if (escape_.size() < 3) return;
      const char arrow = escape_[2];
      escape_.clear();
      if (arrow == 'A') Move(linear_, 0, now);
      if (arrow == 'B') Move(-linear_, 0, now);
      if (arrow == 'D') Move(0, angular_, now);
      if (arrow == 'C') Move(0, -angular_, now);
      return;
    }
    switch (c) {
      case 'w':
        Move(linear_, 0, now);
        break;
      case 's':
        Move(-linear_, 0, now);
        break;
      case 'a':
        Move(0, angular_, now);
        break;
      case 'd':
        Move(0, -angular_, now);
        break;
      case ' ':
        v_ = w_ = 0, last_key_ = {};
        stops_left_ = 3;
        break;
      case 'e':
        estop_ = true;
        std::cerr << "teleop: E-STOP (r releases)\n";
        break;
      case 'r':
        estop_ = false;
        v_ = w_ = 0;
        stops_left_ = 3;
        break;
      case 'q':
        quit_ = true;
        break;
      default:
        break;
    }
  }
  void Quit() { quit_ = true; }
  bool quit() const { return quit_; }
  bool estop() const { return estop_; }

  /// The command of this period, if any: the e-stop while latched, the motion while held,
  /// then three stops once the dead man lets go (a lost datagram is no risk), then quiet.
  std::optional<Command> Next(Steady::time_point now) {
    if (estop_) return Command{0, 0, true};
    if ((v_ != 0 || w_ != 0) && now - last_key_ <= hold_) return Command{v_, w_, false};
    if (stops_left_ > 0) {
      v_ = w_ = 0;
      --stops_left_;
      return Command{0, 0, false};
    }
    return std::nullopt;
  }

 private:
  void Move(double v, double w, Steady::time_point now) {
    v_ = v, w_ = w;
    last_key_ = now;
    stops_left_ = 3;
  }

  double linear_, angular_;
  Steady::duration hold_;
  double v_ = 0, w_ = 0;
  bool estop_ = false, quit_ = false;
  int stops_left_ = 0;
  Steady::time_point last_key_{};
  std::string escape_;  // an arrow key's escape sequence in progress
};

}  // namespace

int RunTeleopCommand(const std::vector<std::string>& args) {
  po::options_description desc(kTeleopHelp);
  double linear = 0.5, angular = 1.0, hold_s = 0.6, rate_hz = 10.0;
  desc.add_options()("help,h", "show this help")(
      "robot", po::value<uint32_t>()->required()->value_name("ID"), "robot id")(
      "lcm-url", po::value<std::string>()->default_value(BusOptions{}.url)->value_name("URL"),
      "LCM provider")("linear-mps", po::value<double>(&linear)->default_value(0.5, "0.5"),
                      "forward speed of w/s, m/s")(
      "angular-radps", po::value<double>(&angular)->default_value(1.0, "1"),
      "turn rate of a/d, rad/s")("hold-s", po::value<double>(&hold_s)->default_value(0.6, "0.6"),
                                 "dead man: a motion lasts this long after its last key")(
      "rate-hz", po::value<double>(&rate_hz)->default_value(10.0, "10"),
      "commands per second while moving");
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return 0;
  }
  if (!(linear > 0 && linear <= 20 && angular > 0 && angular <= 20))
    throw UsageError("--linear-mps and --angular-radps must be in (0, 20]");
  if (!(hold_s > 0 && hold_s <= 5)) throw UsageError("--hold-s must be in (0, 5]");
  if (!(rate_hz >= 2 && rate_hz <= 100)) throw UsageError("--rate-hz must be in [2, 100]");
  const std::string channel = "JAGUAR_CMD_" + std::to_string(vm["robot"].as<uint32_t>());
  const std::string url = vm["lcm-url"].as<std::string>();
  try {  // the check tscd's lcm.url has: a multicast group, a port, a ttl LCM can use
    Settings checked;
    ApplyOverride("lcm.url=" + url, checked, "--lcm-url");
  } catch (const ConfigError& e) {
    throw UsageError(e.what());
  }
  LcmBus bus(url);
  InstallStopHandlers();
  RawTerminal terminal;
  std::cerr << "teleop on " << channel
            << ": w/a/s/d or arrows (hold), space stop, e e-stop, r release, q quit\n";

  const auto period = std::chrono::duration<double>(1.0 / rate_hz);
  TeleopKeys keys(
      linear, angular,
      std::chrono::duration_cast<Steady::duration>(std::chrono::duration<double>(hold_s)));
  int64_t sequence = 0;
  auto publish = [&](const TeleopKeys::Command& c) {
    jaguar::motor_command_t m{};
    m.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                  std::chrono::system_clock::now().time_since_epoch())
                  .count();
    m.sequence = ++sequence;
    m.linear_mps = c.linear_mps;
    m.angular_radps = c.angular_radps;
    m.estop = c.estop;
    if (!bus.Publish(channel, m)) std::cerr << "teleop: cannot publish on " << channel << "\n";
  };
  Steady::time_point next_send = Steady::now();
  while (!keys.quit() && !g_stop) {
    pollfd p{STDIN_FILENO, POLLIN, 0};
    const auto wait =
        std::chrono::duration_cast<std::chrono::milliseconds>(next_send - Steady::now());
    if (::poll(&p, 1, static_cast<int>(std::max<int64_t>(0, wait.count()))) > 0) {
      char buf[64];
      const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
      // End of a script, or a terminal that hung up: stop and quit.
      if (n < 0 || (n == 0 && (!::isatty(STDIN_FILENO) || (p.revents & (POLLHUP | POLLERR))))) {
        keys.Quit();
      }
      for (ssize_t i = 0; i < n; ++i) keys.Key(buf[i], Steady::now());
    }
    const auto now = Steady::now();
    if (now < next_send) continue;
    next_send = now + std::chrono::duration_cast<Steady::duration>(period);
    if (const auto command = keys.Next(now)) publish(*command);
  }
  publish({0, 0, keys.estop()});
  return 0;
}

}  // namespace tsc
