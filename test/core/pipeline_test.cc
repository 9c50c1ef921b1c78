#include "core/pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>

#include "core/memory/descriptor_space_mismatch.h"
#include "core/merge/merge.h"
#include "core/merge/merge_maps.h"
#include "test/support/random_memory.h"

namespace tsc {
namespace {

constexpr int kDim = 700;

// Descriptors on the normalised scale: non-negative, summing to 1.
Eigen::VectorXf Normalised(Eigen::VectorXf v) { return v / v.sum(); }

class PipelineTest : public ::testing::Test {
 protected:
  PipelineTest()
      : dut_(CameraIntrinsics::FromHorizontalFov(64, 48, 60), Options(),
             PlaceMemory(1, Options().memory), TopologicalMap()) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int c = 0; c < 3; ++c) {
      Eigen::VectorXf v(kDim);
      for (int i = 0; i < kDim; ++i) v[i] = u(rng_);
      centres_.push_back(Normalised(v));
    }
  }
  static PipelineOptions Options() {
    PipelineOptions o;
    o.detector = DetectorOptions{2, 2, 3};
    o.memory.view_basis = nullptr;  // the descriptors here are synthetic, of kDim dimensions
    return o;
  }
  // `n` frames of place `c` (small noise), then a transition of 3 incoherent frames.
  void Visit(int c, int n) { Visit(dut_, c, n); }
  void Visit(Pipeline& pipeline, int c, int n) {
    std::normal_distribution<float> noise(0.0f, 0.02f);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXf v = centres_[c];
      for (int i = 0; i < kDim; ++i) v[i] = std::max(0.0f, v[i] * (1.0f + noise(rng_)));
      Collect(pipeline.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05}));
    }
    std::uniform_int_distribution<int> pick(0, kDim - 1);
    for (int j = 0; j < 3; ++j) {
      Eigen::VectorXf v = Eigen::VectorXf::Zero(kDim);
      for (int s = 0; s < 5; ++s) v[pick(rng_)] = 1.0f;  // sparse: far from everything
      Collect(pipeline.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05}));
    }
  }
  void Collect(const FrameResult& r) {
    for (const PlaceEvent& e : r.events) events_.push_back(e);
  }
  int Count(EventKind k, bool partial = false) const {
    int n = 0;
    for (const auto& e : events_) n += e.kind == k && e.partial == partial;
    return n;
  }

  std::mt19937 rng_{11};
  std::vector<Eigen::VectorXf> centres_;
  std::vector<PlaceEvent> events_;
  Pipeline dut_;
};

// A pan sweep's base point is judged coherent or not on its coherence descriptor (the
// sweep's first view), not on the whole sweep's.
TEST_F(PipelineTest, IncoherencyIsJudgedOnTheCoherenceDescriptorWhenGiven) {
  const Descriptor sweep(centres_[0]);
  const Descriptor ahead(centres_[1]), elsewhere(centres_[2]);
  const IntensityStats lit{0.5, 0.05};
  dut_.ProcessDescriptor(sweep, lit, &ahead);
  // The same sweep, but the view ahead changed completely: incoherent.
  EXPECT_EQ(dut_.ProcessDescriptor(sweep, lit, &elsewhere).base.status, BaseStatus::kIncoherent);
  // Another sweep, the same view ahead: coherent. The stored descriptor is the sweep's.
  const FrameResult r = dut_.ProcessDescriptor(Descriptor(centres_[1]), lit, &elsewhere);
  EXPECT_EQ(r.base.status, BaseStatus::kGood);
  EXPECT_EQ(r.base.descriptor, centres_[1]);
  // A coherence descriptor of another dimension is refused.
  const Descriptor short_one(Eigen::VectorXf::Constant(10, 0.1f));
  EXPECT_THROW(dut_.ProcessDescriptor(sweep, lit, &short_one), std::invalid_argument);
}

// The views of a pan sweep of `views` views over a scene of random colour blocks (seeded).
std::vector<Observation> SweepViews(int views, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  const PanSweep sweep(views, 360.0);
  std::vector<Observation> out;
  for (int j = 0; j < views; ++j) {
    Observation o;
    o.bgr = cv::Mat(48, 64, CV_8UC3);
    for (int by = 0; by < 48; by += 8) {
      for (int bx = 0; bx < 64; bx += 8) {
        const cv::Vec3b colour(static_cast<uint8_t>(byte(rng)), static_cast<uint8_t>(byte(rng)),
                               static_cast<uint8_t>(byte(rng)));
        o.bgr(cv::Rect(bx, by, 8, 8)).setTo(colour);
      }
    }
    o.pan_tilt = sweep.View(j);
    out.push_back(std::move(o));
  }
  return out;
}

