#include "core/pipeline/copy_evidence.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

namespace tsc {
namespace {

const PlaceId kA{1, 3}, kB{2, 7}, kC{1, 9};

// A pair is one place once `revisits` detected places showed it; one pass through a room
// (consecutive detected places) counts once, and either order of the pair is the same pair.
TEST(CopyEvidence, APairIsOnePlaceAfterTheRevisitsAskedForNotConsecutive) {
  CopyEvidence dut(2);
  EXPECT_FALSE(dut.Witness(kA, kB, 10));
  EXPECT_FALSE(dut.Witness(kB, kA, 11)) << "the same pass";
  EXPECT_FALSE(dut.Witness(kA, kC, 12)) << "another pair";
  EXPECT_TRUE(dut.Witness(kB, kA, 14));
  EXPECT_EQ(dut.pairs(), 1u) << "spent evidence is forgotten";
  EXPECT_FALSE(dut.Witness(kA, kB, 20)) << "and starts again";
  EXPECT_TRUE(dut.Witness(kA, kC, 30));
}

TEST(CopyEvidence, OneRevisitSufficesWhenAskedAndNoneFoldsWhenOff) {
  CopyEvidence one(1), off(0);
  EXPECT_TRUE(one.Witness(kA, kB, 1));
  EXPECT_FALSE(one.Witness(kA, kA, 5)) << "a place is no copy of itself";
  for (DetectedPlaceIndex m = 1; m < 100; m += 2) EXPECT_FALSE(off.Witness(kA, kB, m));
  EXPECT_EQ(off.pairs(), 0u);
}

// Memory stays bounded whatever the stream shows: beyond kMaxPairs pairs the evidence is
// forgotten.
TEST(CopyEvidence, RemembersBoundedPairs) {
  CopyEvidence dut(3);
  for (uint32_t i = 0; i < 3 * CopyEvidence::kMaxPairs; ++i) {
    EXPECT_FALSE(dut.Witness(PlaceId{1, i}, PlaceId{2, i}, 2 * static_cast<DetectedPlaceIndex>(i)));
    EXPECT_LE(dut.pairs(), CopyEvidence::kMaxPairs);
  }
}

// The evidence a run gathered continues in the next (a restart between laps): what Witnesses()
// gives back, a new CopyEvidence takes up where it was, and it says when it changed.
TEST(CopyEvidence, ContinuesFromTheEvidenceKept) {
  CopyEvidence before(3);
  EXPECT_FALSE(before.Witness(kA, kB, 10));
  const uint64_t changes = before.changes();
  EXPECT_FALSE(before.Witness(kB, kA, 11)) << "the same pass";
  EXPECT_EQ(before.changes(), changes) << "the same pass changes nothing";
  EXPECT_FALSE(before.Witness(kA, kB, 20));
  EXPECT_GT(before.changes(), changes);
  const std::vector<CopyWitness> kept = before.Witnesses();
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept.front(), (CopyWitness{kA, kB, 2, 20}));
  CopyEvidence after(3, kept);
  EXPECT_EQ(after.Witnesses(), kept);
  EXPECT_FALSE(after.Witness(kA, kB, 21)) << "still the pass of 20";
  EXPECT_TRUE(after.Witness(kA, kB, 30)) << "the third revisit, across the restart";
}

TEST(CopyEvidence, RefusesEvidenceThatCannotBe) {
  const std::vector<CopyWitness> reversed{{kB, kA, 1, 4}}, never{{kA, kB, 0, 4}};
  EXPECT_THROW(CopyEvidence(3, reversed), std::invalid_argument);
  EXPECT_THROW(CopyEvidence(3, never), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
