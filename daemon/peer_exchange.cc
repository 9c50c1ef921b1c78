#include "daemon/peer_exchange.h"

#include <chrono>

namespace tsc {

PeerExchange::PeerExchange(int32_t self, PeerExchangeOptions options,
                           std::map<int32_t, MergedVersion> merged)
    : self_(self), options_(options), merged_(std::move(merged)) {}

bool PeerExchange::OnAnnounce(const announce_t& a, Clock::time_point now) {
  if (a.robot == self_ || a.robot <= 0) return true;
  auto [it, fresh] = peers_.try_emplace(a.robot);
  Peer& p = it->second;
  if (!fresh && a.boot_id == p.boot_id && a.sequence <= p.sequence) {
    ++replays_;
    return false;
  }
  // Versions only grow within a boot: an announce older than a version its portions already
  // brought (an answer moves past the announced version) is not new content.
  if (fresh || a.boot_id != p.boot_id || a.memory_version >= p.version) {
    p.version = a.memory_version;
    p.digest = a.memory_digest;
    p.structure_portions = a.structure_portions;
  }
  p.boot_id = a.boot_id;
  p.sequence = a.sequence;
  p.other_basis = a.view_basis != options_.view_basis;
  if (p.other_basis) {
    ++other_basis_;
    last_rejection_ =
        "robot " + std::to_string(a.robot) +
        " keeps member views in another basis (memory.view_basis differs): not fetched";
  }
  p.seen = now;
  return true;
}

bool PeerExchange::Wanted(int32_t robot, const Peer& peer) const {
  if (peer.version <= 0 || peer.other_basis) return false;
  const auto m = merged_.find(robot);
  // A new digest means new content, whatever the version says (a restarted peer counts anew).
  return m == merged_.end() || m->second.digest != peer.digest;
}

memory_request_t PeerExchange::Request(int32_t robot, int64_t version,
                                       std::vector<int32_t> missing) const {
  memory_request_t r{};
  r.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                std::chrono::system_clock::now().time_since_epoch())
                .count();
  r.requester = self_;
  r.robot = robot;
  r.version = version;
  r.missing = std::move(missing);
  r.num_missing = static_cast<int32_t>(r.missing.size());
  r.hmac_size = 0;
  return r;
}

std::vector<memory_request_t> PeerExchange::Tick(Clock::time_point now) {
  for (auto it = peers_.begin(); it != peers_.end();) {
    if (now - it->second.seen > options_.peer_timeout && fetching_ != it->first) {
      it = peers_.erase(it);
    } else {
      ++it;
    }
  }
  if (fetching_) {
    if (now - last_request_ < options_.retry) return {};
    if (++retries_ > options_.max_retries) {
      ++given_up_;
      // Not again until the peer announces anew (about a second: a natural back-off).
      if (auto p = peers_.find(*fetching_); p != peers_.end()) p->second.version = 0;
      fetching_.reset();
      assembler_.reset();
      return {};
    }
    last_request_ = now;
    // The version being assembled, which a newer broadcast or answer may have moved past the
    // announced one: portions asked for by index must be of the version they index.
    const int64_t version = assembler_->started() ? assembler_->version() : fetching_version_;
    return {Request(*fetching_, version, PortionsToAskFor())};
  }
  // Start with the first wanted peer at or after the round-robin position.
  std::optional<int32_t> pick;
  for (const auto& [robot, peer] : peers_) {
    if (!Wanted(robot, peer)) continue;
    if (!pick || (robot >= next_start_ && *pick < next_start_)) pick = robot;
  }
  if (!pick) return {};
  next_start_ = *pick + 1;
  fetching_ = *pick;
  fetching_version_ = peers_[*pick].version;
  const auto known = known_.find(*pick);
  assembler_.emplace(*pick, known == known_.end() ? nullptr : known->second);
  retries_ = 0;
  last_request_ = now;
  return {Request(*pick, fetching_version_, PortionsToAskFor())};
}

std::vector<int32_t> PeerExchange::PortionsToAskFor() const {
  if (assembler_->started()) return assembler_->Missing();
  // Nothing has come yet. Without bodies of this peer: everything (the empty list); with
  // them: the structure, which says which bodies are new.
  const auto known = known_.find(*fetching_);
  const int32_t structure = peers_.at(*fetching_).structure_portions;
  if (known == known_.end() || structure <= 0) return {};
  return PortionsBelow(structure);
}

size_t PeerExchange::known_bodies() const {
  size_t n = 0;
  for (const auto& [robot, bodies] : known_) n += bodies->size();
  return n;
}

std::optional<SnapshotAssembler> PeerExchange::OnPortion(const memory_portion_v2_t& p,
                                                         Clock::time_point now) {
  if (!fetching_ || p.robot != *fetching_ || !assembler_) return std::nullopt;
  const bool had_structure = assembler_->structure_complete();
  const SnapshotAssembler::Result r = assembler_->Accept(p);
  if (r.verdict == SnapshotAssembler::Verdict::kRejected) {
    ++rejected_portions_;
    last_rejection_ = r.reason;
    return std::nullopt;
  }
  if (r.verdict == SnapshotAssembler::Verdict::kAccepted) {
    retries_ = 0;  // progress: the retry budget is for silence
    // The structure we asked for alone just came in whole: ask for the bodies it names that we
    // lack at the next tick instead of after the retry period.
    if (!had_structure && assembler_->structure_complete() && known_.contains(p.robot)) {
      last_request_ = now - options_.retry;
    }
  }
  if (!assembler_->complete()) return std::nullopt;
  // Known before the caller has checked and kept them (it merges in the order completed, so
  // before a next fetch completes); a check, merge or keeping that fails makes it Forget them.
  known_[p.robot] = std::make_shared<const KnownDigests>(assembler_->Named());
  // The peer answered with a version newer than it announced (the one asked for had been
  // withdrawn by a merge): that one is what it holds now. The announced one, fetched again,
  // would bring back this version at every tick until the peer's next announce.
  if (auto peer = peers_.find(p.robot); peer != peers_.end() && peer->second.boot_id == p.boot_id &&
                                        assembler_->version() > peer->second.version) {
    peer->second.version = assembler_->version();
    peer->second.digest = assembler_->digest();
    peer->second.structure_portions = p.structure_portions;
  }
  std::optional<SnapshotAssembler> complete = std::move(assembler_);
  fetching_.reset();
  assembler_.reset();
  return complete;
}

void PeerExchange::MarkMerged(int32_t robot, MergedVersion v) { merged_[robot] = v; }

void PeerExchange::Know(int32_t robot, KnownDigests digests) {
  known_[robot] = std::make_shared<const KnownDigests>(std::move(digests));
}

}  // namespace tsc