// Process over a sweep is the sweep written out: every view observed into one surface, the
// descriptor of the surface after the first view alone judging coherence.
TEST_F(PipelineTest, ProcessOfASweepIsTheSweepWrittenOut) {
  BubbleSurface surface(Options().features, CameraIntrinsics::FromHorizontalFov(64, 48, 60),
                        Options().surface);
  const DescriptorComputer computer(surface.grid(), Options().descriptor);
  Pipeline reference(CameraIntrinsics::FromHorizontalFov(64, 48, 60), Options(),
                     PlaceMemory(1, Options().memory), TopologicalMap());
  // Sweeps of three scenes, some repeated, and one forward view.
  for (const uint32_t scene : {1u, 1u, 2u, 2u, 3u, 1u}) {
    const std::vector<Observation> views = SweepViews(scene == 3 ? 1 : 6, scene);
    surface.Observe(views[0]);
    const Descriptor first = computer.Compute(surface);
    for (size_t j = 1; j < views.size(); ++j) surface.Observe(views[j]);
    const Descriptor whole = computer.Compute(surface);
    const IntensityStats intensity = IntensityStatistics(surface);
    surface.Reset();

    const BasePointView described = DescribeBasePoint(views, surface, computer);
    EXPECT_EQ(described.descriptor.values(), whole.values());
    EXPECT_EQ(described.intensity.mean, intensity.mean);
    EXPECT_EQ(described.intensity.variance, intensity.variance);
    if (views.size() == 1) {
      EXPECT_TRUE(described.coherence.empty());  // a forward view is judged on itself
    } else {
      EXPECT_EQ(described.coherence.values(), first.values());
    }

    const FrameResult got = dut_.Process(views);
    const FrameResult want =
        reference.ProcessDescriptor(whole, intensity, views.size() > 1 ? &first : nullptr);
    EXPECT_EQ(got.base.index, want.base.index);
    EXPECT_EQ(got.base.status, want.base.status) << "scene " << scene;
    EXPECT_EQ(got.base.descriptor, want.base.descriptor);
  }
  // A sweep differs from the same scene's forward view: the views do reach the descriptor.
  const std::vector<Observation> sweep = SweepViews(6, 1);
  const std::vector<Observation> forward(sweep.begin(), sweep.begin() + 1);
  EXPECT_NE(DescribeBasePoint(sweep, surface, computer).descriptor.values(),
            DescribeBasePoint(forward, surface, computer).descriptor.values());
}

TEST_F(PipelineTest, ProcessRefusesNoViewsAndABadViewAndStartsTheNextBasePointClean) {
  EXPECT_THROW(dut_.Process({}), std::invalid_argument);
  std::vector<Observation> views = SweepViews(6, 4);
  const Eigen::VectorXf whole = dut_.Process(views).base.descriptor;
  std::vector<Observation> bad = views;
  cv::resize(bad[3].bgr, bad[3].bgr, cv::Size(32, 24));  // not the camera's size
  EXPECT_THROW(dut_.Process(bad), std::invalid_argument);
  EXPECT_EQ(dut_.state().next_base, 1);  // nothing counted
  // No view of the refused sweep stays in the surface.
  const FrameResult r = dut_.Process(views);
  EXPECT_EQ(r.base.index, 1);
  EXPECT_EQ(r.base.descriptor, whole);
}

TEST_F(PipelineTest, LearnsNewPlacesRecognisesRevisitsAndMapsTransitions) {
  Visit(0, 15);
  Visit(1, 15);
  Visit(2, 15);
  Visit(0, 15);  // revisit
  Collect(dut_.Finish());
  EXPECT_EQ(Count(EventKind::kDetected), 4);
  EXPECT_EQ(Count(EventKind::kLearned), 3);
  EXPECT_EQ(Count(EventKind::kRecognized), 1);
  EXPECT_GE(Count(EventKind::kRecognized, /*partial=*/true), 1);
  ASSERT_EQ(dut_.memory().places().size(), 3u);
  EXPECT_EQ(dut_.memory().places()[0].detected, (std::vector<DetectedPlaceIndex>{1, 4}));
  // 15 + 14: the first frame after a transition is incoherent with its predecessor.
  EXPECT_EQ(dut_.memory().places()[0].member_count, 29);
  // Edges 1-2, 2-3, 3-1; each transition region spans the 3 incoherent frames... and the
  // first good frame after them, which is incoherent with respect to its predecessor.
  EXPECT_EQ(dut_.map().edges().size(), 3u);
  const MapEdge* e = dut_.map().Find(PlaceId{1, 1}, PlaceId{1, 2});
  ASSERT_NE(e, nullptr);
  ASSERT_EQ(e->transitions.size(), 1u);
  EXPECT_EQ(e->transitions[0].first, 15);
  EXPECT_EQ(Count(EventKind::kMapped), 3);
}

