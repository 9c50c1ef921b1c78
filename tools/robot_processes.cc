#include "tools/robot_processes.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace tsc {
namespace fs = std::filesystem;

int RunProgram(const std::vector<std::string>& argv, std::string* output) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  int pipe_fds[2] = {-1, -1};
  if (output != nullptr && ::pipe2(pipe_fds, O_CLOEXEC) != 0) return -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (output != nullptr) {
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
  }
  pid_t pid = -1;
  const int spawned = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (output != nullptr) {
    ::close(pipe_fds[1]);
    output->clear();
    char buf[4096];
    for (ssize_t n; spawned == 0 && (n = ::read(pipe_fds[0], buf, sizeof buf)) != 0;) {
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) break;
      output->append(buf, static_cast<size_t>(n));
    }
    ::close(pipe_fds[0]);
  }
  if (spawned != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

bool HasNonLoopbackInterface() {
  std::ifstream dev("/proc/self/net/dev");
  if (!dev) return true;
  std::string line;
  for (int i = 0; std::getline(dev, line); ++i) {
    if (i < 2) continue;  // two header lines
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string name = line.substr(0, colon);
    name.erase(0, name.find_first_not_of(' '));
    if (name != "lo") return true;
  }
  return false;
}

int ReexecInNewNamespace(const std::string& subcommand, const std::vector<std::string>& args,
                         const char* marker) {
  std::vector<std::string> argv = {"unshare", getuid() == 0 ? "-n" : "-rn", "--",
                                   fs::read_symlink("/proc/self/exe").string(), subcommand};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<char*> raw;
  for (const std::string& a : argv) raw.push_back(const_cast<char*>(a.c_str()));
  raw.push_back(nullptr);
  setenv(marker, "1", 1);
  execvp("unshare", raw.data());
  std::cerr << "tsc: cannot run unshare to create a private network namespace: "
            << std::strerror(errno) << "\n";
  return 1;
}

void SetUpLoopbackMulticast() {
  if (RunProgram({"ip", "link", "set", "lo", "up"}) != 0 ||
      RunProgram({"ip", "link", "set", "lo", "multicast", "on"}) != 0) {
    throw std::runtime_error("cannot bring up lo with multicast in the private namespace (ip)");
  }
  // "File exists" when a caller already added it: fine, and not printed (ip's own
  // "RTNETLINK answers: File exists" on the terminal looked like a failure).
  std::string said;
  if (RunProgram({"ip", "route", "add", "224.0.0.0/4", "dev", "lo"}, &said) != 0 &&
      said.find("File exists") == std::string::npos) {
    throw std::runtime_error("cannot route multicast on lo in the private namespace: ip: " + said);
  }
}

std::optional<int> EnterPrivateNetwork(const std::string& subcommand,
                                       const std::vector<std::string>& args,
                                       const std::string& netns, const char* marker) {
  if (netns == "new" && std::getenv(marker) == nullptr) {
    return ReexecInNewNamespace(subcommand, args, marker);
  }
  if (HasNonLoopbackInterface()) {
    std::cerr << "tsc: refusing to run the " << subcommand
              << " in a network namespace with interfaces other than lo (its multicast could "
                 "leave this host); use --netns new\n";
    return 1;
  }
  SetUpLoopbackMulticast();
  return std::nullopt;
}

std::filesystem::path TscdBesideThisTsc() {
  const std::filesystem::path tscd =
      std::filesystem::read_symlink("/proc/self/exe").parent_path() / "tscd";
  if (!std::filesystem::exists(tscd)) {
    throw std::runtime_error("tscd not found next to tsc: " + tscd.string());
  }
  return tscd;
}

pid_t SpawnProcess(const fs::path& program, const std::vector<std::string>& argv,
                   const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> raw;
  for (const std::string& a : argv) raw.push_back(const_cast<char*>(a.c_str()));
  raw.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, program.c_str(), &actions, nullptr, raw.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    throw std::runtime_error("cannot start " + program.string() + ": " + std::strerror(rc));
  }
  return pid;
}

ChildExit ReapChild(pid_t pid, bool block) {
  int status = 0;
  const pid_t got = waitpid(pid, &status, block ? 0 : WNOHANG);
  if (got != pid) return {};
  return {true, WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status)};
}

ChildExit TerminateChild(pid_t pid, double grace_s) {
  kill(pid, SIGTERM);
  return WaitForExit(pid, grace_s);
}

ChildExit WaitForExit(pid_t pid, double grace_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace_s);
  while (std::chrono::steady_clock::now() < deadline) {
    const ChildExit e = ReapChild(pid, false);
    if (e.exited) return e;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  return ReapChild(pid, true);
}

ProcessSample SampleProcess(pid_t pid) {
  ProcessSample s;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  const std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const size_t paren = text.rfind(')');
  if (paren == std::string::npos || paren + 2 >= text.size()) return s;
  // Field 3 is the state (Z: exited, not reaped yet); 14 utime, 15 stime (clock ticks).
  std::istringstream fields(text.substr(paren + 2));
  std::string f;
  double utime = 0, stime = 0;
  for (int i = 3; fields >> f; ++i) {
    if (i == 3 && (f == "Z" || f == "X")) return s;
    if (i == 14) utime = std::stod(f);
    if (i == 15) {
      stime = std::stod(f);
      break;
    }
  }
  s.cpu_s = (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  bool has_rss = false;  // a process that died since its stat was read has no VmRSS
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) {
      s.rss_mb = std::stod(line.substr(6)) / 1024.0;
      has_rss = true;
    }
    if (line.rfind("VmHWM:", 0) == 0) s.peak_rss_mb = std::stod(line.substr(6)) / 1024.0;
    if (line.rfind("Threads:", 0) == 0) s.threads = std::stoi(line.substr(8));
  }
  s.alive = has_rss;
  return s;
}

}  // namespace tsc
