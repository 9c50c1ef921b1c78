// `tsc team --offline` end to end (issue 21, item 3): three robots' routes through a small
// simulated world replayed in-process by the real binary, their memories exchanged in a fixed
// or given order, scored as the live run scores. Two runs with the same arguments write the
// same summary.json; the figures are within their ranges and agree with each other.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>
#include <vector>

#include "test/support/json_number.h"
#include "test/support/temp_dir.h"
#include "test/support/tsc_command.h"

namespace tsc {
namespace {

using testing_support::JsonNumberAt;
using testing_support::ReadFile;

// The text of the JSON array after "key": ("[1,2,3]"); "" when absent.
std::string ArrayAt(const std::string& json, const std::string& key) {
  const size_t at = json.find("\"" + key + "\":[");
  if (at == std::string::npos) return "";
  const size_t open = at + key.size() + 3;
  return json.substr(open, json.find(']', open) - open + 1);
}

// The numbers of `places_per_label`, one per final memory (empty when absent).
std::vector<double> PlacesPerLabel(const std::string& json) {
  const std::string ppl = ArrayAt(json, "places_per_label");
  std::vector<double> out;
  for (size_t p = 1; p < ppl.size();) {
    out.push_back(std::stod(ppl.substr(p)));
    p = ppl.find(',', p);
    if (p == std::string::npos) break;
    ++p;
  }
  return out;
}

class TeamOfflineTest : public ::testing::Test {
 protected:
  // World 5 (office), three robots, frames of 160x120 (the bubble surface resamples to its own
  // patch size), the pan-sweep camera of config/sweep.ini.
  testing_support::TscOutcome Run(const std::string& out, const std::string& extra = "") {
    const std::string args =
        "team --offline --robots 3 --world 5 --config " +
        testing_support::Quote(std::string(TSCD_SOURCE_DIR) + "/config/sweep.ini") +
        " --set sim.width=160 --set sim.height=120 --out " +
        testing_support::Quote((temp_.path() / out).string()) + " " + extra;
    return testing_support::RunTsc(temp_.path(), args);
  }
  std::string Summary(const std::string& out) {
    return ReadFile(temp_.path() / out / "summary.json");
  }
  // The swept bar worlds (seeds picked before measuring: 201 office, 202 corridors, 203
  // outdoor), three robots at 160x120 with config/sweep.ini, merged in the default order;
  // `extra` adds to the command. Returns each world's summary.json, named as "office-201".
  std::vector<std::pair<std::string, std::string>> RunBarWorlds(const std::string& extra) {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& [kind, seed] : std::vector<std::pair<std::string, int>>{
             {"office", 201}, {"corridors", 202}, {"outdoor", 203}}) {
      const std::string name = kind + "-" + std::to_string(seed);
      const auto run = testing_support::RunTsc(
          temp_.path(),
          "team --offline --robots 3 --world " + std::to_string(seed) + " --kind " + kind +
              " --config " +
              testing_support::Quote(std::string(TSCD_SOURCE_DIR) + "/config/sweep.ini") +
              " --set sim.width=160 --set sim.height=120 --out " +
              testing_support::Quote((temp_.path() / name).string()) + " " + extra);
      EXPECT_EQ(run.code, 0) << name << ": " << run.out << run.err;
      out.emplace_back(name, Summary(name));
      std::cout << name << ": " << out.back().second;
    }
    return out;
  }
  testing_support::TempDir temp_{"tscd_team_offline_test"};
};

TEST_F(TeamOfflineTest, TwoRunsWriteTheSameSummaryAndTheFiguresAreSane) {
  const auto first = Run("a");
  ASSERT_EQ(first.code, 0) << first.out << first.err;
  const auto second = Run("b");
  ASSERT_EQ(second.code, 0) << second.out << second.err;
  const std::string json = Summary("a");
  std::cout << first.out << json;
  ASSERT_FALSE(json.empty());
  EXPECT_EQ(Summary("b"), json);

  // The team map: a picture of the final memory over the floor plan (item 4).
  const cv::Mat map = cv::imread((temp_.path() / "a" / "team_map.png").string());
  EXPECT_GT(map.cols, 500);
  EXPECT_GT(map.rows, 300);
  EXPECT_NE(json.find("\"mode\":\"offline\""), std::string::npos);
  EXPECT_EQ(ArrayAt(json, "order"), "[1,2,3]");
  EXPECT_NE(json.find("\"settled\":true"), std::string::npos);
  // Every robot walked its route and learned places; after the exchange every memory holds
  // places of the others.
  size_t at = 0;
  for (int r = 1; r <= 3; ++r) {
    at = json.find("{\"robot\":" + std::to_string(r), at);
    ASSERT_NE(at, std::string::npos) << "robot " << r;
    EXPECT_GT(JsonNumberAt(json, "frames", at), 0) << "robot " << r;
    EXPECT_GT(JsonNumberAt(json, "own_places", at), 0) << "robot " << r;
    EXPECT_GT(JsonNumberAt(json, "places_from_peers", at) +
                  JsonNumberAt(json, "peer_places_absorbed", at),
              0)
        << "robot " << r;
  }
  // The exchange settled, so every robot knows the same places.
  EXPECT_NE(json.find("\"consistent\":true"), std::string::npos);
  const std::string known = ArrayAt(json, "known_places");
  const size_t comma = known.find(',');
  ASSERT_NE(comma, std::string::npos) << known;
  const std::string k = known.substr(1, comma - 1);
  EXPECT_EQ(known, "[" + k + "," + k + "," + k + "]");
  // Scores within their ranges, and their parts agree.
  const double merges = JsonNumberAt(json, "merges"), correct = JsonNumberAt(json, "correct");
  EXPECT_GT(merges, 0);  // three tours of one office share rooms
  EXPECT_LE(correct, merges);
  EXPECT_DOUBLE_EQ(JsonNumberAt(json, "precision", json.find("\"merge\":")), correct / merges);
  const double with = JsonNumberAt(json, "places_with_namesake");
  const double merged = JsonNumberAt(json, "places_merged_with_namesake");
  EXPECT_GT(with, 0);
  EXPECT_LE(merged, with);
  EXPECT_DOUBLE_EQ(JsonNumberAt(json, "place_recall"), merged / with);
  const std::vector<double> ppl = PlacesPerLabel(json);
  ASSERT_FALSE(ppl.empty());
  for (double v : ppl) {
    EXPECT_GE(v, 1.0) << ArrayAt(json, "places_per_label");  // a labelled place per room at least
  }
}

// Every final memory holds at most `most` places per label.
void ExpectPlacesPerLabelAtMost(const std::string& json, double most) {
  const std::vector<double> ppl = PlacesPerLabel(json);
  ASSERT_FALSE(ppl.empty()) << json;
  for (double v : ppl) EXPECT_LE(v, most) << ArrayAt(json, "places_per_label");
}

// Issue 21's bars on the deterministic evaluation, the routes driven first and then merged:
// merge place recall >= 0.8 at precision >= 0.95, places per label <= 1.5 in every final
// memory, memories consistent.
TEST_F(TeamOfflineTest, MergeBarsWithPanSweepsOnThreeWorlds) {
  for (const auto& [name, json] : RunBarWorlds("")) {
    SCOPED_TRACE(name);
    EXPECT_GE(JsonNumberAt(json, "place_recall"), 0.8);
    EXPECT_GE(JsonNumberAt(json, "precision", json.find("\"merge\":")), 0.95);
    EXPECT_NE(json.find("\"consistent\":true"), std::string::npos);
    ExpectPlacesPerLabelAtMost(json, 1.5);
  }
}

// The same worlds exchanging while they drive, as live robots do (docs/open-decisions.md 12):
// a robot recognises a room its teammate learned first, so few copies are left for the merge
// to join and place recall counts only those (null on corridors 202, where none is left).
// What a user of a live team sees is held to the bars instead: at most 1.5 places per label,
// merges and the pipelines' recognitions of peer places at precision >= 0.95, consistent.
TEST_F(TeamOfflineTest, DrivingTeamsOnThePanSweepBarWorldsKeepOnePlaceARoom) {
  for (const auto& [name, json] : RunBarWorlds("--exchange-every 50")) {
    SCOPED_TRACE(name);
    EXPECT_GE(JsonNumberAt(json, "precision", json.find("\"merge\":")), 0.95);
    const double peer = JsonNumberAt(json, "peer_recognitions");
    EXPECT_GT(peer, 0);  // the robots met their teammates' places while driving
    EXPECT_GE(JsonNumberAt(json, "peer_recognitions_correct") / peer, 0.95);
    EXPECT_NE(json.find("\"settled\":true"), std::string::npos);
    EXPECT_NE(json.find("\"consistent\":true"), std::string::npos);
    ExpectPlacesPerLabelAtMost(json, 1.5);
  }
}

// Exchanging while driving (--exchange-every), as live robots do: the pipelines go on with the
// merges they adopt, so they meet places their teammates learned first, which robots that
// exchange only after their routes never do. Deterministic like the rest of the evaluation.
TEST_F(TeamOfflineTest, ExchangingWhileDrivingIsDeterministicAndThePipelinesMeetPeerPlaces) {
  const auto after = Run("after");
  ASSERT_EQ(after.code, 0) << after.out << after.err;
  EXPECT_EQ(JsonNumberAt(Summary("after"), "peer_recognitions"), 0);
  EXPECT_NE(Summary("after").find("\"exchange_every\":0"), std::string::npos);

  const auto first = Run("driving-a", "--exchange-every 50");
  ASSERT_EQ(first.code, 0) << first.out << first.err;
  const auto second = Run("driving-b", "--exchange-every 50");
  ASSERT_EQ(second.code, 0) << second.out << second.err;
  const std::string json = Summary("driving-a");
  std::cout << first.out << json;
  EXPECT_EQ(Summary("driving-b"), json);
  EXPECT_NE(json.find("\"exchange_every\":50"), std::string::npos);
  EXPECT_GT(JsonNumberAt(json, "peer_recognitions"), 0);
  // Each wrong one is named (place, its label, the frames' label).
  size_t wrong = 0;
  for (size_t at = json.find("\"frames_label\":"); at != std::string::npos;
       at = json.find("\"frames_label\":", at + 1)) {
    ++wrong;
  }
  EXPECT_EQ(static_cast<double>(wrong), JsonNumberAt(json, "peer_recognitions") -
                                            JsonNumberAt(json, "peer_recognitions_correct"));
  EXPECT_NE(json.find("\"settled\":true"), std::string::npos);
  EXPECT_NE(json.find("\"consistent\":true"), std::string::npos);

  for (const std::string bad : {"0", "-3"}) {
    const auto run = Run("bad", "--exchange-every " + bad);
    EXPECT_EQ(run.code, 2) << bad << ": " << run.err;
  }
}

TEST_F(TeamOfflineTest, AGivenOrderIsUsedAndWritten) {
  const auto run = Run("order", "--order 3,1,2");
  ASSERT_EQ(run.code, 0) << run.out << run.err;
  const std::string json = Summary("order");
  EXPECT_EQ(ArrayAt(json, "order"), "[3,1,2]");
  EXPECT_NE(json.find("\"consistent\":true"), std::string::npos);
}

TEST_F(TeamOfflineTest, AnOrderThatIsNotAPermutationIsAUsageError) {
  for (const std::string order : {"1,2", "1,2,2", "1,2,4", "a,b,c"}) {
    const auto run = Run("bad", "--order " + order);
    EXPECT_EQ(run.code, 2) << order << ": " << run.err;
    EXPECT_NE(run.err.find("--order"), std::string::npos) << run.err;
  }
  // --order without --offline.
  const auto live =
      testing_support::RunTsc(temp_.path(), "team --robots 3 --world 5 --order 1,2,3 --out " +
                                                testing_support::Quote(temp_.path().string()));
  EXPECT_EQ(live.code, 2) << live.err;
}

}  // namespace
}  // namespace tsc