// The pipeline hands the memory the map's neighbours of the previous place: a revisit whose
// cost lies just above τ_r is recognised when the robot comes from a place the map joins to it
// (route 0 1 2 1) and not when it comes from one it does not (route 0 1 2 3 1).
TEST_F(PipelineTest, ARevisitFromAMapNeighbourMayCostUpToTheNeighbourMargin) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Eigen::VectorXf fourth(kDim);
  for (int i = 0; i < kDim; ++i) fourth[i] = u(rng_);
  centres_.push_back(Normalised(fourth));
  // The decision on the route's last place, at τ_r with the given margin.
  const auto last_decision = [&](const std::vector<int>& route, double tau_r, double margin) {
    PipelineOptions options = Options();
    options.memory.tau_r = tau_r;
    options.memory.neighbour_margin = margin;
    Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 60), options,
                      PlaceMemory(1, options.memory), TopologicalMap());
    events_.clear();
    rng_.seed(5);
    for (int c : route) Visit(pipeline, c, 15);
    Collect(pipeline.Finish());
    for (auto e = events_.rbegin(); e != events_.rend(); ++e) {
      if ((e->kind == EventKind::kRecognized && !e->partial) || e->kind == EventKind::kLearned) {
        return *e;
      }
    }
    return PlaceEvent{};
  };
  for (const bool from_neighbour : {true, false}) {
    SCOPED_TRACE(from_neighbour);
    const std::vector<int> route =
        from_neighbour ? std::vector<int>{0, 1, 2, 1} : std::vector<int>{0, 1, 2, 3, 1};
    // The smallest τ_r (to 0.002) that recognises the revisit without the margin.
    double lo = 0.001, hi = 100.0;
    ASSERT_EQ(last_decision(route, hi, 0.0).kind, EventKind::kRecognized);
    while (hi - lo > 0.002) {
      const double mid = 0.5 * (lo + hi);
      (last_decision(route, mid, 0.0).kind == EventKind::kRecognized ? hi : lo) = mid;
    }
    const PlaceEvent got = last_decision(route, lo, 0.05);
    EXPECT_EQ(got.kind, from_neighbour ? EventKind::kRecognized : EventKind::kLearned);
    EXPECT_EQ(got.neighbour, from_neighbour);
    if (from_neighbour) {
      EXPECT_EQ(got.place, (PlaceId{1, 2}));
    }
  }
}

