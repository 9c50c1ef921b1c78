#include "core/merge/merge_cases.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "core/on_threads.h"

namespace tsc {
namespace {

// The radius around `centre` of the ball that holds every member view of `memory`, in the
// space of the views (a view basis shortens distances, never lengthens them).
double ViewBound(const PlaceMemory& memory, const Eigen::VectorXf& centre) {
  double bound = 0.0;
  for (size_t i = 0; i < memory.places().size(); ++i) {
    const double spread = memory.ViewRadius(static_cast<int>(i));
    bound = std::max(bound, (memory.places()[i].mean - centre).norm() + spread);
  }
  return bound;
}

// ‖a − b‖ in the space of the member views.
double ViewSpaceDistance(const PlaceMemory& memory, const Eigen::VectorXf& a,
                         const Eigen::VectorXf& b) {
  return ViewCoordinates(memory.view_basis(), a - b).norm();
}

std::vector<int> AllPlaces(const PlaceMemory& memory) {
  std::vector<int> all(memory.places().size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return all;
}

// A memory's root sphere and the radius around its centre of the ball that holds every
// member view.
struct RootBall {
  NodeStatistics sphere;
  double view_bound = 0.0;
};

RootBall RootBallOf(const PlaceMemory& memory) {
  RootBall b;
  b.sphere = StatisticsOf(memory, AllPlaces(memory));
  b.view_bound = ViewBound(memory, b.sphere.centroid);
  return b;
}

// Figure 4.4's case for the root balls `b` of the base and `i` of the incoming memory. Telling
// the contained cases apart takes the larger memory's hyper-terminals, which go into
// `terminals` (base [0], incoming [1]).
MergeCase RootSphereCase(const PlaceMemory& base, const PlaceMemory& incoming, const RootBall& b,
                         const RootBall& i, double tau_r,
                         std::array<std::vector<HyperTerminal>, 2>& terminals) {
  const NodeStatistics& sb = b.sphere;
  const NodeStatistics& si = i.sphere;
  const double d = (sb.centroid - si.centroid).norm();
  // The spheres reach a recognition radius further: views nearer than sqrt(τ_r·u) may be
  // one place's (term 1 of g is δ/u), so spheres closer than that must not count as apart.
  // Without it two small memories (a single place has radius 0) are always disjoint, and a
  // team exchanging memories as it learns would never recognise a place (docs/decisions.md,
  // "Merging": recognition reach).
  const double reach = std::sqrt(tau_r * std::max(base.DistanceUnit(), incoming.DistanceUnit()));
  // (4.5), decided on the spheres that hold every member view: ρ of (4.4) is a root mean
  // square, and a place outside it may coincide with one of the other memory.
  if (ViewSpaceDistance(base, sb.centroid, si.centroid) > b.view_bound + i.view_bound + reach) {
    return MergeCase::kDisjoint;
  }
  const bool base_large = sb.radius >= si.radius;
  const NodeStatistics& small = base_large ? si : sb;
  const NodeStatistics& large = base_large ? sb : si;
  if (d + small.radius > large.radius) return MergeCase::kIntersecting;
  std::vector<HyperTerminal>& of_large = terminals[base_large ? 0 : 1];
  of_large = HyperTerminals(base_large ? base : incoming);
  for (const HyperTerminal& h : of_large) {
    if ((h.sphere.centroid - small.centroid).norm() <= h.sphere.radius + small.radius + reach) {
      return MergeCase::kContainedIntersecting;
    }
  }
  return MergeCase::kContained;
}

}  // namespace

std::string_view ToString(MergeCase c) {
  switch (c) {
    case MergeCase::kNothingNew:
      return "nothing-new";
    case MergeCase::kDisjoint:
      return "disjoint";
    case MergeCase::kContained:
      return "contained";
    case MergeCase::kContainedIntersecting:
      return "contained-intersecting";
    case MergeCase::kIntersecting:
      return "intersecting";
  }
  return "?";
}

bool PeerGoesIntoOurs(const PlaceMemory& ours, const PlaceMemory& peer) {
  return PeerGoesIntoOurs(ours.places().size(), ours.robot(), peer.places().size(), peer.robot());
}

bool PeerGoesIntoOurs(size_t ours_places, uint32_t ours_robot, size_t peer_places,
                      uint32_t peer_robot) {
  return peer_places < ours_places || (peer_places == ours_places && ours_robot <= peer_robot);
}

RootSpheres CaseOfRootSpheres(const PlaceMemory& base, const PlaceMemory& incoming, double tau_r,
                              int threads) {
  // Each memory's ball reads every one of its means: the two are measured side by side, each
  // as one thread would.
  RootBall balls[2];
  OnThreads(2, threads, [&](size_t m) { balls[m] = RootBallOf(m == 0 ? base : incoming); });
  RootSpheres s;
  s.merge_case = RootSphereCase(base, incoming, balls[0], balls[1], tau_r, s.terminals);
  s.base = std::move(balls[0].sphere);
  s.incoming = std::move(balls[1].sphere);
  return s;
}

bool RecognitionDecides(MergeCase c) {
  return c == MergeCase::kContainedIntersecting || c == MergeCase::kIntersecting;
}

}  // namespace tsc
