#include "core/memory/point_agreement.h"

#include <algorithm>
#include <stdexcept>

namespace tsc {

double PointAgreement(const ViewDistances& vd, int place, std::span<const int> copies,
                      double slack) {
  if (!vd.measured(place)) throw std::invalid_argument("agreement with a place not measured");
  if (!(slack >= 1.0)) throw std::invalid_argument("agreement slack below 1");
  int agree = 0, judged = 0;
  for (int j = 0; j < vd.num_votes(); ++j) {
    const int nearest = vd.NearestPlace(j);
    if (nearest < 0) continue;
    ++judged;
    if (nearest == place || std::find(copies.begin(), copies.end(), nearest) != copies.end() ||
        vd.distance(j, place) <= slack * vd.distance(j, nearest)) {
      ++agree;
    }
  }
  return judged == 0 ? 1.0 : static_cast<double>(agree) / judged;
}

}  // namespace tsc