// A pass from place B to place C so gradual that it is one detected place, with a place M
// halfway between them known too: M is nearest the pass in the median, so g_N recognises it,
// but only the pass's middle names M (its ends name B and C). By default it is left without a
// place (an "ambiguous" event: nothing learned, no map edge across it, as the robot's
// whereabouts are unknown); with memory.learn_disagreed it is learned as a new place.
TEST_F(PipelineTest, APlaceItsPointsDoNotAgreeWithIsLeftWithoutAPlaceUnlessLearningIsAsked) {
  const Eigen::VectorXf b = centres_[0], c = centres_[1];
  const Eigen::VectorXf m = Normalised((b + c) / 2);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  const auto noisy = [&](const Eigen::VectorXf& centre) {
    Eigen::VectorXf v = centre;
    for (int i = 0; i < kDim; ++i) v[i] = std::max(0.0f, v[i] * (1.0f + noise(rng_)));
    return Normalised(v);
  };
  for (const bool learn : {false, true}) {
    SCOPED_TRACE(learn);
    PipelineOptions options = Options();
    options.memory.tau_r = 1000;              // the cost passes: the agreement decides
    options.memory.cost.coincide_factor = 0;  // B and C are no copies of M
    options.memory.cost.agreement_slack = 1;  // a point agrees with its nearest place only
    options.memory.cost.min_agreement = 0.6;  // the middle half of the pass names M
    options.memory.learn_disagreed = learn;
    PlaceMemory memory(1, options.memory);
    BaseIndex next = 0;
    for (const Eigen::VectorXf* centre : {&b, &c, &m}) {
      DetectedPlace d;
      d.index = static_cast<DetectedPlaceIndex>(memory.places().size() + 1);
      d.descriptors.resize(kDim, 15);
      for (int j = 0; j < 15; ++j) {
        d.descriptors.col(j) = noisy(*centre);
        d.members.push_back(next++);
      }
      memory.Learn(d);
    }
    Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 60), options, std::move(memory),
                      TopologicalMap());
    events_.clear();
    constexpr int kPass = 60;
    for (int j = 0; j < kPass; ++j) {
      const float t = static_cast<float>(j) / (kPass - 1);
      Collect(pipeline.ProcessDescriptor(Descriptor(noisy((1 - t) * b + t * c)),
                                         IntensityStats{0.5, 0.05}));
    }
    std::uniform_int_distribution<int> pick(0, kDim - 1);
    for (int j = 0; j < 3; ++j) {  // a transition
      Eigen::VectorXf v = Eigen::VectorXf::Zero(kDim);
      for (int s = 0; s < 5; ++s) v[pick(rng_)] = 1.0f;
      Collect(pipeline.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05}));
    }
    Visit(pipeline, 0, 15);  // B again
    Collect(pipeline.Finish());
    ASSERT_EQ(Count(EventKind::kDetected), 2);
    const auto pass = std::find_if(events_.begin(), events_.end(), [](const PlaceEvent& e) {
      return (e.kind == EventKind::kRecognized && !e.partial) || e.kind == EventKind::kLearned ||
             e.kind == EventKind::kAmbiguous;
    });
    ASSERT_NE(pass, events_.end());
    EXPECT_EQ(pass->detected_place, 1);
    EXPECT_LT(pass->terms.agreement, options.memory.cost.min_agreement);
    EXPECT_LE(pass->cost, options.memory.tau_r);
    if (learn) {
      EXPECT_EQ(pass->kind, EventKind::kLearned);
      EXPECT_EQ(pipeline.memory().places().size(), 4u);
      continue;
    }
    EXPECT_EQ(pass->kind, EventKind::kAmbiguous);
    EXPECT_FALSE(pass->near_miss);
    EXPECT_FALSE(pass->place.has_value());
    EXPECT_EQ(pipeline.memory().places().size(), 3u);  // nothing learned
    EXPECT_EQ(Count(EventKind::kRecognized), 1);       // B, on its revisit
    EXPECT_EQ(Count(EventKind::kMapped), 0) << "no edge across a place of unknown whereabouts";
    EXPECT_TRUE(pipeline.map().edges().empty());
  }
}

