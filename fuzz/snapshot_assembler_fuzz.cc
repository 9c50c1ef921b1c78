// Fuzz target: a peer's memory as the daemon receives it. The input is a stream of portions,
// each a 4-byte big-endian length and a memory_portion_v2_t encoding; they are decoded, given
// the digest of what arrived of their version (so the fuzzer gets past the digest check, as a
// peer that computes digests honestly over a malicious memory would), fed to a
// SnapshotAssembler, and a snapshot it accepts is turned into a place memory and a map as the
// daemon does before merging, then merged into a memory of ours, maps included, as the
// daemon merges it: a memory the assembler accepts is merged or refused with
// std::invalid_argument, nothing else (the daemon's worker survives either). The bodies of a
// complete snapshot are offered to the next assembly, as the daemon does for a peer's next
// version (issue 23), with their names (KeptPlaceNames): bodies known by name are left
// unloaded, the merge's first question is asked of the names (MergeLeavesOurs), and the bodies
// are then loaded as the daemon loads them for a merge.
//
// The options are those of the view basis the snapshot declares (none, or tscd's default
// builtin one), so that both kinds of memory are reached; tscd itself refuses a basis not its
// own before this point (ToPlaceMemory).

#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/merge/merge.h"
#include "core/merge/merge_maps.h"
#include "core/pipeline/pipeline.h"
#include "daemon/lcm_bus.h"
#include "daemon/memory_snapshot.h"
#include "daemon/snapshot_assembler.h"
#include "fuzz/fuzz_target.h"
#include "test/support/random_memory.h"

namespace {

// The receiving robot's memory: robot 1 holding the places the seeds' peer holds (the same
// random seed, fuzz/make_seeds.cc), so that merging a seed absorbs places, not only adds them.
const tsc::testing_support::RandomMemory& Ours(bool builtin_basis) {
  static const tsc::testing_support::RandomMemory plain =
      tsc::testing_support::MakeRandomMemory(1, 12, 32, 1, 4);
  static const tsc::testing_support::RandomMemory in_basis = tsc::testing_support::MakeRandomMemory(
      1, 4, tsc::BuiltinViewBasis()->input_dimension(), 1, 4, tsc::PipelineOptions{}.memory);
  return builtin_basis ? in_basis : plain;
}

void MergeAsTheDaemonDoes(const tsc::PeerSnapshot& snapshot) {
  const bool builtin_basis = snapshot.view_basis == tsc::ViewBasisId(tsc::BuiltinViewBasis().get());
  const tsc::testing_support::RandomMemory& ours = Ours(builtin_basis);
  // tscd never fetches a memory announced under its own robot id (PeerExchange).
  if (snapshot.robot == static_cast<int32_t>(ours.memory.robot())) return;
  try {
    tsc::PlaceMemory peer = tsc::ToPlaceMemory(snapshot, ours.memory.options());
    const tsc::TopologicalMap peer_map = tsc::ToTopologicalMap(snapshot);
    const tsc::MemoryMerge merged = tsc::MergeMemories(ours.memory, std::move(peer));
    const tsc::TopologicalMap map = tsc::MergeMaps(ours.map, peer_map, merged.memory);
    (void)tsc::MergeChangesAnything(merged, map, ours.map);
  } catch (const std::invalid_argument&) {
    // refused, as the daemon refuses it: the documented way to fail
  }
}

// What tscd asks of a snapshot before building the peer's memory: whether the ids alone say the
// merge leaves ours as it is.
void AskByNames(const tsc::PeerSnapshot& snapshot, const tsc::KeptPlaceNames* names) {
  const bool builtin_basis = snapshot.view_basis == tsc::ViewBasisId(tsc::BuiltinViewBasis().get());
  const tsc::testing_support::RandomMemory& ours = Ours(builtin_basis);
  if (snapshot.robot == static_cast<int32_t>(ours.memory.robot())) return;
  const auto by_name = tsc::PlaceNamesOf(snapshot, ours.memory, names);
  if (by_name) {
    (void)tsc::MergeLeavesOurs(ours.memory, static_cast<uint32_t>(snapshot.robot), *by_name);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<tsc::memory_portion_v2_t> portions;
  size_t at = 0;
  while (at + 4 <= size && portions.size() < 64) {
    const size_t n = (size_t{data[at]} << 24) | (size_t{data[at + 1]} << 16) |
                     (size_t{data[at + 2]} << 8) | size_t{data[at + 3]};
    at += 4;
    if (n > size - at) break;
    if (auto p = tsc::LcmBus::Decode<tsc::memory_portion_v2_t>(data + at, n)) {
      portions.push_back(std::move(*p));
    }
    at += n;
  }
  if (portions.empty()) return 0;
  std::map<int64_t, std::vector<tsc::memory_portion_v2_t>> by_version;
  for (const tsc::memory_portion_v2_t& p : portions) by_version[p.version].push_back(p);
  std::map<int64_t, int64_t> digests;
  for (const auto& [version, of_version] : by_version) {
    digests[version] = tsc::SnapshotDigest(of_version);
  }
  std::optional<tsc::SnapshotAssembler> dut(std::in_place, portions.front().robot);
  tsc::PlaceBodies kept;
  std::optional<tsc::KeptPlaceNames> names;  // of the bodies in `kept`
  const auto load = [&](const tsc::KnownDigests&) { return kept; };
  for (tsc::memory_portion_v2_t& p : portions) {
    p.digest = digests[p.version];
    dut->Accept(p);
    (void)dut->Missing();
    if (!dut->complete()) continue;
    auto known = std::make_shared<const tsc::KnownDigests>(dut->Named());
    std::string reason;
    std::optional<tsc::PeerSnapshot> snapshot = dut->Take(&reason, load, names ? &*names : nullptr);
    dut.emplace(portions.front().robot, std::move(known));
    if (!snapshot) continue;
    AskByNames(*snapshot, names ? &*names : nullptr);
    names = tsc::NamesOfBodies(*snapshot, names ? &*names : nullptr);
    if (!tsc::LoadKeptBodies(*snapshot, load, &reason)) {  // as tscd, which fetches it whole
      names.reset();
      kept.clear();
      continue;
    }
    // What a receiver keeps of it for the next (tscd: in its store).
    kept.clear();
    for (size_t i = 0; i < snapshot->places.size(); ++i) {
      kept.emplace(snapshot->entries[i].body_digest, snapshot->places[i]);
    }
    MergeAsTheDaemonDoes(*snapshot);
  }
  return 0;
}
