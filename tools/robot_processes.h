#pragma once
// Process management shared by `tsc team` and `tsc soak`: a private network namespace whose
// multicast stays on lo, tscd robots as child processes with their logs, their exit, and
// what /proc says about them.

#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace tsc {

/// Runs a program (no shell) and waits for it. Returns its exit status (128 + signal when
/// killed), or -1 if it could not start. With `output`, what it writes to stdout and stderr
/// is put there instead of this process's terminal.
int RunProgram(const std::vector<std::string>& argv, std::string* output = nullptr);

/// True when this network namespace has an interface other than lo, i.e. multicast could
/// leave the host (read from /proc/self/net/dev).
bool HasNonLoopbackInterface();

/// Re-executes `tsc <subcommand> <args>` inside a new network namespace (`unshare -n`, or
/// `-rn` for a user without root) with the environment variable `marker` set, so the new
/// process knows it is inside. Returns only on failure (1, the error on stderr).
int ReexecInNewNamespace(const std::string& subcommand, const std::vector<std::string>& args,
                         const char* marker);

/// Host-local multicast inside the private namespace: lo up, multicast on, 224.0.0.0/4 on lo.
/// Throws std::runtime_error when `ip` fails.
void SetUpLoopbackMulticast();

/// Where `tsc team` and `tsc soak` run their robots. With `netns` "new" (and not yet inside)
/// re-executes `tsc <subcommand> <args>` in a new private namespace and returns its failure;
/// otherwise refuses (exit 1, reason on stderr) a namespace with interfaces other than lo,
/// sets up host-local multicast and returns nothing: the caller goes on here.
std::optional<int> EnterPrivateNetwork(const std::string& subcommand,
                                       const std::vector<std::string>& args,
                                       const std::string& netns, const char* marker);

/// The tscd binary next to this tsc. Throws std::runtime_error when it is missing.
std::filesystem::path TscdBesideThisTsc();

/// Starts `program` with `argv` (argv[0] included), stdout and stderr appended to `log`.
/// Throws std::runtime_error naming the program when it cannot start.
pid_t SpawnProcess(const std::filesystem::path& program, const std::vector<std::string>& argv,
                   const std::filesystem::path& log);

/// A child's exit, once reaped.
struct ChildExit {
  bool exited = false;
  int status = 0;  ///< exit code, or 128 + signal
};
/// Reaps `pid` if it has exited (or waits for it when `block`).
ChildExit ReapChild(pid_t pid, bool block);

/// Waits up to `grace_s` for `pid` to exit; then SIGKILL. Returns how it ended.
ChildExit WaitForExit(pid_t pid, double grace_s);
/// Sends SIGTERM, then WaitForExit.
ChildExit TerminateChild(pid_t pid, double grace_s);

/// What /proc says about a live process.
struct ProcessSample {
  bool alive = false;
  double rss_mb = 0.0;       ///< VmRSS
  double peak_rss_mb = 0.0;  ///< VmHWM
  double cpu_s = 0.0;        ///< utime + stime, seconds
  int threads = 0;
};
ProcessSample SampleProcess(pid_t pid);

}  // namespace tsc
