#include "daemon/join_gate.h"

namespace tsc {

JoinGate::JoinGate(bool closed, Clock::duration join_wait, Clock::duration longest,
                   Clock::time_point now)
    : open_(!closed), quiet_until_(now + join_wait), give_up_at_(now + longest) {}

void JoinGate::PeerHeard(Clock::time_point) {
  std::lock_guard lock(mutex_);
  peer_heard_ = true;
}

void JoinGate::PeerMerged() {
  std::lock_guard lock(mutex_);
  OpenLocked();
}

std::string JoinGate::Tick(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  if (open_) return "";
  if (!peer_heard_ && now >= quiet_until_) {
    OpenLocked();
    return "no peer heard";
  }
  if (now >= give_up_at_) {
    OpenLocked();
    return "a peer was heard but its memory did not arrive";
  }
  return "";
}

void JoinGate::Open() {
  std::lock_guard lock(mutex_);
  OpenLocked();
}

void JoinGate::Wait() {
  std::unique_lock lock(mutex_);
  opened_.wait(lock, [this] { return open_; });
}

bool JoinGate::open() const {
  std::lock_guard lock(mutex_);
  return open_;
}

void JoinGate::OpenLocked() {
  open_ = true;
  opened_.notify_all();
}

}  // namespace tsc