// A pass that starts in a known place B and leaves it gradually for ground never seen is
// one detected place, part of whose points vote for B. When its g_N fails τ_r by less than
// memory.near_miss_margin and N¹ = B had at least memory.near_miss_vote of the votes, it is
// a near miss: left without a place (no copy of B learned, no map edge across it). Beyond
// the margin, with fewer votes, or with a lone N¹ (a memory of one place, ratio term 1 by
// rule: no evidence B was nearer than another place) it is learned.
TEST_F(PipelineTest, ANearMissIsLeftWithoutAPlaceWhereBHadHalfTheVotes) {
  struct Case {
    const char* name;
    bool with_c;           // the memory also holds C (else B alone: a lone N¹)
    double under, margin;  // τ_r = the pass's g_N − under; memory.near_miss_margin
    double extra_vote;     // memory.near_miss_vote = the pass's V + extra_vote
    bool ambiguous;
  };
  // Runs B (and C), then a pass half in B; returns the places learned and sets *pass to the
  // pass's decision.
  const auto run = [&](bool with_c, double tau_r, double margin, double vote,
                       PlaceEvent* pass) -> size_t {
    PipelineOptions options = Options();
    options.memory.tau_r = tau_r;
    options.memory.near_miss_margin = margin;
    options.memory.near_miss_vote = vote;
    options.memory.neighbour_margin = 0;  // B is C's map neighbour: τ_r alone decides
    Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 60), options,
                      PlaceMemory(1, options.memory), TopologicalMap());
    events_.clear();
    rng_.seed(5);
    Visit(pipeline, 0, 15);              // learns B
    if (with_c) Visit(pipeline, 1, 15);  // learns C
    std::normal_distribution<float> noise(0.0f, 0.02f);
    constexpr int kIn = 30, kOut = 30;  // frames in B, then frames leaving it
    for (int j = 0; j < kIn + kOut; ++j) {
      const float t = static_cast<float>(std::max(0, j - kIn + 1)) / kOut;
      Eigen::VectorXf v = (1 - t) * centres_[0] + t * centres_[2];
      for (int i = 0; i < kDim; ++i) v[i] = std::max(0.0f, v[i] * (1.0f + noise(rng_)));
      Collect(pipeline.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05}));
    }
    Collect(pipeline.Finish());
    const auto last = std::find_if(events_.rbegin(), events_.rend(), [](const PlaceEvent& e) {
      return (e.kind == EventKind::kRecognized && !e.partial) || e.kind == EventKind::kLearned ||
             e.kind == EventKind::kAmbiguous;
    });
    if (last != events_.rend()) *pass = *last;
    return pipeline.memory().places().size();
  };
  for (const bool with_c : {true, false}) {
    SCOPED_TRACE(with_c);
    const size_t before = with_c ? 2u : 1u;
    PlaceEvent measured;
    ASSERT_EQ(run(with_c, 1e-3, 0.0, 1.0, &measured), before + 1);
    ASSERT_EQ(measured.kind, EventKind::kLearned);
    ASSERT_EQ(measured.detected_place, static_cast<DetectedPlaceIndex>(before + 1));
    const double g = measured.cost, v = measured.terms.vote;
    // Part of the pass lies in B, part does not.
    ASSERT_GT(v, 0.2);
    ASSERT_LT(v, 0.8);
    ASSERT_GT(g, 0.5);
    EXPECT_EQ(measured.terms.ratio < 1.0, with_c);
    for (const Case& c : {Case{"near miss", true, 0.2, 0.5, 0.0, true},
                          Case{"beyond the margin", true, 0.2, 0.1, 0.0, false},
                          Case{"too few votes", true, 0.2, 0.5, 0.05, false},
                          Case{"lone N1", false, 0.2, 0.5, 0.0, false}}) {
      if (c.with_c != with_c) continue;
      SCOPED_TRACE(c.name);
      PlaceEvent pass;
      const size_t places = run(with_c, g - c.under, c.margin, v + c.extra_vote, &pass);
      EXPECT_NEAR(pass.cost, g, 1e-9);
      if (c.ambiguous) {
        EXPECT_EQ(pass.kind, EventKind::kAmbiguous);
        EXPECT_TRUE(pass.near_miss);
        EXPECT_FALSE(pass.place.has_value());
        EXPECT_EQ(places, before) << "no copy of B learned";
      } else {
        EXPECT_EQ(pass.kind, EventKind::kLearned);
        EXPECT_EQ(places, before + 1);
      }
    }
  }
}

// A short passage through a known place P between A and B is pruned (extent ≤ τ_p). Without
// whereabouts recognition the map joins A and B across it; with it, the robot recognises P
// on the passage and the map records A → P → B, leaving the memory as it was.
TEST_F(PipelineTest, APrunedPassageThroughAKnownPlaceIsMappedThroughIt) {
  const PlaceId a{1, 1}, p{1, 2}, b{1, 3};
  for (const int points : {0, 2}) {
    SCOPED_TRACE(points);
    PipelineOptions options = Options();  // τ_p = 3
    options.whereabouts_points = points;
    Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 60), options,
                      PlaceMemory(1, options.memory), TopologicalMap());
    events_.clear();
    rng_.seed(5);
    Visit(pipeline, 0, 15);  // learns A
    Visit(pipeline, 1, 15);  // learns P
    Visit(pipeline, 2, 15);  // learns B
    Visit(pipeline, 1, 15);  // P again
    Visit(pipeline, 0, 15);  // A again
    ASSERT_EQ(pipeline.memory().places().size(), 3u);
    ASSERT_EQ(pipeline.map().Find(a, b), nullptr);
    const int64_t p_members = pipeline.memory().places()[1].member_count;
    const int64_t ap = pipeline.map().Find(a, p)->traversals;
    const size_t before = events_.size();
    // The passage: 4 frames of P, of which 3 are good (the first is incoherent with the
    // transition before it): pruned.
    Visit(pipeline, 1, 4);
    Visit(pipeline, 2, 15);  // B
    Collect(pipeline.Finish());
    const std::vector<PlaceEvent> passage(events_.begin() + static_cast<long>(before),
                                          events_.end());
    EXPECT_EQ(std::count_if(passage.begin(), passage.end(),
                            [](const PlaceEvent& e) { return e.kind == EventKind::kPruned; }),
              1);
    EXPECT_EQ(pipeline.memory().places()[1].member_count, p_members);  // nothing learned
    if (points == 0) {
      EXPECT_NE(pipeline.map().Find(a, b), nullptr);  // across the pruned passage
      continue;
    }
    EXPECT_EQ(pipeline.map().Find(a, b), nullptr);
    EXPECT_EQ(pipeline.map().Find(a, p)->traversals, ap + 1);
    // A → P as a mapped event of no detected place, then P → B when B closes.
    std::vector<std::pair<PlaceId, PlaceId>> mapped;
    for (const PlaceEvent& e : passage) {
      if (e.kind != EventKind::kMapped) continue;
      mapped.emplace_back(*e.from, *e.place);
      if (*e.from == a) {
        EXPECT_EQ(e.detected_place, 0);
      }
    }
    EXPECT_EQ(mapped, (std::vector<std::pair<PlaceId, PlaceId>>{{a, p}, {p, b}}));
  }
}

