#include "core/detect/place_detector.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace tsc {

void DetectorOptions::Validate() const {
  kTauNRange.Check("detection.tau_n", tau_n);
  kTauWRange.Check("detection.tau_w", tau_w);
  kTauPRange.Check("detection.tau_p (-1: from tau_p_m)", tau_p);
  kTauPMRange.Check("detection.tau_p_m (m)", tau_p_m);
  kSpacingMRange.Check("base point spacing (m)", spacing_m);
}

int DetectorOptions::EffectiveTauP() const {
  if (tau_p >= 0) return tau_p;
  // The tolerance keeps 3.75 / 0.15 at 25 (it is 24.999... in doubles).
  const double count = std::floor(tau_p_m / spacing_m + 1e-9);
  return static_cast<int>(std::min(count, 100000.0));
}

PlaceDetector::PlaceDetector(DetectorOptions options, DetectedPlaceIndex next_place,
                             BaseIndex first_base)
    : options_(options),
      tau_p_((options_.Validate(), options_.EffectiveTauP())),
      next_place_(next_place),
      expected_k_(first_base) {
  if (next_place < 1) throw std::invalid_argument("detected place indices start at 1");
}

void PlaceDetector::Readapt(const DetectorOptions& options) {
  options.Validate();
  options_ = options;
  tau_p_ = options_.EffectiveTauP();
}

std::vector<DetectionEvent> PlaceDetector::Add(BaseIndex k, bool good) {
  if (k != expected_k_) {
    throw std::invalid_argument("base point " + std::to_string(k) + " out of order, expected " +
                                std::to_string(expected_k_));
  }
  ++expected_k_;
  std::vector<DetectionEvent> out;
  if (!good) {
    if (window_open_) {
      // (3.3)-(3.4): a bad point within τ_n of the last one extends T*; the good points in
      // between are absorbed into the window.
      pending_good_.clear();
      window_last_ = k;
    } else {
      window_open_ = true;
      window_first_ = window_last_ = k;
    }
    return out;
  }
  if (!window_open_) {
    AppendGood(k, out);
    return out;
  }
  pending_good_.push_back(k);
  if (static_cast<int>(pending_good_.size()) >= options_.tau_n) {
    // τ_n good points after the last bad one: T* is final and the good points start Q*.
    CloseWindow(out);
    for (BaseIndex g : pending_good_) AppendGood(g, out);
    pending_good_.clear();
  }
  return out;
}

std::vector<DetectionEvent> PlaceDetector::Finish() {
  std::vector<DetectionEvent> out;
  if (window_open_) {
    CloseWindow(out);
    for (BaseIndex g : pending_good_) AppendGood(g, out);
    pending_good_.clear();
  }
  CloseCurrentPlace(out);
  return out;
}

std::vector<DetectionEvent> PlaceDetector::SplitBefore(BaseIndex first) {
  const auto at = std::lower_bound(current_.begin(), current_.end(), first);
  if (!current_opened_ || window_open_ || at == current_.end() || *at != first ||
      at == current_.begin()) {
    throw std::logic_error("place detector: no open place to split before base point " +
                           std::to_string(first));
  }
  std::vector<BaseIndex> tail(at, current_.end());
  current_.erase(at, current_.end());
  // A head of τ_p base points or fewer is no place (its opening index stays unused).
  if (static_cast<int64_t>(current_.size()) <= tau_p_) current_opened_ = false;
  std::vector<DetectionEvent> out;
  CloseCurrentPlace(out);
  for (BaseIndex k : tail) AppendGood(k, out);
  return out;
}

void PlaceDetector::AppendGood(BaseIndex k, std::vector<DetectionEvent>& out) {
  current_.push_back(k);
  if (!current_opened_ && static_cast<int64_t>(current_.size()) > tau_p_) {
    current_opened_ = true;
    current_index_ = next_place_++;
    out.push_back(PlaceOpened{current_index_, current_});
  }
}

void PlaceDetector::CloseWindow(std::vector<DetectionEvent>& out) {
  const bool transition = window_last_ - window_first_ + 1 >= options_.tau_w;
  out.push_back(WindowClosed{window_first_, window_last_, transition});
  window_open_ = false;
  // |T*| ≥ τ_w: the current place ends here; shorter windows are noise inside the place.
  if (transition) CloseCurrentPlace(out);
}

void PlaceDetector::CloseCurrentPlace(std::vector<DetectionEvent>& out) {
  if (current_.empty()) return;
  if (current_opened_) {
    TransitionRegion before;
    if (last_place_end_) before = TransitionRegion{*last_place_end_ + 1, current_.front() - 1};
    last_place_end_ = current_.back();
    out.push_back(PlaceClosed{current_index_, std::move(current_), before});
  } else {
    out.push_back(PlacePruned{std::move(current_)});  // extent ≤ τ_p: to D_0
  }
  current_.clear();
  current_opened_ = false;
}

}  // namespace tsc
