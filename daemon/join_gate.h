#pragma once
// A robot that starts with an empty memory (a first start, or a state directory wiped) may be
// rejoining a team that still holds its old places under their ids 1..n. Learning before it
// has merged them would give a new place an old id, and the merge would take the new place
// for a fresher copy of the old one. So the camera waits at this gate: it opens when a peer's
// memory has been merged (the ids then continue after the team's, core/merge), when no peer
// holding places was heard for the join wait (a robot alone, or a team starting together), or after
// the longest wait (a peer heard whose memory never completed: learning goes on, and says so).
// Issue 21 item 5.

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>

namespace tsc {

class JoinGate {
 public:
  using Clock = std::chrono::steady_clock;
  /// `closed`: the memory is empty and the join wait is positive. `join_wait`: how long to
  /// listen for peers; `longest`: the wait's bound while a peer is heard but not merged.
  JoinGate(bool closed, Clock::duration join_wait, Clock::duration longest, Clock::time_point now);

  /// A peer holding places announced itself (event loop).
  void PeerHeard(Clock::time_point now);
  /// A peer memory was merged (worker): opens.
  void PeerMerged();
  /// Time passed (event loop timer): opens when the wait is over. Returns why it opened, or ""
  /// while it stays closed (also when it was open already).
  std::string Tick(Clock::time_point now);
  /// Opens at once (stopping).
  void Open();
  /// Blocks until open (camera thread).
  void Wait();
  bool open() const;

 private:
  void OpenLocked();

  mutable std::mutex mutex_;
  std::condition_variable opened_;
  bool open_;
  bool peer_heard_ = false;
  Clock::time_point quiet_until_, give_up_at_;
};

}  // namespace tsc