// A loop closing without a visible transition: the robot comes from a new stretch (centre 2)
// into known place A (centre 0) so gradually that no base point is incoherent. The open place
// then holds the new stretch and A's revisit; with known tails it is split where A begins,
// so the revisit is recognised as A instead of being learned with the new stretch.
TEST_F(PipelineTest, AKnownPlaceEnteredWithoutATransitionIsSplitOffAndRecognised) {
  for (const bool split : {false, true}) {
    SCOPED_TRACE(split);
    PipelineOptions options = Options();  // τ_p = 3: tails of 4 base points, checked each
    options.split_known_tails = split;
    Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 60), options,
                      PlaceMemory(1, options.memory), TopologicalMap());
    rng_.seed(7);
    Visit(pipeline, 0, 15);  // learns A
    Visit(pipeline, 1, 15);  // learns B
    std::normal_distribution<float> noise(0.0f, 0.02f);
    int incoherent = 0;
    auto frame = [&](const Eigen::VectorXf& centre) {
      Eigen::VectorXf v = centre;
      for (int i = 0; i < kDim; ++i) v[i] = std::max(0.0f, v[i] * (1.0f + noise(rng_)));
      const FrameResult r =
          pipeline.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05});
      incoherent += r.base.status != BaseStatus::kGood;
    };
    for (int j = 0; j < 15; ++j) frame(centres_[2]);
    ASSERT_EQ(incoherent, 1);  // the first, after the transition from B
    for (int j = 1; j <= 30; ++j) {
      const float t = static_cast<float>(j) / 30.0f;
      frame(Normalised((1.0f - t) * centres_[2] + t * centres_[0]));
    }
    for (int j = 0; j < 15; ++j) frame(centres_[0]);
    ASSERT_EQ(incoherent, 1);  // no transition into A
    Visit(pipeline, 1, 15);    // a transition closes the open place, then B again
    pipeline.Finish();
    const LearnedPlace& a = pipeline.memory().places().at(0);
    if (split) {
      EXPECT_EQ(a.detected.size(), 2u);  // A learned, then recognised on the split-off tail
      EXPECT_EQ(pipeline.memory().places().size(), 3u);  // A, B and the new stretch
    } else {
      EXPECT_EQ(a.detected.size(), 1u);  // the revisit went into a place with the stretch
    }
  }
}

TEST_F(PipelineTest, StateContinuesIndices) {
  Visit(0, 10);
  Collect(dut_.Finish());
  const PipelineState s = dut_.state();
  EXPECT_EQ(s.next_base, 13);
  EXPECT_EQ(s.next_detected, 2);
  ASSERT_TRUE(s.previous_place.has_value());
  EXPECT_EQ(*s.previous_place, (PlaceId{1, 1}));
  // The position is the same state without the copy evidence a writer rarely needs.
  const PipelineState p = dut_.position();
  EXPECT_EQ(p.next_base, s.next_base);
  EXPECT_EQ(p.next_detected, s.next_detected);
  EXPECT_EQ(p.previous_place, s.previous_place);
  EXPECT_TRUE(p.copies.empty());
}

