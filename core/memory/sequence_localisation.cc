#include "core/memory/sequence_localisation.h"

#include <limits>
#include <stdexcept>

namespace tsc {
namespace {

// Columns scaled to sum 1 (a zero column stays zero): the descriptors' blocks are amplitudes,
// and a frame's overall brightness should not decide which member it shows.
Eigen::MatrixXf SumNormalised(const Eigen::MatrixXf& m) {
  Eigen::MatrixXf out = m;
  for (Eigen::Index c = 0; c < out.cols(); ++c) {
    const float s = out.col(c).sum();
    if (s > 0.0f) out.col(c) /= s;
  }
  return out;
}

}  // namespace

std::vector<int> LocaliseAlongSequence(const Eigen::MatrixXf& query, const Eigen::MatrixXf& members,
                                       int half_window) {
  if (half_window < 0) throw std::invalid_argument("localisation: negative half window");
  const int n = static_cast<int>(query.cols()), p = static_cast<int>(members.cols());
  std::vector<int> out(static_cast<size_t>(n), -1);
  if (p == 0 || n == 0) return out;
  if (query.rows() != members.rows()) {
    throw std::invalid_argument("localisation: descriptors of different dimensions");
  }
  const Eigen::MatrixXf q = SumNormalised(query), m = SumNormalised(members);
  Eigen::MatrixXf dist(n, p);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < p; ++i) dist(j, i) = (q.col(j) - m.col(i)).cwiseAbs().sum();
  }
  for (int j = 0; j < n; ++j) {
    float best = std::numeric_limits<float>::infinity();
    for (int i = 0; i < p; ++i) {
      for (const int direction : {1, -1}) {
        float sum = 0.0f;
        int count = 0;
        for (int t = -half_window; t <= half_window; ++t) {
          const int a = j + t, b = i + direction * t;
          if (a < 0 || a >= n || b < 0 || b >= p) continue;
          sum += dist(a, b);
          ++count;
        }
        const float mean = sum / static_cast<float>(count);  // count ≥ 1: t = 0 is in range
        if (mean < best) best = mean, out[static_cast<size_t>(j)] = i;
      }
    }
  }
  return out;
}

}  // namespace tsc
