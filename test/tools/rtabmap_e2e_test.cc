// End to end on real frames: ../shared/data/rtabmap-loop (84 frames of an office loop; frames
// 41-84 revisit 1-40). The shipped defaults (τ_p follows the keyframes' spacing), scored with the
// rules of DESIGN §7.1b.

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "drivers/dataset/dataset.h"
#include "store/store.h"
#include "test/support/default_profile.h"
#include "test/support/temp_dir.h"
#include "tools/scoring.h"

namespace tsc {
namespace {

TEST(RtabmapLoop, LearnsPlacesAndRecognisesRevisitsWithoutMistakes) {
  const std::filesystem::path folder = std::filesystem::path(TSCD_DATA_DIR) / "rtabmap-loop";
  if (!std::filesystem::exists(folder)) GTEST_SKIP() << folder << " is not present";
  const Dataset dataset = Dataset::Open(folder);
  ASSERT_EQ(dataset.size(), 84);
  ASSERT_FALSE(dataset.revisits().empty());

  const testing_support::TempDir temp("tscd_e2e_test");
  const std::filesystem::path db = temp.path() / "rtabmap.db";
  const PipelineOptions options = testing_support::DefaultProfile(dataset);
  Store store = Store::Open(db);
  StoredState state = store.Load(options.robot, options.memory);
  Pipeline pipeline(dataset.camera(), options, std::move(state.memory), std::move(state.map),
                    state.pipeline);

  std::map<DetectedPlaceIndex, std::vector<int>> frames_of;
  std::vector<Assignment> assignments;
  auto consume = [&](const FrameResult& r) {
    store.Commit(r, pipeline);
    for (const DetectedPlace& d : r.closed_places) {
      for (BaseIndex k : d.members) frames_of[d.index].push_back(static_cast<int>(k));
    }
    for (const PlaceEvent& e : r.events) {
      const bool recognized = e.kind == EventKind::kRecognized && !e.partial;
      if (recognized || e.kind == EventKind::kLearned) {
        assignments.push_back({frames_of.at(e.detected_place), *e.place, recognized});
      }
    }
  };
  for (int i = 0; i < dataset.size(); ++i) {
    consume(pipeline.Process(dataset.Load(i)));  // one view: the loop has no sweep
  }
  consume(pipeline.Finish());

  GroundTruth truth;
  truth.revisits = dataset.revisits();
  const RecognitionScore score = ScoreRecognition(truth, assignments);
  EXPECT_GE(pipeline.memory().places().size(), 3u);
  EXPECT_GE(score.correct, 1);
  EXPECT_EQ(score.recognitions, score.correct) << "wrong recognitions";
  EXPECT_GE(pipeline.map().edges().size(), 2u);
  RecordProperty("learned_places", static_cast<int>(pipeline.memory().places().size()));
  RecordProperty("recognitions", score.recognitions);
  RecordProperty("should_be_recognized", score.should_be_recognized);

  // The store holds the same memory after reopening.
  Store reopened = Store::Open(db);
  const StoredState loaded = reopened.Load(options.robot, options.memory);
  EXPECT_EQ(loaded.memory.places().size(), pipeline.memory().places().size());
  EXPECT_EQ(loaded.map.edges().size(), pipeline.map().edges().size());
}

}  // namespace
}  // namespace tsc
