#pragma once
// Place detection (thesis section 3.4): an online state machine that partitions the stream of
// base points into maximal neighbourhoods Q* (runs of good points) and temporal windows T*
// (runs of bad points, extended while another bad point follows within τ_n).

#include <cstdint>
#include <optional>
#include <variant>
#include <vector>

#include "core/range.h"

namespace tsc {

/// Index k of a base point in the robot's stream, 0-based, strictly increasing.
using BaseIndex = int64_t;
/// Index m of a detected place, 1-based like D_m (D_0 holds discarded points).
using DetectedPlaceIndex = int64_t;

struct DetectorOptions {
  int tau_n = 2;  ///< τ_n: a bad point within this many points extends the temporal window
  int tau_w = 2;  ///< τ_w: temporal windows this long or longer are transitions, shorter noise
  /// τ_p in base points: places with this many base points or fewer are pruned. -1 (the
  /// default): derived from tau_p_m and spacing_m, so that one configuration serves a 10 fps
  /// camera and a keyframe sequence (DESIGN §3.2 amended; docs/decisions.md, "Frame rate").
  int tau_p = -1;
  /// τ_p as a length of travel: places spanning this many metres or fewer are pruned (3.75 m
  /// = the thesis-sized 25 base points of the simulated robot's 0.15 m step).
  double tau_p_m = 3.75;
  /// Metres of travel between consecutive base points, as the source declares it (a dataset's
  /// camera.json or poses, a camera's route or rate; docs/decisions.md, "Frame rate").
  double spacing_m = 0.15;
  // Valid ranges (tau_* also the configuration's, detection.*).
  static constexpr Range kTauNRange{1, 100000};
  static constexpr Range kTauWRange{1, 100000};
  static constexpr Range kTauPRange{-1, 100000};  ///< -1: from tau_p_m
  static constexpr Range kTauPMRange{0, 10000};
  static constexpr Range kSpacingMRange{0, 1000, /*min_open=*/true};
  /// τ_p in base points: tau_p when set, else the largest count whose length count x
  /// spacing_m is at most tau_p_m.
  int EffectiveTauP() const;
  void Validate() const;
};

/// Base points between two consecutive detected places (inclusive range; empty at the start).
struct TransitionRegion {
  BaseIndex first = 0;
  BaseIndex last = -1;
  bool empty() const { return last < first; }
  int64_t size() const { return empty() ? 0 : last - first + 1; }
  bool operator==(const TransitionRegion&) const = default;
};

/// The place's extent passed τ_p: recognition may run on the partial place.
struct PlaceOpened {
  DetectedPlaceIndex place;
  std::vector<BaseIndex> members;  ///< good base points so far
};
/// A transition (or the end of the stream) closed a place with extent > τ_p.
struct PlaceClosed {
  DetectedPlaceIndex place;
  std::vector<BaseIndex> members;
  TransitionRegion transition_before;  ///< region from the previous detected place to this one
};
/// A closed place with extent ≤ τ_p went to D_0.
struct PlacePruned {
  std::vector<BaseIndex> members;
};
/// A temporal window closed. |T*| ≥ τ_w: a transition; shorter: noise inside a place.
struct WindowClosed {
  BaseIndex first;
  BaseIndex last;
  bool transition;
};
using DetectionEvent = std::variant<PlaceOpened, PlaceClosed, PlacePruned, WindowClosed>;

/// Feed one base point at a time with Add(); Finish() at the end of the stream.
class PlaceDetector {
 public:
  explicit PlaceDetector(DetectorOptions options, DetectedPlaceIndex next_place = 1,
                         BaseIndex first_base = 0);

  /// `good` = ς(k)=0 and κ(k)=0. Indices must increase by one each call.
  std::vector<DetectionEvent> Add(BaseIndex k, bool good);
  /// Closes any open window and place as if a transition followed.
  std::vector<DetectionEvent> Finish();
  /// Ends the open place before its base point `first`, as if a transition without base
  /// points lay there: the members before `first` close as one place (PlaceClosed, or
  /// PlacePruned when τ_p or fewer), the rest continue as the next place (PlaceOpened when
  /// more than τ_p). The pipeline splits where a place it already knows begins inside the
  /// open one (Pipeline, "known tails"). Throws std::logic_error unless a place is open, no
  /// temporal window is, and `first` is a member after the first.
  std::vector<DetectionEvent> SplitBefore(BaseIndex first);
  bool place_open() const { return current_opened_; }
  bool window_open() const { return window_open_; }

  /// Continues under `options` (validated): base points now taken at another spacing count
  /// τ_p and τ_w anew. A place already opened stays open; one not yet opened opens once its
  /// extent passes the new τ_p. Throws std::invalid_argument on invalid options.
  void Readapt(const DetectorOptions& options);

  const DetectorOptions& options() const { return options_; }
  DetectedPlaceIndex next_place() const { return next_place_; }
  /// Members of the place being accumulated (possibly not yet opened).
  const std::vector<BaseIndex>& current_members() const { return current_; }

 private:
  void AppendGood(BaseIndex k, std::vector<DetectionEvent>& out);
  void CloseWindow(std::vector<DetectionEvent>& out);
  void CloseCurrentPlace(std::vector<DetectionEvent>& out);

  DetectorOptions options_;
  int tau_p_;  // options_.EffectiveTauP()
  DetectedPlaceIndex next_place_;
  BaseIndex expected_k_;
  std::vector<BaseIndex> current_;  // good points of the current place
  bool current_opened_ = false;
  DetectedPlaceIndex current_index_ = 0;
  // Open temporal window: first and last bad point; good points after the last bad point wait
  // in pending_good_ until τ_n of them show the window is over.
  bool window_open_ = false;
  BaseIndex window_first_ = 0, window_last_ = 0;
  std::vector<BaseIndex> pending_good_;
  // Last base point of the last closed (non-pruned) place, for transition regions.
  std::optional<BaseIndex> last_place_end_;
};

}  // namespace tsc
