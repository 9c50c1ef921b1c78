#include "daemon/snapshot_assembler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

#include "test/support/derived_compare.h"
#include "test/support/random_memory.h"

namespace tsc {
namespace {

constexpr int kDim = 64;

MemorySnapshot MakeSnapshot(int places, int64_t version, int portion_bytes = 6000) {
  const auto m = testing_support::MakeRandomMemory(2, places, kDim, static_cast<unsigned>(places));
  return BuildSnapshot(m.memory, m.map, {2, 77, version, 1}, portion_bytes);
}

TEST(SnapshotAssembler, CompletesFromShuffledDuplicatedPortionsAfterAskingForTheLostOne) {
  const MemorySnapshot snap = MakeSnapshot(30, 4);
  ASSERT_GE(static_cast<size_t>(snap.count()), 3u);
  std::vector<memory_portion_v2_t> order = AllPortions(snap);
  std::mt19937 rng(1);
  std::shuffle(order.begin(), order.end(), rng);
  const memory_portion_v2_t lost = order.back();
  order.pop_back();
  order.push_back(order.front());  // a duplicate

  SnapshotAssembler dut(2);
  for (const memory_portion_v2_t& p : order) {
    const auto r = dut.Accept(p);
    EXPECT_NE(r.verdict, SnapshotAssembler::Verdict::kRejected) << r.reason;
  }
  EXPECT_FALSE(dut.complete());
  EXPECT_EQ(dut.Missing(), std::vector<int32_t>{lost.index});
  EXPECT_EQ(dut.Accept(lost).verdict, SnapshotAssembler::Verdict::kAccepted);
  ASSERT_TRUE(dut.complete());
  std::string reason;
  const auto got = dut.Take(&reason);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(got->places.size(), 30u);
  EXPECT_EQ(got->version, 4);
  EXPECT_EQ(got->edges.size(), 29u);
  std::vector<learned_place_v2_t> sent;
  for (const memory_portion_v2_t& p : AllPortions(snap))
    sent.insert(sent.end(), p.places.begin(), p.places.end());
  ASSERT_EQ(sent.size(), 30u);
  for (size_t i = 0; i < sent.size(); ++i) EXPECT_EQ(got->places[i]->mean, sent[i].mean) << i;
  int32_t expected_local = 1;
  for (const auto& p : got->places) EXPECT_EQ(p->id.local, expected_local++);
}

// ToPlaceMemory lets the bodies go a few hundred at a time as it builds: past such a batch
// each place is still built from its own body.
TEST(ToPlaceMemory, BuildsEveryPlaceFromItsOwnBodyPastTheBodiesLetGo) {
  constexpr int kPlaces = 700;
  const auto m = testing_support::MakeRandomMemory(2, kPlaces, kDim, 7);
  const MemorySnapshot snap = BuildSnapshot(m.memory, m.map, {2, 77, 1, 1}, 6000);
  SnapshotAssembler assembler(2);
  for (const memory_portion_v2_t& p : AllPortions(snap)) {
    ASSERT_EQ(assembler.Accept(p).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  std::string reason;
  auto peer = assembler.Take(&reason);
  ASSERT_TRUE(peer.has_value()) << reason;
  const PlaceMemory built = ToPlaceMemory(std::move(*peer), PlaceMemoryOptions{});
  ASSERT_EQ(built.places().size(), m.memory.places().size());
  for (size_t p = 0; p < built.places().size(); ++p) {
    const LearnedPlace &got = built.places()[p], &sent = m.memory.places()[p];
    EXPECT_EQ(got.id, sent.id) << p;
    EXPECT_TRUE(got.mean == sent.mean) << p;
    EXPECT_TRUE(got.samples == sent.samples) << p;
  }
}

// The worker builds a peer's memory on its merge threads: the same memory on any number.
TEST(ToPlaceMemory, BuildsTheSameMemoryOnAnyNumberOfThreads) {
  const MemorySnapshot snap = MakeSnapshot(40, 1);
  SnapshotAssembler assembler(2);
  for (const memory_portion_v2_t& p : AllPortions(snap)) {
    ASSERT_EQ(assembler.Accept(p).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  std::string reason;
  const auto peer = assembler.Take(&reason);
  ASSERT_TRUE(peer.has_value()) << reason;
  const PlaceMemory one = ToPlaceMemory(*peer, PlaceMemoryOptions{}, 1);
  const PlaceMemory three = ToPlaceMemory(*peer, PlaceMemoryOptions{}, 3);
  ASSERT_EQ(one.places().size(), 40u);
  ASSERT_EQ(three.places().size(), one.places().size());
  EXPECT_EQ(three.slink().pi(), one.slink().pi());
  EXPECT_EQ(three.slink().lambda(), one.slink().lambda());
  for (int p = 0; p < static_cast<int>(one.places().size()); ++p) {
    const LearnedPlace &a = one.places()[static_cast<size_t>(p)],
                       &b = three.places()[static_cast<size_t>(p)];
    EXPECT_EQ(b.id, a.id);
    EXPECT_TRUE(b.mean == a.mean);
    EXPECT_TRUE(b.samples.Decoded() == a.samples.Decoded());
  }
  EXPECT_EQ(testing_support::DerivedDifference(three, one), "");
}

TEST(SnapshotAssembler, RejectsForeignNonFiniteAndInconsistentPortions) {
  const MemorySnapshot snap = MakeSnapshot(12, 1);
  SnapshotAssembler dut(2);
  memory_portion_v2_t other = snap.Portion(0);
  other.robot = 3;
  EXPECT_EQ(dut.Accept(other).verdict, SnapshotAssembler::Verdict::kRejected);

  const memory_portion_v2_t& body = snap.Portion(snap.structure_portions);
  memory_portion_v2_t nan = body;
  ASSERT_EQ(nan.places.size(), 1u);
  nan.places[0].mean[3] = std::nanf("");
  EXPECT_EQ(dut.Accept(nan).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_v2_t small = body;  // integers no encoding gives: the largest below 2^14
  for (auto& col : small.places[0].samples) std::fill(col.begin(), col.end(), int16_t{1});
  EXPECT_EQ(dut.Accept(small).reason, "member views that are no 16-bit encoding");

  memory_portion_v2_t huge = body;  // a valid encoding whose squared distances overflow (fuzzing)
  huge.places[0].view_shift = -15;
  EXPECT_EQ(dut.Accept(huge).reason, "out-of-range member views");

  memory_portion_v2_t view_dims = body;  // rows of another length than the body claims
  view_dims.places[0].view_dims += 1;
  EXPECT_EQ(dut.Accept(view_dims).reason, "bad sample");
  view_dims.places[0].view_dims = 0;
  EXPECT_EQ(dut.Accept(view_dims).reason, "bad view dimension");

  memory_portion_v2_t lengths = body;
  lengths.num_places += 1;
  EXPECT_EQ(dut.Accept(lengths).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_v2_t two = body;  // a body portion holds one place
  two.places.push_back(two.places[0]);
  two.num_places = 2;
  EXPECT_EQ(dut.Accept(two).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_v2_t lambda = snap.Portion(0);
  ASSERT_FALSE(lambda.entries.empty());
  lambda.entries[0].slink_lambda = std::nan("");
  EXPECT_EQ(dut.Accept(lambda).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_v2_t bodies = snap.Portion(0);  // more places than bodies
  bodies.total_places += 1;
  EXPECT_EQ(dut.Accept(bodies).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_v2_t index = snap.Portion(0);
  index.index = index.count;
  EXPECT_EQ(dut.Accept(index).verdict, SnapshotAssembler::Verdict::kRejected);
  EXPECT_FALSE(dut.started());  // nothing kept
}

// Every portion of a version names the basis its views are kept in; one that names another
// does not belong to the memory being assembled.
TEST(SnapshotAssembler, PortionsOfOneVersionAgreeOnTheViewBasis) {
  const MemorySnapshot snap = MakeSnapshot(12, 1);
  SnapshotAssembler dut(2);
  ASSERT_EQ(dut.Accept(snap.Portion(0)).verdict, SnapshotAssembler::Verdict::kAccepted);
  memory_portion_v2_t other = snap.Portion(1);
  other.view_basis = 99;
  const SnapshotAssembler::Result r = dut.Accept(other);
  EXPECT_EQ(r.verdict, SnapshotAssembler::Verdict::kRejected);
  EXPECT_NE(r.reason.find("disagrees"), std::string::npos) << r.reason;
}

TEST(SnapshotAssembler, TamperedContentFailsTheDigests) {
  const MemorySnapshot snap = MakeSnapshot(8, 1);
  {
    SnapshotAssembler dut(2);
    for (memory_portion_v2_t p : AllPortions(snap)) {
      if (!p.places.empty()) p.places[0].mean[0] += 0.25f;  // finite, plausible, wrong
      ASSERT_EQ(dut.Accept(p).verdict, SnapshotAssembler::Verdict::kAccepted);
    }
    std::string reason;
    EXPECT_FALSE(dut.Take(&reason).has_value());
    EXPECT_EQ(reason, "a place body does not match its digest");
    EXPECT_FALSE(dut.started());
  }
  {
    SnapshotAssembler dut(2);
    for (memory_portion_v2_t p : AllPortions(snap)) {
      for (place_entry_t& e : p.entries) e.slink_lambda += 0.25;  // the structure changed
      ASSERT_EQ(dut.Accept(p).verdict, SnapshotAssembler::Verdict::kAccepted);
    }
    std::string reason;
    EXPECT_FALSE(dut.Take(&reason).has_value());
    EXPECT_EQ(reason, "digest mismatch");
  }
}

// Issue 23: a receiver that kept the bodies of version 1 asks for the structure of version 2
// and then only for the body of the place that changed, and ends with version 2 exactly.
TEST(SnapshotAssembler, KnownBodiesLeaveOnlyTheChangedPlaceToAskFor) {
  auto m = testing_support::MakeRandomMemory(2, 80, kDim, 80);
  const MemorySnapshot v1 = BuildSnapshot(m.memory, m.map, {2, 77, 1, 1}, 4096);
  SnapshotAssembler first(2);
  for (const memory_portion_v2_t& p : AllPortions(v1)) first.Accept(p);
  ASSERT_TRUE(first.complete());
  const auto known = std::make_shared<const KnownDigests>(first.Named());
  EXPECT_EQ(*known, KnownDigests(v1.body_digests.begin(), v1.body_digests.end()));
  // What the receiver keeps them in (tscd: its store).
  PlaceBodies kept;
  for (size_t i = 0; i < v1.bodies.size(); ++i) kept.emplace(v1.body_digests[i], v1.bodies[i]);
  KnownDigests asked;
  const BodyLoader load = [&](const KnownDigests& digests) {
    asked = digests;
    return kept;
  };

  DetectedPlace revisit;  // place 12 seen again: its mean and samples change
  revisit.index = 81;
  revisit.descriptors = Eigen::MatrixXf::Constant(kDim, 4, 0.5f);
  revisit.members = {3100, 3101, 3102, 3103};
  m.memory.Update(12, revisit);
  const MemorySnapshot v2 = BuildSnapshot(m.memory, m.map, {2, 77, 2, 2}, 4096);
  ASSERT_GE(v2.structure_portions, 2);
  ASSERT_NE(v2.digest, v1.digest);

  SnapshotAssembler dut(2, known);
  EXPECT_TRUE(dut.Missing().empty());  // nothing has come: the caller asks for the structure
  for (int32_t i = 0; i + 1 < v2.structure_portions; ++i) {
    ASSERT_EQ(dut.Accept(v2.Portion(i)).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  // Structure incomplete: only the structure is asked for, not bodies that may be known.
  EXPECT_EQ(dut.Missing(), std::vector<int32_t>{v2.structure_portions - 1});
  dut.Accept(v2.Portion(v2.structure_portions - 1));
  ASSERT_TRUE(dut.structure_complete());
  EXPECT_EQ(dut.Missing(), std::vector<int32_t>{v2.structure_portions + 12});
  EXPECT_EQ(dut.Accept(v2.Portion(v2.structure_portions + 12)).verdict,
            SnapshotAssembler::Verdict::kAccepted);
  ASSERT_TRUE(dut.complete());
  EXPECT_EQ(dut.buffered(), static_cast<size_t>(v2.structure_portions) + 1);
  std::string reason;
  const auto got = dut.Take(&reason, load);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(asked.size(), 79u);  // every body but the one that came
  EXPECT_FALSE(asked.contains(v2.body_digests[12]));
  ASSERT_EQ(got->places.size(), 80u);
  for (size_t i = 0; i < 80; ++i) {
    const learned_place_v2_t& want = *v2.bodies[i];
    EXPECT_EQ(got->places[i]->mean, want.mean) << i;
    EXPECT_EQ(got->places[i]->samples, want.samples) << i;
  }
  EXPECT_EQ(got->places[0], v1.bodies[0]);  // as loaded, not copied
}

// A known body the receiver no longer keeps (its store lost or damaged it): the snapshot is
// refused with the reason, and the assembler starts over (tscd then fetches the memory whole).
TEST(SnapshotAssembler, AKnownBodyNoLongerKeptRefusesTheSnapshot) {
  auto m = testing_support::MakeRandomMemory(2, 30, kDim, 30);
  const MemorySnapshot v1 = BuildSnapshot(m.memory, m.map, {2, 77, 1, 1}, 4096);
  const auto known =
      std::make_shared<const KnownDigests>(v1.body_digests.begin(), v1.body_digests.end());
  PlaceBodies kept;
  for (size_t i = 0; i + 1 < v1.bodies.size(); ++i) kept.emplace(v1.body_digests[i], v1.bodies[i]);
  for (const BodyLoader& load :
       {BodyLoader{}, BodyLoader([&](const KnownDigests&) { return kept; })}) {
    SnapshotAssembler dut(2, known);
    for (int32_t i = 0; i < v1.structure_portions; ++i) dut.Accept(v1.Portion(i));
    ASSERT_TRUE(dut.complete());  // every body known
    std::string reason;
    EXPECT_FALSE(dut.Take(&reason, load).has_value());
    EXPECT_EQ(reason, "a place body kept from an earlier version is no longer kept");
    EXPECT_FALSE(dut.started());
  }
}

// A receiver that took `v1` whole, as tscd keeps it for the next version: the digests of its
// bodies (for the next assembler) and their names.
struct Received {
  std::shared_ptr<const KnownDigests> known;
  KeptPlaceNames names;
};
Received ReceiveWhole(const MemorySnapshot& v1) {
  SnapshotAssembler first(2);
  for (const memory_portion_v2_t& p : AllPortions(v1)) first.Accept(p);
  auto known = std::make_shared<const KnownDigests>(first.Named());
  std::string reason;
  const auto got = first.Take(&reason);
  if (!got) throw std::runtime_error("not taken: " + reason);
  return Received{std::move(known), NamesOfBodies(*got, nullptr)};
}

// Issue 23: a receiver that also keeps the names of the bodies it merged (KeptPlaceNames) checks
// the next version's known bodies by their names and loads none until the merge needs them; the
// ids and sources it then reads are those of the bodies, and loading them later gives exactly
// the bodies.
TEST(SnapshotAssembler, KnownBodiesNamedAreLoadedOnlyWhenAsked) {
  auto m = testing_support::MakeRandomMemory(2, 80, kDim, 81);
  const MemorySnapshot v1 = BuildSnapshot(m.memory, m.map, {2, 77, 1, 1}, 4096);
  const Received received = ReceiveWhole(v1);
  const auto& known = received.known;
  const auto& names = received.names;
  ASSERT_EQ(names.size(), 80u);
  std::string reason;
  PlaceBodies kept;
  for (size_t i = 0; i < v1.bodies.size(); ++i) kept.emplace(v1.body_digests[i], v1.bodies[i]);
  size_t loads = 0;
  KnownDigests asked;
  const BodyLoader load = [&](const KnownDigests& digests) {
    ++loads;
    asked = digests;
    return kept;
  };

  DetectedPlace revisit;  // place 12 seen again
  revisit.index = 81;
  revisit.descriptors = Eigen::MatrixXf::Constant(kDim, 4, 0.5f);
  revisit.members = {3100, 3101, 3102, 3103};
  m.memory.Update(12, revisit);
  const MemorySnapshot v2 = BuildSnapshot(m.memory, m.map, {2, 77, 2, 2}, 4096);
  const auto assemble = [&] {
    SnapshotAssembler dut(2, known);
    for (int32_t i = 0; i < v2.structure_portions; ++i) dut.Accept(v2.Portion(i));
    dut.Accept(v2.Portion(v2.structure_portions + 12));
    EXPECT_TRUE(dut.complete());
    return dut;
  };

  auto got = assemble().Take(&reason, load, &names);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(loads, 0u);
  EXPECT_EQ(got->unloaded, 79);
  ASSERT_EQ(got->places.size(), 80u);
  for (size_t i = 0; i < 80; ++i) EXPECT_EQ(got->places[i] == nullptr, i != 12) << i;
  EXPECT_THROW(ToPlaceMemory(*got, PlaceMemoryOptions{}), std::invalid_argument);

  // The names the merge's first question reads, as from the bodies themselves.
  const auto by_name = PlaceNamesOf(*got, m.memory, &names);
  ASSERT_TRUE(by_name.has_value());
  EXPECT_FALSE(PlaceNamesOf(*got, m.memory).has_value());  // unloaded and unnamed
  ASSERT_EQ(by_name->size(), m.memory.places().size());
  for (size_t i = 0; i < by_name->size(); ++i) {
    EXPECT_EQ((*by_name)[i].id, m.memory.places()[i].id) << i;
    EXPECT_EQ((*by_name)[i].sources, m.memory.places()[i].sources) << i;
  }
  // The successor's names: the received body's own, the others carried.
  const KeptPlaceNames next = NamesOfBodies(*got, &names);
  EXPECT_EQ(next.size(), 80u);
  EXPECT_TRUE(next.Find(v2.body_digests[12]).has_value());
  EXPECT_FALSE(next.Find(v1.body_digests[12]).has_value());

  ASSERT_TRUE(LoadKeptBodies(*got, load, &reason)) << reason;
  EXPECT_EQ(loads, 1u);
  EXPECT_EQ(asked.size(), 79u);
  EXPECT_EQ(got->unloaded, 0);
  for (size_t i = 0; i < 80; ++i) {
    EXPECT_EQ(got->places[i]->mean, v2.bodies[i]->mean) << i;
    EXPECT_EQ(got->places[i]->samples, v2.bodies[i]->samples) << i;
  }
  EXPECT_EQ(ToPlaceMemory(*got, PlaceMemoryOptions{}).places().size(), 80u);

  // Names that miss a known body do not do: every known body is loaded, as without names.
  std::vector<KeptPlaceNames::Named> partial;
  for (size_t i = 1; i < 80; ++i) {
    partial.push_back({v1.body_digests[i], m.memory.places()[i].id, {}});
  }
  const KeptPlaceNames missing_one(kDim, std::move(partial));
  loads = 0;
  got = assemble().Take(&reason, load, &missing_one);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(loads, 1u);
  EXPECT_EQ(got->unloaded, 0);

  // A structure that names a known body for another place is refused by its name, as by its
  // body; so is one whose named bodies are of another dimension.
  std::vector<KeptPlaceNames::Named> shifted;
  for (size_t i = 0; i < 80; ++i) {
    shifted.push_back({v1.body_digests[i], m.memory.places()[(i + 1) % 80].id, {}});
  }
  const KeptPlaceNames wrong_ids(kDim, std::move(shifted));
  EXPECT_FALSE(assemble().Take(&reason, load, &wrong_ids).has_value());
  EXPECT_EQ(reason, "a place body of another place");
  std::vector<KeptPlaceNames::Named> same;
  for (size_t i = 0; i < 80; ++i) same.push_back({v1.body_digests[i], m.memory.places()[i].id, {}});
  const KeptPlaceNames wrong_dims(kDim + 1, std::move(same));
  EXPECT_FALSE(assemble().Take(&reason, load, &wrong_dims).has_value());
  EXPECT_EQ(reason, "places of different dimensions");
}

// A body left unloaded that the receiver no longer keeps when the merge asks for it: refused
// with the reason, so tscd fetches the memory whole.
TEST(LoadKeptBodies, SaysWhichBodyCannotBeLoaded) {
  auto m = testing_support::MakeRandomMemory(2, 20, kDim, 20);
  const MemorySnapshot v1 = BuildSnapshot(m.memory, m.map, {2, 77, 1, 1}, 4096);
  const Received received = ReceiveWhole(v1);
  const auto& known = received.known;
  const auto& names = received.names;
  SnapshotAssembler dut(2, known);
  std::string reason;
  for (int32_t i = 0; i < v1.structure_portions; ++i) dut.Accept(v1.Portion(i));
  auto got = dut.Take(&reason, {}, &names);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(got->unloaded, 20);
  PlaceBodies all_but_one;
  for (size_t i = 1; i < v1.bodies.size(); ++i) {
    all_but_one.emplace(v1.body_digests[i], v1.bodies[i]);
  }
  EXPECT_FALSE(LoadKeptBodies(
      *got, [&](const KnownDigests&) { return all_but_one; }, &reason));
  EXPECT_EQ(reason, "a place body kept from an earlier version is no longer kept");
}

// A peer whose memory changes while we assemble it: the bodies received of the version given
// up count for the next, so a receiver with nothing known still completes (the soak's
// restarted robots fetching peers that learn as they drive).
TEST(SnapshotAssembler, BodiesOfAReplacedVersionCarryOverToTheNext) {
  auto m = testing_support::MakeRandomMemory(2, 80, kDim, 80);
  const MemorySnapshot v1 = BuildSnapshot(m.memory, m.map, {2, 77, 1, 1}, 4096);
  DetectedPlace revisit;
  revisit.index = 81;
  revisit.descriptors = Eigen::MatrixXf::Constant(kDim, 4, 0.5f);
  revisit.members = {3100, 3101, 3102, 3103};
  m.memory.Update(12, revisit);
  const MemorySnapshot v2 = BuildSnapshot(m.memory, m.map, {2, 77, 2, 2}, 4096);

  SnapshotAssembler dut(2);
  for (int32_t i = v1.structure_portions; i < v1.count(); ++i) {
    ASSERT_EQ(dut.Accept(v1.Portion(i)).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  ASSERT_FALSE(dut.complete());  // version 1's structure was lost
  for (int32_t i = 0; i < v2.structure_portions; ++i) {
    ASSERT_EQ(dut.Accept(v2.Portion(i)).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  EXPECT_EQ(dut.version(), 2);
  EXPECT_EQ(dut.Missing(), std::vector<int32_t>{v2.structure_portions + 12});
  dut.Accept(v2.Portion(v2.structure_portions + 12));
  ASSERT_TRUE(dut.complete());
  std::string reason;
  const auto got = dut.Take(&reason);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(got->digest, v2.digest);
}

// A body whose content is not what the structure names is refused, even when the receiver
// knows a body of that digest.
TEST(SnapshotAssembler, AReceivedBodyMustMatchItsEntry) {
  const MemorySnapshot snap = MakeSnapshot(5, 1);
  SnapshotAssembler first(2);
  for (const memory_portion_v2_t& p : AllPortions(snap)) first.Accept(p);
  ASSERT_TRUE(first.complete());
  SnapshotAssembler dut(2, std::make_shared<const KnownDigests>(first.Named()));
  memory_portion_v2_t swapped = snap.Portion(snap.structure_portions + 1);
  swapped.places[0] = snap.Portion(snap.structure_portions).places[0];
  swapped.first_place = 1;
  for (int32_t i = 0; i < snap.structure_portions; ++i) dut.Accept(snap.Portion(i));
  ASSERT_TRUE(dut.complete());  // every body known
  ASSERT_EQ(dut.Accept(swapped).verdict, SnapshotAssembler::Verdict::kAccepted);
  PlaceBodies kept;
  for (size_t i = 0; i < snap.bodies.size(); ++i)
    kept.emplace(snap.body_digests[i], snap.bodies[i]);
  std::string reason;
  EXPECT_FALSE(dut.Take(&reason, [&](const KnownDigests&) { return kept; }).has_value());
  EXPECT_EQ(reason, "a place body does not match its digest");
}

TEST(SnapshotAssembler, NewerVersionRestartsOlderIsStale) {
  const MemorySnapshot v1 = MakeSnapshot(8, 1);
  const MemorySnapshot v2 = MakeSnapshot(9, 2);
  SnapshotAssembler dut(2);
  ASSERT_EQ(dut.Accept(v1.Portion(0)).verdict, SnapshotAssembler::Verdict::kAccepted);
  ASSERT_EQ(dut.Accept(v2.Portion(0)).verdict, SnapshotAssembler::Verdict::kAccepted);
  EXPECT_EQ(dut.version(), 2);
  EXPECT_EQ(dut.Accept(v1.Portion(0)).verdict, SnapshotAssembler::Verdict::kStale);
  for (const memory_portion_v2_t& p : AllPortions(v2)) dut.Accept(p);
  std::string reason;
  const auto got = dut.Take(&reason);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(got->places.size(), 9u);
}

TEST(SnapshotAssembler, BrokenTreeIsRefusedAsAWhole) {
  MemorySnapshot snap = MakeSnapshot(6, 1, 60000);
  ASSERT_EQ(snap.structure_portions, 1);
  std::vector<memory_portion_v2_t> portions = AllPortions(snap);
  memory_portion_v2_t& p = portions[0];
  ASSERT_GE(p.nodes.size(), 2u);
  p.nodes.back().children.push_back(p.nodes.back().index);  // a node its own child
  p.nodes.back().num_children += 1;
  p.digest = snap.digest = SnapshotDigest(portions);  // an honest digest of a bad tree
  SnapshotAssembler dut(2);
  for (memory_portion_v2_t& q : portions) {
    q.digest = snap.digest;
    ASSERT_EQ(dut.Accept(q).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  std::string reason;
  EXPECT_FALSE(dut.Take(&reason).has_value());
  EXPECT_FALSE(reason.empty());
}

}  // namespace
}  // namespace tsc
