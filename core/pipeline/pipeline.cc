#include "core/pipeline/pipeline.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/memory/builtin_view_basis.h"
#include "core/memory/descriptor_space_mismatch.h"
#include "core/merge/consolidate.h"
#include "core/merge/merge_maps.h"

namespace tsc {
namespace {
PlaceEvent MakeEvent(EventKind kind, BaseIndex frame, DetectedPlaceIndex detected) {
  PlaceEvent e;
  e.kind = kind;
  e.frame = frame;
  e.detected_place = detected;
  return e;
}
}  // namespace

const char* EventKindName(EventKind k) {
  switch (k) {
    case EventKind::kDetected:
      return "detected";
    case EventKind::kRecognized:
      return "recognized";
    case EventKind::kLearned:
      return "learned";
    case EventKind::kMapped:
      return "mapped";
    case EventKind::kPruned:
      return "pruned";
    case EventKind::kAmbiguous:
      return "ambiguous";
  }
  return "?";
}

void PipelineOptions::Validate() const {
  surface.Validate();
  descriptor.Validate();
  reliability.Validate();
  detector.Validate();
  memory.Validate();
  kWhereaboutsPointsRange.Check("pipeline.whereabouts_points", whereabouts_points);
  kConsolidateAfterRange.Check("pipeline.consolidate_after", consolidate_after);
  if (!features.Contains(Feature::kIntensity)) {
    throw std::invalid_argument("bubble.features must include intensity (place detection uses it)");
  }
  // Said when the configuration is read (exit 78), rather than when the pipeline starts. (The
  // view basis is checked at start: tools read a configuration and set other features.)
  descriptor.CheckGrid(ViewingGrid(surface.d_phi_deg));
}

PlaceMemoryOptions WithBuiltinViewBasis(PlaceMemoryOptions options) {
  options.view_basis = BuiltinViewBasis();
  return options;
}

Pipeline::Pipeline(CameraIntrinsics camera, PipelineOptions options, PlaceMemory memory,
                   TopologicalMap map, PipelineState state)
    : options_((options.Validate(), std::move(options))),
      surface_(options_.features, camera, options_.surface),
      computer_(surface_.grid(), options_.descriptor),
      detector_(options_.detector, state.next_detected, state.next_base),
      memory_(std::move(memory)),
      copies_(options_.consolidate_after, state.copies),
      map_(std::move(map)),
      next_base_(state.next_base),
      previous_place_(state.previous_place) {
  if (memory_.robot() != options_.robot) {
    throw std::invalid_argument("place memory of robot " + std::to_string(memory_.robot()) +
                                " given to the pipeline of robot " +
                                std::to_string(options_.robot));
  }
  // A stored memory does not know the camera: its units are those of the options, adapted to
  // the camera's spacing and lens.
  memory_.AdoptUnits(options_.memory);
  // Said here, at start, rather than when the first place is learned.
  descriptor_dimension_ = computer_.Compute(surface_).dim();
  surface_.Reset();
  if (const ViewBasis* basis = memory_.view_basis();
      basis && descriptor_dimension_ != basis->input_dimension()) {
    throw std::invalid_argument(
        "memory.view_basis = " + basis->name() + " takes descriptors of dimension " +
        std::to_string(basis->input_dimension()) + ", but bubble.features = " +
        options_.features.ToString() + " gives " + std::to_string(descriptor_dimension_) +
        ": set memory.view_basis = none, or fit a basis for these features with tsc basis");
  }
}

void Pipeline::RequireMemoryOfTheseFeatures() const {
  if (memory_.empty()) return;
  const Eigen::Index held = memory_.places().front().mean.size();
  if (held != descriptor_dimension_) {
    throw DescriptorSpaceMismatch(
        "the place memory holds descriptors of dimension " + std::to_string(held) +
        ", but bubble.features = " + options_.features.ToString() + " gives " +
        std::to_string(descriptor_dimension_) +
        ": the memory was learned with other features; use the configuration it was learned "
        "with");
  }
}

PipelineState Pipeline::state() const {
  PipelineState s = position();
  s.copies = copies_.Witnesses();
  return s;
}

PipelineState Pipeline::position() const {
  return PipelineState{next_base_, detector_.next_place(), previous_place_, {}};
}

BasePointView FinishBasePoint(BubbleSurface& surface, const DescriptorComputer& computer) {
  BasePointView view{computer.Compute(surface), IntensityStatistics(surface), Descriptor()};
  surface.Reset();
  return view;
}

BasePointView DescribeBasePoint(std::span<const Observation> views, BubbleSurface& surface,
                                const DescriptorComputer& computer) {
  if (views.empty()) throw std::invalid_argument("a base point of no views");
  try {
    Descriptor coherence;
    for (size_t j = 0; j < views.size(); ++j) {
      surface.Observe(views[j]);
      // The surface holds the sweep's first view alone: its descriptor is a forward camera's.
      if (j == 0 && views.size() > 1) coherence = computer.Compute(surface);
    }
    BasePointView out;
    if (surface.features().IndexOf(Feature::kIntensity) >= 0) {
      out = FinishBasePoint(surface, computer);
    } else {
      out.descriptor = computer.Compute(surface);
      surface.Reset();
    }
    out.coherence = std::move(coherence);
    return out;
  } catch (...) {
    surface.Reset();  // the next base point starts from nothing
    throw;
  }
}

FrameResult Pipeline::Process(std::span<const Observation> views) {
  const BasePointView view = DescribeBasePoint(views, surface_, computer_);
  return ProcessDescriptor(view.descriptor, view.intensity,
                           view.coherence.empty() ? nullptr : &view.coherence);
}

FrameResult Pipeline::ProcessDescriptor(const Descriptor& descriptor,
                                        const IntensityStats& intensity,
                                        const Descriptor* coherence) {
  if (!memory_.empty() && descriptor.dim() != memory_.places().front().mean.size()) {
    throw std::invalid_argument("descriptor of dimension " + std::to_string(descriptor.dim()) +
                                " for a memory of dimension " +
                                std::to_string(memory_.places().front().mean.size()));
  }
  if (coherence != nullptr && coherence->dim() != descriptor.dim()) {
    throw std::invalid_argument("coherence descriptor of dimension " +
                                std::to_string(coherence->dim()) + " for a descriptor of " +
                                std::to_string(descriptor.dim()));
  }
  FrameResult out;
  const BaseIndex k = next_base_++;
  out.base.index = k;
  out.base.descriptor = descriptor.values();
  out.base.intensity = intensity;
  const Eigen::VectorXf& judged = coherence != nullptr ? coherence->values() : descriptor.values();
  out.base.status = ClassifyBasePoint(options_.reliability, intensity, judged,
                                      previous_descriptor_ ? &*previous_descriptor_ : nullptr);
  previous_descriptor_ = judged;
  recent_.emplace_back(k, descriptor.values());
  HandleDetection(detector_.Add(k, out.base.status == BaseStatus::kGood), k, out);
  SplitAtKnownTail(k, out);
  RecogniseWhereabouts(k, out);
  TrimDescriptors();
  return out;
}

void Pipeline::Readapt(const DetectorOptions& detector, double step_unit) {
  // Each check comes before anything changes: a throw leaves the pipeline as it was.
  PlaceMemoryOptions units = options_.memory;
  units.step_unit = step_unit;
  units.ValidateUnits();
  detector_.Readapt(detector);
  memory_.AdoptUnits(units);
  options_.detector = detector;
  options_.memory = units;
}

void Pipeline::AdoptMerged(PlaceMemory memory, TopologicalMap map) {
  if (memory.robot() != memory_.robot()) {
    throw std::invalid_argument("merged memory of robot " + std::to_string(memory.robot()) +
                                " given to the pipeline of robot " +
                                std::to_string(memory_.robot()));
  }
  // The previous place and the whereabouts follow the place that absorbed them.
  for (std::optional<PlaceId>* followed : {&previous_place_, &whereabouts_}) {
    if (!*followed) continue;
    for (const LearnedPlace& p : memory.places()) {
      if (std::binary_search(p.sources.begin(), p.sources.end(), **followed)) {
        *followed = p.id;
        break;
      }
    }
  }
  partial_recognition_.reset();
  known_tail_.reset();
  // A merged memory carries our memory's options (MergeMemories, Consolidate): the step unit
  // stays the one this robot's base points are taken at (Readapt).
  memory_ = std::move(memory);
  map_ = std::move(map);
}

PlaceMemory Pipeline::GiveUpMemory() {
  PlaceMemory out = std::move(memory_);
  memory_ = PlaceMemory(out.robot(), out.options());
  return out;
}

int Pipeline::Consolidate(int place, const CostTerms& terms, DetectedPlaceIndex m, PlaceEvent& e,
                          FrameResult& out) {
  if (terms.held_again.empty() || options_.consolidate_after == 0) return place;
  const PlaceId id = memory_.places()[static_cast<size_t>(place)].id;
  const std::vector<PlaceId> neighbours = map_.Neighbours(id);
  std::vector<int> group{place};
  for (const int q : terms.held_again) {
    const PlaceId copy = memory_.places()[static_cast<size_t>(q)].id;
    // A place the map joins to this one is the room next door seen through a door, not a
    // copy; a copy is entered from where the room is (docs/calibration.md, twenty-first pass).
    const std::vector<PlaceId> around = map_.Neighbours(copy);
    if (std::find(neighbours.begin(), neighbours.end(), copy) != neighbours.end()) continue;
    const bool shared = std::any_of(around.begin(), around.end(), [&](const PlaceId& p) {
      return std::find(neighbours.begin(), neighbours.end(), p) != neighbours.end();
    });
    const uint64_t before = copies_.changes();
    if (shared && copies_.Witness(id, copy, m)) group.push_back(q);
    out.copies_changed |= copies_.changes() != before;
  }
  if (group.size() == 1) return place;
  if (before_replace_) before_replace_();
  Consolidation c = tsc::Consolidate(std::move(memory_), std::move(group));
  e.folded = std::move(c.folded);
  TopologicalMap map = MergeMaps(map_, TopologicalMap{}, c.memory);
  AdoptMerged(std::move(c.memory), std::move(map));
  out.memory_replaced = true;
  return *memory_.Find(c.holder);
}

FrameResult Pipeline::Finish() {
  FrameResult out;
  out.has_base = false;
  HandleDetection(detector_.Finish(), next_base_ - 1, out);
  TrimDescriptors();
  return out;
}

DetectedPlace Pipeline::Gather(DetectedPlaceIndex m, const std::vector<BaseIndex>& members) const {
  DetectedPlace d;
  d.index = m;
  d.members = members;
  const Eigen::Index dim = recent_.empty() ? 0 : recent_.front().second.size();
  d.descriptors.resize(dim, static_cast<Eigen::Index>(members.size()));
  // recent_ is sorted by base index and holds every member of an unclosed place.
  size_t r = 0;
  for (size_t j = 0; j < members.size(); ++j) {
    while (r < recent_.size() && recent_[r].first < members[j]) ++r;
    if (r == recent_.size() || recent_[r].first != members[j]) {
      throw std::logic_error("descriptor of base point " + std::to_string(members[j]) + " lost");
    }
    d.descriptors.col(static_cast<Eigen::Index>(j)) = recent_[r].second;
  }
  return d;
}

void Pipeline::HandleDetection(const std::vector<DetectionEvent>& events, BaseIndex k,
                               FrameResult& out) {
  const auto previous_index = [&]() -> std::optional<int> {
    return previous_place_ ? memory_.Find(*previous_place_) : std::nullopt;
  };
  const auto neighbour_indices = [&]() {
    std::vector<int> indices;
    if (!previous_place_) return indices;
    for (const PlaceId& p : map_.Neighbours(*previous_place_)) {
      if (const auto i = memory_.Find(p)) indices.push_back(*i);
    }
    return indices;
  };
  for (const DetectionEvent& event : events) {
    if (!std::holds_alternative<WindowClosed>(event)) known_tail_.reset();
    if (const auto* opened = std::get_if<PlaceOpened>(&event)) {
      partial_recognition_.reset();
      if (!options_.recognize_partial || memory_.empty()) continue;
      const Recognition r =
          memory_.Recognize(Gather(opened->place, opened->members), previous_index());
      if (!r.place) continue;
      partial_recognition_ = *r.place;  // a known tail of the same place is no split
      PlaceEvent e = MakeEvent(EventKind::kRecognized, k, opened->place);
      e.place = memory_.places()[*r.place].id;
      e.cost = r.cost;
      e.terms = r.terms;
      e.partial = true;
      e.hybrid = r.hybrid;
      out.events.push_back(e);
    } else if (const auto* closed = std::get_if<PlaceClosed>(&event)) {
      DetectedPlace d = Gather(closed->place, closed->members);
      PlaceEvent detected = MakeEvent(EventKind::kDetected, k, closed->place);
      detected.members = static_cast<int64_t>(closed->members.size());
      out.events.push_back(detected);
      if (!closed->transition_before.empty()) out.transitions.push_back(closed->transition_before);
      // Recognise or learn (sections 3.5, 3.6); the map says which places lie next to the
      // previous one.
      const Recognition r = memory_.Recognize(d, previous_index(), neighbour_indices());
      const bool disagreement = r.disagreed && !memory_.options().learn_disagreed;
      if (!r.place && (disagreement || r.near_miss)) {
        // Known by its cost, but its points name other places (a room held several times
        // splits them), or nearly known, half of it in a place held already: learning it
        // would add one more copy. It stays without a place, and the map joins nothing
        // across it: where the robot was is not known.
        PlaceEvent e = MakeEvent(EventKind::kAmbiguous, k, closed->place);
        e.cost = r.cost;
        e.terms = r.terms;
        e.near_miss = !disagreement;
        out.events.push_back(e);
        previous_place_.reset();
        whereabouts_.reset();
        partial_recognition_.reset();
        out.closed_places.push_back(std::move(d));
        continue;
      }
      int place;
      PlaceEvent e = MakeEvent(EventKind::kLearned, k, closed->place);
      if (r.place) {
        place = *r.place;
        if (before_update_) before_update_(place);
        memory_.Update(place, d);
        e.kind = EventKind::kRecognized;
        e.hybrid = r.hybrid;
        e.neighbour = r.neighbour;
        place = Consolidate(place, r.terms, closed->place, e, out);
      } else {
        place = memory_.Learn(d);
        e.kind = EventKind::kLearned;
      }
      e.cost = r.cost;
      e.terms = r.terms;
      const PlaceId id = memory_.places()[place].id;
      e.place = id;
      out.events.push_back(e);
      out.changed_places.push_back(place);
      out.memory_changed = true;
      map_.AddPlace(id);
      // Mapping (section 3.7): the edge β(D_{m−1})β(D_m), or from the known place the robot
      // was recognised at since D_{m−1} closed (RecogniseWhereabouts).
      const TransitionRegion region = whereabouts_ != previous_place_ && whereabouts_seen_
                                          ? SinceWhereabouts(closed->members.front())
                                          : closed->transition_before;
      if (whereabouts_) MapFromWhereabouts(id, region, k, closed->place, out);
      previous_place_ = whereabouts_ = id;
      whereabouts_seen_ = closed->members.back();
      partial_recognition_.reset();
      out.closed_places.push_back(std::move(d));
    } else if (const auto* pruned = std::get_if<PlacePruned>(&event)) {
      PlaceEvent e = MakeEvent(EventKind::kPruned, k, 0);
      e.members = static_cast<int64_t>(pruned->members.size());
      out.events.push_back(e);
    }
  }
}

// Until a maximal neighbourhood has the plenitude of a place (extent ≤ τ_p) it is no detected
// place yet, and if the robot leaves it that soon it is pruned; the map would then join the
// places before and after it (β(D_{m−1})β(D_m) across a short corridor passage). Meanwhile
// the robot recognises its whereabouts (section 3.5) on the last whereabouts_points base
// points: recognition without learning, the memory is not touched. A known place other than
// the whereabouts enters the map (A → P → B). Once the place opens, its own recognition
// (partial, then on closing) decides. docs/decisions.md, "Map".
void Pipeline::RecogniseWhereabouts(BaseIndex k, FrameResult& out) {
  const int n = options_.whereabouts_points;
  const std::vector<BaseIndex>& members = detector_.current_members();
  const int64_t extent = static_cast<int64_t>(members.size());
  if (n <= 0 || memory_.empty() || !whereabouts_ || members.empty() || members.back() != k ||
      extent < n || extent > options_.detector.EffectiveTauP()) {
    return;
  }
  const std::vector<BaseIndex> window(members.end() - n, members.end());
  const Recognition r = memory_.Recognize(Gather(0, window), memory_.Find(*whereabouts_));
  if (!r.place) return;
  const PlaceId id = memory_.places()[*r.place].id;
  if (id != *whereabouts_) {
    // No detected place of its own: the event names detected place 0.
    MapFromWhereabouts(id, SinceWhereabouts(window.front()), k, 0, out);
    whereabouts_ = id;
  }
  whereabouts_seen_ = k;
}

void Pipeline::SplitAtKnownTail(BaseIndex k, FrameResult& out) {
  if (!options_.split_known_tails || memory_.empty() || !detector_.place_open() ||
      detector_.window_open()) {
    return;
  }
  const std::vector<BaseIndex>& members = detector_.current_members();
  const int64_t tail_size = options_.detector.EffectiveTauP() + 1;
  const int64_t size = static_cast<int64_t>(members.size());
  // The head left by a split must be a place of its own (more than τ_p base points); the
  // tail is checked every quarter of its length (a recognition per base point at 30 fps would
  // cost more than the frame).
  const int64_t every = std::max<int64_t>(1, tail_size / 4);
  if (size < 2 * tail_size || members.back() != k || (size - 2 * tail_size) % every != 0) return;
  const std::vector<BaseIndex> tail(members.end() - tail_size, members.end());
  const auto previous = previous_place_ ? memory_.Find(*previous_place_) : std::nullopt;
  const Recognition r = memory_.Recognize(Gather(0, tail), previous);
  const std::optional<int> seen_before = std::exchange(known_tail_, std::nullopt);
  if (!r.place || r.place == partial_recognition_) return;
  // Two checks in a row must show the same place: one tail alone split corridors at look-alike
  // stretches (docs/decisions.md, "Known tails").
  if (seen_before != r.place) {
    known_tail_ = r.place;
    return;
  }
  const std::vector<BaseIndex> head(members.begin(), members.end() - tail_size);
  if (memory_.Recognize(Gather(0, head), previous).place == r.place) return;
  HandleDetection(detector_.SplitBefore(tail.front()), k, out);
}

TransitionRegion Pipeline::SinceWhereabouts(BaseIndex before) const {
  if (!whereabouts_seen_ || *whereabouts_seen_ + 1 > before - 1) return TransitionRegion{};
  return TransitionRegion{*whereabouts_seen_ + 1, before - 1};
}

void Pipeline::MapFromWhereabouts(PlaceId to, TransitionRegion region, BaseIndex k,
                                  DetectedPlaceIndex m, FrameResult& out) {
  if (!map_.RecordTransition(*whereabouts_, to, region)) return;
  PlaceEvent mapped = MakeEvent(EventKind::kMapped, k, m);
  mapped.place = to;
  mapped.from = whereabouts_;
  mapped.transition = region;
  out.events.push_back(mapped);
}

void Pipeline::TrimDescriptors() {
  // Keep what an unclosed place or a pending window may still claim.
  BaseIndex keep_from = next_base_ - options_.detector.tau_n - 1;
  if (!detector_.current_members().empty()) {
    keep_from = std::min(keep_from, detector_.current_members().front());
  }
  while (!recent_.empty() && recent_.front().first < keep_from) recent_.pop_front();
}

}  // namespace tsc