// A restart (a new pipeline on the stored memory, map and state) does not know where the robot
// is until it closes a place: the first place after it is not linked to the last before it.
// Places seen in sequence after the restart are linked as usual.
TEST_F(PipelineTest, ARestartDoesNotLinkThePlaceBeforeItToThePlaceAfterIt) {
  Visit(0, 15);
  Visit(1, 15);
  Collect(dut_.Finish());
  const PlaceId a{1, 1}, b{1, 2}, c{1, 3};
  ASSERT_EQ(dut_.map().edges().size(), 1u);
  ASSERT_EQ(dut_.state().previous_place, b);

  Pipeline restarted(CameraIntrinsics::FromHorizontalFov(64, 48, 60), Options(), dut_.memory(),
                     dut_.map(), dut_.state());
  events_.clear();
  Visit(restarted, 2, 15);  // a new place right after the restart
  Visit(restarted, 0, 15);  // then a known one, seen in sequence
  Collect(restarted.Finish());
  EXPECT_EQ(restarted.memory().places().size(), 3u);
  EXPECT_EQ(restarted.map().Find(b, c), nullptr) << "edge invented across the restart";
  EXPECT_NE(restarted.map().Find(c, a), nullptr) << "places seen in sequence not linked";
  EXPECT_EQ(restarted.map().edges().size(), 2u);
  for (const PlaceEvent& e : events_) {
    if (e.kind == EventKind::kMapped) {
      EXPECT_NE(*e.from, b) << "mapped from before the restart";
    }
  }
  // The hint of hybrid search survives the restart: the stored previous place is kept until a
  // place closes.
  Pipeline again(CameraIntrinsics::FromHorizontalFov(64, 48, 60), Options(), dut_.memory(),
                 dut_.map(), dut_.state());
  EXPECT_EQ(again.state().previous_place, b);
}

// The parts of a memory a hand-over could lose or scramble.
void ExpectSameMemory(const PlaceMemory& a, const PlaceMemory& b) {
  ASSERT_EQ(a.places().size(), b.places().size());
  for (size_t i = 0; i < a.places().size(); ++i) {
    EXPECT_EQ(a.places()[i].id, b.places()[i].id);
    EXPECT_TRUE(a.places()[i].mean == b.places()[i].mean) << "mean of place " << i;
    EXPECT_EQ(a.places()[i].members, b.places()[i].members);
  }
  EXPECT_EQ(a.nodes().size(), b.nodes().size());
  EXPECT_EQ(a.slink().pi(), b.slink().pi());
  EXPECT_EQ(a.next_local_id(), b.next_local_id());
}

TEST_F(PipelineTest, AdoptingAMergeThatBringsNothingNewKeepsTheMemory) {
  Visit(0, 15);
  Visit(1, 15);
  Visit(2, 15);  // closes place 1; place 2 stays open across the merge
  ASSERT_EQ(dut_.memory().places().size(), 2u);
  const PlaceMemory before = dut_.memory();

  // A peer that knows nothing new: the merge returns ours as it was.
  MemoryMerge merged = MergeMemories(dut_.memory(), PlaceMemory(2, Options().memory));
  ASSERT_EQ(merged.merge_case, MergeCase::kNothingNew);
  ASSERT_TRUE(merged.peer_into_ours);
  const BaseIndex next = dut_.state().next_base;
  dut_.AdoptMerged(std::move(merged.memory), dut_.map());
  EXPECT_EQ(dut_.state().next_base, next);
  ExpectSameMemory(dut_.memory(), before);
  // The pipeline goes on with it: place 2 is learned, the revisit of place 0 recognised.
  Visit(0, 15);
  Visit(1, 15);
  EXPECT_EQ(dut_.memory().places().size(), 3u);
  EXPECT_GE(Count(EventKind::kRecognized), 1);
}

TEST_F(PipelineTest, AdoptingTheMergedMemoryContinuesWithIt) {
  Visit(0, 15);
  Visit(1, 15);
  Visit(2, 15);
  testing_support::RandomMemory peer = testing_support::MakeRandomMemory(2, 1, kDim, 5);
  const MemoryMerge merged = MergeMemories(dut_.memory(), peer.memory);
  ASSERT_NE(merged.merge_case, MergeCase::kNothingNew);
  dut_.AdoptMerged(merged.memory, MergeMaps(dut_.map(), peer.map, merged.memory));
  ExpectSameMemory(dut_.memory(), merged.memory);
  EXPECT_EQ(dut_.memory().places().size(), 3u);
  Visit(0, 15);
  Visit(1, 15);
  EXPECT_EQ(dut_.memory().places().size(), 4u);
  EXPECT_GE(Count(EventKind::kRecognized), 1);
}

