#pragma once
// Which member frame of a recognised place each frame of a detected place shows (the
// frame-level localisation DESIGN §7.1b scores): not the nearest member descriptor alone, but
// the member whose neighbourhood matches the frame's neighbourhood, a short sequence filter
// along either diagonal (the stretch seen again in the same or the opposite direction).
// On the real loop a single nearest descriptor names a frame within 2 of a true revisit for
// 2 % of the revisits at precision 1, the filter over ±2 neighbours for 73 %
// (docs/decisions.md, "Frame-level localisation").

#include <Eigen/Core>
#include <vector>

namespace tsc {

/// Half width of the sequence filter, in base points.
inline constexpr int kLocalisationHalfWindow = 2;

/// For each column of `query` (D's descriptors in base-point order), the index of the column of
/// `members` (P's member descriptors, in the order they were taken) it shows: the member i
/// minimising the mean, over t in [−half_window, half_window] where both exist, of the L1
/// distance between sum-normalised descriptors query(j + t) and members(i ± t). Ties: the
/// smaller i, the same direction first. Empty `members`: every entry −1.
std::vector<int> LocaliseAlongSequence(const Eigen::MatrixXf& query, const Eigen::MatrixXf& members,
                                       int half_window = kLocalisationHalfWindow);

}  // namespace tsc
