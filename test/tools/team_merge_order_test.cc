// Order independence of team merging (issue 21, item 2), on memories from real runs: three
// robots' routes through small simulated worlds replayed as `tsc team --offline` replays them
// (tools/team_replay.h), then their memories exchanged in every order of the round-based
// exchange and in random pairwise schedules (a robot merges a peer again after the peer
// changed) until nothing changes. Every schedule must end with every robot holding the same
// places (ids and sources) and the same map. Seeds are fixed and printed. 2 worlds x (6 orders
// + 24 seeded schedules) = 60 orders x seeds.
//
// The property FAILS on today's core/merge in one part, which ids are one place: those tests
// are skipped with the finding as their message (kKnownFailure below) unless
// TSCD_RUN_KNOWN_FAILURES=1. What does hold is checked always: the exchange settles in every
// schedule, every robot knows every learned place id, and the ids and the map are a function
// of the groups (every robot of a schedule ends with the same memory and map, every place
// carries the smallest id of its group, the same groups end with the same ids and map).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <optional>
#include <ostream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "settings/settings.h"
#include "test/support/known_failure.h"
#include "tools/team_replay.h"

namespace tsc {
namespace {

struct TeamWorld {
  const char* kind;
  int seed;
};
// Small worlds at 160x120 with the pan-sweep camera (config/sweep.ini), which recognises
// rooms across robots, so merges absorb places.
void PrintTo(const TeamWorld& w, std::ostream* os) { *os << w.kind << " " << w.seed; }
constexpr TeamWorld kWorlds[] = {{"office", 5}, {"corridors", 6}};
constexpr int kRandomSchedules = 24;  // per world, beside the 6 orders of the rounds
constexpr int kRandomMerges = 12;     // pairwise merges before the settling rounds

// What a robot's final memory says: each place's id with its sources, and each map edge.
struct Outcome {
  std::set<std::pair<PlaceId, std::set<PlaceId>>> places;
  std::set<std::tuple<PlaceId, PlaceId, int64_t>> edges;
  bool operator==(const Outcome&) const = default;
};

Outcome OutcomeOf(const ReplayedRobot& r) {
  Outcome o;
  for (const LearnedPlace& p : r.memory.places()) {
    o.places.emplace(p.id, std::set<PlaceId>(p.sources.begin(), p.sources.end()));
  }
  for (const auto& [ends, e] : r.map.edges()) o.edges.emplace(e.a, e.b, e.traversals);
  return o;
}

std::string Describe(const Outcome& o) {
  std::ostringstream s;
  s << o.places.size() << " places:";
  for (const auto& [id, sources] : o.places) {
    s << " " << id.ToString();
    if (!sources.empty()) {
      s << "{";
      for (const PlaceId& p : sources) s << p.ToString() << (p == *sources.rbegin() ? "" : ",");
      s << "}";
    }
  }
  s << "; " << o.edges.size() << " edges:";
  for (const auto& [a, b, n] : o.edges) s << " " << a.ToString() << "-" << b.ToString() << "x" << n;
  return s.str();
}

std::vector<ReplayedRobot> ReplayTeam(const TeamWorld& w, int* portion_bytes) {
  std::vector<ReplayedRobot> team;
  for (int route = 0; route < 3; ++route) {
    const Settings settings =
        LoadSettings(std::string(TSCD_SOURCE_DIR) + "/config/sweep.ini",
                     {"camera.source=sim", "sim.world=" + std::string(w.kind),
                      "sim.world_seed=" + std::to_string(w.seed), "sim.team_size=3",
                      "sim.route=" + std::to_string(route), "sim.width=160", "sim.height=120"});
    *portion_bytes = settings.daemon.bus.portion_bytes;
    team.push_back(ReplayRoute(settings, static_cast<uint32_t>(route + 1)));
  }
  return team;
}

// The groups of a memory without their representatives' ids: which ids are one place.
std::set<std::set<PlaceId>> Groups(const PlaceMemory& m) {
  std::set<std::set<PlaceId>> out;
  for (const LearnedPlace& p : m.places()) {
    std::set<PlaceId> g(p.sources.begin(), p.sources.end());
    g.insert(p.id);
    out.insert(g);
  }
  return out;
}

std::string DescribeGroups(const std::set<std::set<PlaceId>>& groups) {
  std::string s;
  for (const auto& g : groups) {
    s += " {";
    for (const PlaceId& p : g) s += p.ToString() + (p == *g.rbegin() ? "" : ",");
    s += "}";
  }
  return s;
}

// The property does not hold yet (issue 21, item 2; docs/results.md, "The order matters"):
// the two tests that compare groups across orders fail on core/merge, so they are skipped unless
// TSCD_RUN_KNOWN_FAILURES=1 is set; set it to see the figures, and remove the skip once
// core/merge makes them pass.
constexpr const char* kKnownFailure =
    "KNOWN FAILURE (issue 21, item 2), set TSCD_RUN_KNOWN_FAILURES=1 to run: which ids are "
    "one place depends on the merge order. MergeMemories is commutative for two memories but "
    "not associative for three. On corridors 6 (routes replayed at 160x120, pan sweep) robot 1 "
    "merging 2 then 3 keeps 3:1 apart from {1:1,2:1}; merging 3 then 2 keeps 2:1 apart from "
    "{1:1,3:1} and joins {1:2,2:3,3:2}; robot 2 merging 3 then 1 joins {1:1,2:1,3:1}. Office 5 "
    "ends in 12 distinct groupings over 30 schedules, corridors 6 in 4. (The ids and the map "
    "given the groups no longer depend on the order: TheSameGroupsEndWithTheSameIdsAndMap.)";

// The minimised regression input: corridors 6, the three robots' memories after their routes,
// merged into one robot's memory in each order of the two peers. One merge order must not
// decide which ids are one place.
TEST(TeamMergeOrderRegression, ThreeMemoriesMergedInAnyOrderGroupTheSameIds) {
  if (!testing_support::KnownFailuresRequested()) GTEST_SKIP() << kKnownFailure;
  const TeamWorld w = {"corridors", 6};
  int portion_bytes = 0;
  const std::vector<ReplayedRobot> routes = ReplayTeam(w, &portion_bytes);
  std::optional<std::set<std::set<PlaceId>>> reference;
  std::string reference_name;
  std::vector<uint32_t> order = {1, 2, 3};
  do {
    std::vector<ReplayedRobot> team = routes;
    ReplayedRobot& a = team[order[0] - 1];
    MergePeer(a, team[order[1] - 1], portion_bytes);
    MergePeer(a, team[order[2] - 1], portion_bytes);
    const std::string name = std::to_string(order[0]) + " merges " + std::to_string(order[1]) +
                             " then " + std::to_string(order[2]);
    const std::set<std::set<PlaceId>> groups = Groups(a.memory);
    std::printf("corridors 6, %s:%s\n", name.c_str(), DescribeGroups(groups).c_str());
    if (!reference) {
      reference = groups;
      reference_name = name;
      continue;
    }
    EXPECT_TRUE(groups == *reference) << name << ":" << DescribeGroups(groups) << "\n"
                                      << reference_name << ":" << DescribeGroups(*reference);
  } while (std::next_permutation(order.begin(), order.end()));
}

// The team after one schedule of the exchange, and the schedule's name.
struct ScheduleEnd {
  std::string name;
  bool settled = false;
  std::vector<ReplayedRobot> team;
};

// Every order of the round-based exchange (`tsc team --offline --order`), then
// kRandomSchedules pairwise schedules (seeds 1000 * world seed + k, printed): a robot merges a
// peer, which may have changed since it last merged it; then rounds in a random order settle
// the exchange.
std::vector<ScheduleEnd> RunSchedulesOnce(const TeamWorld& w) {
  int portion_bytes = 0;
  const std::vector<ReplayedRobot> routes = ReplayTeam(w, &portion_bytes);
  for (const ReplayedRobot& r : routes) {
    std::printf("%s %d robot %u: %zu places, %zu edges after its route\n", w.kind, w.seed, r.id,
                r.memory.places().size(), r.map.edges().size());
  }
  std::vector<ScheduleEnd> out;
  std::vector<uint32_t> order = {1, 2, 3};
  do {
    ScheduleEnd end{"order " + std::to_string(order[0]) + "," + std::to_string(order[1]) + "," +
                        std::to_string(order[2]),
                    false, routes};
    end.settled = ExchangeMemories(end.team, order, portion_bytes);
    out.push_back(std::move(end));
  } while (std::next_permutation(order.begin(), order.end()));
  for (int k = 0; k < kRandomSchedules; ++k) {
    const uint32_t seed = static_cast<uint32_t>(1000 * w.seed + k);
    std::mt19937 rng(seed);
    ScheduleEnd end{"schedule seed " + std::to_string(seed), false, routes};
    std::uniform_int_distribution<size_t> pick(0, 2), other(1, 2);
    for (int m = 0; m < kRandomMerges; ++m) {
      const size_t r = pick(rng), s = (r + other(rng)) % 3;
      MergePeer(end.team[r], end.team[s], portion_bytes);
    }
    std::vector<uint32_t> settle = {1, 2, 3};
    std::shuffle(settle.begin(), settle.end(), rng);
    end.settled = ExchangeMemories(end.team, settle, portion_bytes);
    out.push_back(std::move(end));
  }
  std::printf("%s %d: %zu schedules (6 orders, %d seeded schedules, seeds %d..%d)\n", w.kind,
              w.seed, out.size(), kRandomSchedules, 1000 * w.seed,
              1000 * w.seed + kRandomSchedules - 1);
  return out;
}

// The schedules of a world, run once for the tests below (each run replays the routes and
// merges 30 times).
const std::vector<ScheduleEnd>& RunSchedules(const TeamWorld& w) {
  static std::map<std::pair<std::string, int>, std::vector<ScheduleEnd>> done;
  const std::pair<std::string, int> key(w.kind, w.seed);
  auto it = done.find(key);
  if (it == done.end()) it = done.emplace(key, RunSchedulesOnce(w)).first;
  return it->second;
}

class TeamMergeOrderTest : public ::testing::TestWithParam<TeamWorld> {};

// What holds today (and `tsc team`'s consistency check relies on): whatever the order, the
// exchange settles, every robot then knows every place id learned by anyone (as a place or a
// source), and so the same ids as in every other schedule.
TEST_P(TeamMergeOrderTest, EveryOrderAndScheduleSettlesKnowingEveryPlace) {
  std::set<PlaceId> learned;
  int schedules = 0;
  for (const ScheduleEnd& end : RunSchedules(GetParam())) {
    ++schedules;
    EXPECT_TRUE(end.settled) << end.name << " does not settle within 20 rounds";
    for (const ReplayedRobot& r : end.team) {
      std::set<PlaceId> known;
      for (const auto& [id, sources] : OutcomeOf(r).places) {
        known.insert(id);
        known.insert(sources.begin(), sources.end());
      }
      if (learned.empty()) {
        for (const ReplayedRobot& q : end.team) {
          for (const auto& [place, members] : q.assignments) learned.insert(place);
        }
        ASSERT_FALSE(learned.empty());
      }
      EXPECT_TRUE(known == learned) << end.name << ", robot " << r.id << " knows " << known.size()
                                    << " of the " << learned.size() << " places learned";
    }
  }
  EXPECT_EQ(schedules, 6 + kRandomSchedules);
}

// What holds since canonical ids and largest traversal counts (docs/decisions.md, "Merging"):
// the place ids and the map are a function of which ids are one place. In every schedule the
// three robots end with the same places (ids and sources) and the same map, every place
// carries the smallest id of its group, and schedules that end with the same groups end with
// the same memory and map. (Which ids are one place still depends on the order: the test
// below.)
TEST_P(TeamMergeOrderTest, TheSameGroupsEndWithTheSameIdsAndMap) {
  std::map<std::set<std::set<PlaceId>>, std::pair<Outcome, std::string>> by_groups;
  size_t robots = 0;
  for (const ScheduleEnd& end : RunSchedules(GetParam())) {
    ASSERT_TRUE(end.settled) << end.name;
    for (const ReplayedRobot& r : end.team) {
      ++robots;
      const std::string where = end.name + "/robot " + std::to_string(r.id);
      for (const LearnedPlace& p : r.memory.places()) {
        EXPECT_TRUE(p.sources.empty() || p.id < p.sources.front())
            << where << ": place " << p.id.ToString() << " holds the smaller id "
            << p.sources.front().ToString();
      }
      const Outcome o = OutcomeOf(r);
      const auto [it, first] = by_groups.try_emplace(Groups(r.memory), o, where);
      EXPECT_TRUE(it->second.first == o)
          << where << ": " << Describe(o) << "\n"
          << it->second.second << ", the same groups: " << Describe(it->second.first);
    }
    for (const ReplayedRobot& r : end.team) {
      EXPECT_TRUE(OutcomeOf(r) == OutcomeOf(end.team.front()))
          << end.name << ": robot " << r.id << " holds " << Describe(OutcomeOf(r)) << "\nrobot "
          << end.team.front().id << " holds " << Describe(OutcomeOf(end.team.front()));
    }
  }
  std::printf("%s %d: %zu robot memories, %zu distinct groupings\n", GetParam().kind,
              GetParam().seed, robots, by_groups.size());
  EXPECT_EQ(robots, 3u * (6 + kRandomSchedules));
}

TEST_P(TeamMergeOrderTest, EveryOrderAndScheduleEndsWithTheSamePlacesAndMap) {
  if (!testing_support::KnownFailuresRequested()) GTEST_SKIP() << kKnownFailure;
  const TeamWorld w = GetParam();
  // Each distinct final memory, with the schedules and robots that ended with it.
  std::vector<std::pair<Outcome, std::vector<std::string>>> outcomes;
  for (const ScheduleEnd& end : RunSchedules(w)) {
    ASSERT_TRUE(end.settled) << end.name;
    for (const ReplayedRobot& r : end.team) {
      const Outcome o = OutcomeOf(r);
      auto it = std::find_if(outcomes.begin(), outcomes.end(),
                             [&](const auto& seen) { return seen.first == o; });
      if (it == outcomes.end()) it = outcomes.insert(outcomes.end(), {o, {}});
      it->second.push_back(end.name + "/robot " + std::to_string(r.id));
    }
  }
  std::printf("%s %d: %zu distinct final memories\n", w.kind, w.seed, outcomes.size());
  for (const auto& [o, where] : outcomes) {
    std::printf("  %s\n    in %zu robot memories:", Describe(o).c_str(), where.size());
    for (size_t i = 0; i < where.size() && i < 8; ++i) std::printf(" %s;", where[i].c_str());
    std::printf("%s\n", where.size() > 8 ? " ..." : "");
  }
  EXPECT_EQ(outcomes.size(), 1u) << "schedules end with different places or maps (above)";
  // The robots recognise each other's rooms: some place absorbed a peer's.
  ASSERT_FALSE(outcomes.empty());
  size_t absorbed = 0;
  for (const auto& [id, sources] : outcomes.front().first.places) absorbed += sources.size();
  EXPECT_GT(absorbed, 0u);
}

INSTANTIATE_TEST_SUITE_P(Worlds, TeamMergeOrderTest, ::testing::ValuesIn(kWorlds),
                         [](const ::testing::TestParamInfo<TeamWorld>& world) {
                           return std::string(world.param.kind) + std::to_string(world.param.seed);
                         });

}  // namespace
}  // namespace tsc