// Base points found to lie at another spacing (tscd's odometry): detection counts with the
// new options from the next base point, recognition scales its unit with the new step unit,
// and a merged memory adopted later keeps it.
TEST_F(PipelineTest, ReadaptsDetectionAndTheStepUnitAndKeepsThemAcrossAMerge) {
  DetectorOptions detector = Options().detector;
  detector.tau_p = 5;
  dut_.Readapt(detector, 0.25);
  EXPECT_EQ(dut_.options().detector.tau_p, 5);
  EXPECT_EQ(dut_.memory().options().step_unit, 0.25);
  Visit(0, 5);  // 5 base points: a place under τ_p 3, pruned under 5
  Visit(1, 15);
  Visit(2, 15);
  EXPECT_EQ(dut_.memory().places().size(), 1u);  // place 1's; place 2 is open
  testing_support::RandomMemory peer = testing_support::MakeRandomMemory(2, 1, kDim, 5);
  const MemoryMerge merged = MergeMemories(dut_.memory(), peer.memory);
  dut_.AdoptMerged(merged.memory, MergeMaps(dut_.map(), peer.map, merged.memory));
  EXPECT_EQ(dut_.memory().options().step_unit, 0.25);

  EXPECT_THROW(dut_.Readapt(detector, -1.0), std::invalid_argument);
  detector.tau_w = 0;
  EXPECT_THROW(dut_.Readapt(detector, 0.5), std::invalid_argument);
  EXPECT_EQ(dut_.options().detector.tau_w, 2);
  EXPECT_EQ(dut_.memory().options().step_unit, 0.25);
}

// A stored memory read under a configuration of other features (config/sweep.ini's L2+I, 700
// dimensions, against the defaults' 1200) would have every frame refused ("descriptor of
// dimension 1200 for a memory of dimension 700"): tscd and `tsc run` ask first, and stop with
// a configuration error.
TEST_F(PipelineTest, AMemoryLearnedWithOtherFeaturesIsNamedBeforeAnyFrame) {
  Visit(0, 15);
  Visit(1, 15);
  Collect(dut_.Finish());
  ASSERT_FALSE(dut_.memory().empty());
  ASSERT_EQ(dut_.memory().places().front().mean.size(), kDim);
  EXPECT_EQ(dut_.descriptor_dimension(), 1200);  // the default features
  try {
    dut_.RequireMemoryOfTheseFeatures();
    FAIL() << "a memory of " << kDim << " dimensions was taken for one of 1200";
  } catch (const DescriptorSpaceMismatch& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("dimension 700"), std::string::npos) << what;
    EXPECT_NE(what.find("gives 1200"), std::string::npos) << what;
  }
  const CameraIntrinsics camera = CameraIntrinsics::FromHorizontalFov(64, 48, 60);
  PipelineOptions thesis = Options();
  thesis.features = FeatureSet::Thesis(2);  // L2+I: 7 features of 100 coefficients
  const Pipeline fits(camera, thesis, dut_.memory(), dut_.map());
  EXPECT_EQ(fits.descriptor_dimension(), kDim);
  EXPECT_NO_THROW(fits.RequireMemoryOfTheseFeatures());
  const Pipeline empty(camera, Options(), PlaceMemory(1, Options().memory), TopologicalMap{});
  EXPECT_NO_THROW(empty.RequireMemoryOfTheseFeatures());
}

// A stored memory does not know the camera: a pipeline given one measures with its own units,
// adapted to the camera's spacing and lens (AdaptToSpacing, AdaptToLens).
TEST(PipelineUnits, AMemoryGivenToAPipelineTakesItsUnits) {
  PipelineOptions options;
  options.memory.view_basis = nullptr;
  PlaceMemoryOptions stored = options.memory;
  stored.distance_unit = 9e-6;
  stored.step_unit = 0.5;
  options.memory.distance_unit = 2.5e-6;
  options.memory.step_unit = 0.25;
  const Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 45), options,
                          PlaceMemory(1, stored), TopologicalMap{});
  EXPECT_EQ(pipeline.memory().options().distance_unit, 2.5e-6);
  EXPECT_EQ(pipeline.memory().options().step_unit, 0.25);
}

TEST(PipelineOptions, RefusesANegativeWhereaboutsWindow) {
  PipelineOptions options;
  options.whereabouts_points = -1;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
}

TEST(PipelineOptions, RequiresIntensity) {
  PipelineOptions o;
  o.features = FeatureSet::Thesis(2, false);
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
