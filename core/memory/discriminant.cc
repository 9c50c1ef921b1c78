#include "core/memory/discriminant.h"

#include <svm.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "core/median.h"

namespace tsc {
namespace {

void Quiet(const char*) {}

// Scale of the RBF kernel from the data: 1 / median squared distance over a fixed set of pairs
// (i, i + n/2), so the cost stays O(n·dim) and the result deterministic.
double MedianGamma(const Eigen::MatrixXf& x) {
  const Eigen::Index n = x.cols();
  std::vector<double> d2;
  const Eigen::Index pairs = std::min<Eigen::Index>(n, 256);
  for (Eigen::Index i = 0; i < pairs; ++i) {
    const Eigen::Index j = (i + std::max<Eigen::Index>(1, n / 2)) % n;
    if (j != i) d2.push_back((x.col(i) - x.col(j)).squaredNorm());
  }
  const double median = d2.empty() ? 0.0 : UpperMedian(std::move(d2));
  if (median > 1e-12) return 1.0 / median;
  // All samples (nearly) equal: size the support from the vector's own scale instead.
  const double scale = x.col(0).squaredNorm();
  return scale > 1e-12 ? 1.0 / (0.01 * scale) : 1.0;
}

}  // namespace

void DiscriminantOptions::Validate() const {
  kNuRange.Check("memory.svm_nu", nu);
  kGammaRange.Check("memory.svm_gamma", gamma);
  kMaxTrainingRange.Check("memory.svm_max_training", max_training);
}

OneClassDiscriminant::OneClassDiscriminant(Eigen::MatrixXf support, Eigen::VectorXf coef,
                                           double rho, double gamma) {
  if (support.cols() != coef.size()) {
    throw std::invalid_argument("discriminant: " + std::to_string(support.cols()) +
                                " support vectors but " + std::to_string(coef.size()) +
                                " coefficients");
  }
  if (!support.allFinite() || !coef.allFinite() || !std::isfinite(rho) || !std::isfinite(gamma) ||
      gamma <= 0) {
    throw std::invalid_argument("discriminant: non-finite values or gamma <= 0");
  }
  auto model = std::make_shared<Model>();
  model->support_sq_norm = support.colwise().squaredNorm().transpose();
  model->support = std::move(support);
  model->coef = std::move(coef);
  model->rho = rho;
  model->gamma = gamma;
  model_ = std::move(model);
}

const OneClassDiscriminant::Model& OneClassDiscriminant::model() const {
  static const Model kUntrained;
  return model_ != nullptr ? *model_ : kUntrained;
}

OneClassDiscriminant OneClassDiscriminant::Train(const Eigen::MatrixXf& samples,
                                                 const DiscriminantOptions& options) {
  options.Validate();
  const Eigen::Index n = samples.cols(), dim = samples.rows();
  if (n < 1) throw std::invalid_argument("discriminant: no training samples");
  const double gamma = options.gamma > 0 ? options.gamma : MedianGamma(samples);
  if (n == 1 || (samples.colwise() - samples.col(0)).squaredNorm() < 1e-20) {
    // A single point: the ball exp(−γ‖x−s‖²) > e^{−1}, i.e. ‖x−s‖² < 1/γ.
    return OneClassDiscriminant(samples.col(0), Eigen::VectorXf::Ones(1), std::exp(-1.0), gamma);
  }
  static std::once_flag quiet;
  std::call_once(quiet, [] { svm_set_print_string_function(&Quiet); });

  // The Gram matrix is computed here with one matrix product and handed to libsvm as a
  // precomputed kernel: libsvm's own sparse dot products cost ~20x more on dense descriptors.
  // Row i is [0: serial i+1, 1..n: K(i, ·)], terminated by index −1.
  const Eigen::VectorXf sq = samples.colwise().squaredNorm().transpose();
  Eigen::MatrixXf d2 = -2.0f * (samples.transpose() * samples);
  d2.colwise() += sq;
  d2.rowwise() += sq.transpose();
  const Eigen::MatrixXd gram = (-gamma * d2.cast<double>().array().max(0.0)).exp().matrix();
  std::vector<std::vector<svm_node>> nodes(n);
  std::vector<svm_node*> rows(n);
  std::vector<double> labels(n, 1.0);
  for (Eigen::Index i = 0; i < n; ++i) {
    nodes[i].reserve(n + 2);
    nodes[i].push_back({0, static_cast<double>(i + 1)});
    for (Eigen::Index j = 0; j < n; ++j) nodes[i].push_back({static_cast<int>(j + 1), gram(i, j)});
    nodes[i].push_back({-1, 0.0});
    rows[i] = nodes[i].data();
  }
  svm_problem problem{static_cast<int>(n), labels.data(), rows.data()};
  svm_parameter param{};
  param.svm_type = ONE_CLASS;
  param.kernel_type = PRECOMPUTED;
  param.gamma = gamma;
  param.nu = options.nu;
  param.cache_size = 16;
  param.eps = 1e-3;
  param.shrinking = 1;
  if (const char* err = svm_check_parameter(&problem, &param)) {
    throw std::invalid_argument(std::string("libsvm: ") + err);
  }
  std::unique_ptr<svm_model, void (*)(svm_model*)> model(
      svm_train(&problem, &param), [](svm_model* m) { svm_free_and_destroy_model(&m); });
  const int n_sv = model->l;
  Eigen::MatrixXf support(dim, n_sv);
  Eigen::VectorXf coef(n_sv);
  for (int s = 0; s < n_sv; ++s) {
    const auto serial = static_cast<Eigen::Index>(model->SV[s][0].value);  // 1-based
    support.col(s) = samples.col(serial - 1);
    coef[s] = static_cast<float>(model->sv_coef[0][s]);
  }
  return OneClassDiscriminant(std::move(support), std::move(coef), model->rho[0], gamma);
}

double OneClassDiscriminant::Evaluate(const Eigen::VectorXf& x) const {
  if (!trained()) return -1.0;
  const Model& m = *model_;
  const Eigen::VectorXf d2 =
      (m.support_sq_norm.array() + x.squaredNorm() - 2.0f * (m.support.transpose() * x).array())
          .matrix();
  return (m.coef.array() * (-static_cast<float>(m.gamma) * d2.array().max(0.0f)).exp()).sum() -
         m.rho;
}

double OneClassDiscriminant::VoteFraction(const Eigen::MatrixXf& xs) const {
  if (!trained() || xs.cols() == 0) return 0.0;
  const Model& m = *model_;
  // ‖x−s‖² for all pairs at once: one matrix product.
  Eigen::MatrixXf d2 = (-2.0f * (m.support.transpose() * xs)).eval();
  d2.colwise() += m.support_sq_norm;
  d2.rowwise() += xs.colwise().squaredNorm();
  const Eigen::VectorXf k =
      (m.coef.transpose() * (-static_cast<float>(m.gamma) * d2.array().max(0.0f)).exp().matrix())
          .transpose();
  const auto votes = (k.array() > static_cast<float>(m.rho)).count();
  return static_cast<double>(votes) / static_cast<double>(xs.cols());
}

}  // namespace tsc
