#pragma once
// Which peer to fetch a memory from, and when to ask again (DESIGN §4, chapter 4): peers are
// discovered from their announces; the robot fetches one peer's memory at a time, only when
// that peer announces a memory it has not merged yet; lost portions are asked for again until
// the snapshot completes or the attempt is given up. The place bodies of each peer's last
// complete memory are kept (by the merge, in the store; here their digests), so the next fetch
// asks for the structure first and then only for the bodies it names that are new (issue 23). Pure
// logic with the time passed in, so loss and timeouts are tested without sockets; the daemon does
// the sending.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/snapshot_assembler.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_request_t.hpp"

namespace tsc {

struct PeerExchangeOptions {
  std::chrono::milliseconds retry{500};           ///< ask again for missing portions after this
  int max_retries = 20;                           ///< then give up on this attempt
  std::chrono::milliseconds peer_timeout{10000};  ///< a peer silent this long is forgotten
  /// ViewBasisId of our member views: a peer announcing another is never fetched (its views
  /// do not compare with ours; a team must share memory.view_basis).
  int64_t view_basis = 0;
};

/// What is known of a merged peer memory (kept in the store's peers table).
struct MergedVersion {
  int64_t version = 0;
  int64_t digest = 0;
};

class PeerExchange {
 public:
  using Clock = std::chrono::steady_clock;

  PeerExchange(int32_t self, PeerExchangeOptions options,
               std::map<int32_t, MergedVersion> merged = {});

  /// An announce whose signature the caller has checked. Returns false (and counts it) for a
  /// replay: the same boot with a sequence not above the last one seen.
  bool OnAnnounce(const announce_t& a, Clock::time_point now);
  /// A portion of the peer being fetched (others are ignored). When this portion completed
  /// the memory, its portions, still to be joined and checked by the caller
  /// (SnapshotAssembler::Take: the digest over every portion, the slow part) where that holds
  /// up nothing else; the exchange with that peer ends here either way.
  std::optional<SnapshotAssembler> OnPortion(const memory_portion_v2_t& p, Clock::time_point now);
  /// Requests to send now: the first request of a new exchange, or a repeat for what is
  /// missing. At most one peer at a time.
  std::vector<memory_request_t> Tick(Clock::time_point now);
  /// The caller merged (or deliberately skipped) this snapshot: it will not be fetched again.
  void MarkMerged(int32_t robot, MergedVersion v);
  /// The caller keeps the bodies of `robot` with these digests (its store, at start): they are
  /// not fetched again. A completed memory replaces them by the digests it names, which the
  /// caller keeps when it merges it (or Forgets).
  void Know(int32_t robot, KnownDigests digests);
  /// The merge of `robot`'s memory failed: fetch it again, whole, when it is next announced.
  void Forget(int32_t robot) {
    merged_.erase(robot);
    known_.erase(robot);
  }

  std::optional<int32_t> fetching() const { return fetching_; }
  int64_t replays() const { return replays_; }
  int64_t rejected_portions() const { return rejected_portions_; }
  int64_t given_up() const { return given_up_; }
  /// Announces of peers whose member views are kept in another basis (not fetched).
  int64_t other_basis() const { return other_basis_; }
  const std::string& last_rejection() const { return last_rejection_; }
  /// Peers heard from within the peer timeout (or being fetched).
  size_t peers() const { return peers_.size(); }
  /// Peers whose merged memory version is remembered.
  size_t merged_peers() const { return merged_.size(); }
  /// Portions of the memory being fetched held until it completes.
  size_t buffered_portions() const { return assembler_ ? assembler_->buffered() : 0; }
  /// Place bodies kept from the peers' last complete memories (their digests).
  size_t known_bodies() const;

 private:
  struct Peer {
    int64_t boot_id = 0;
    int64_t sequence = 0;
    int64_t version = 0;
    int64_t digest = 0;
    int32_t structure_portions = 0;
    bool other_basis = false;  // its views are in another basis: never fetched
    Clock::time_point seen{};
  };
  bool Wanted(int32_t robot, const Peer& peer) const;
  /// What to ask the peer being fetched for now.
  std::vector<int32_t> PortionsToAskFor() const;
  memory_request_t Request(int32_t robot, int64_t version, std::vector<int32_t> missing) const;

  int32_t self_;
  PeerExchangeOptions options_;
  std::map<int32_t, MergedVersion> merged_;
  std::map<int32_t, Peer> peers_;
  std::map<int32_t, std::shared_ptr<const KnownDigests>> known_;  // by peer
  std::optional<int32_t> fetching_;
  std::optional<SnapshotAssembler> assembler_;
  int64_t fetching_version_ = 0;
  Clock::time_point last_request_{};
  int retries_ = 0;
  int32_t next_start_ = 0;  // round-robin over peers so one busy peer cannot starve the others
  int64_t replays_ = 0;
  int64_t rejected_portions_ = 0;
  int64_t given_up_ = 0;
  int64_t other_basis_ = 0;
  std::string last_rejection_;
};

}  // namespace tsc
