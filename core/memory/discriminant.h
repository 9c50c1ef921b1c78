#pragma once
// One-class SVM discriminant d_N of a place memory node (section 3.3): ν-OCSVM with an RBF
// kernel, trained with libsvm, evaluated densely with Eigen.

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "core/range.h"

namespace tsc {

struct DiscriminantOptions {
  double nu = 0.1;         ///< ν of the one-class SVM, (0, 1]
  double gamma = 0.0;      ///< RBF γ; 0 → 1/(median squared distance) of the training set
  int max_training = 128;  ///< cap of training vectors per node (deterministic subsample)
  // Valid ranges (also the configuration's, memory.svm_*).
  static constexpr Range kNuRange{0, 1, /*min_open=*/true};
  static constexpr Range kGammaRange{0, 1e9};
  static constexpr Range kMaxTrainingRange{2, 10000000};
  void Validate() const;
};

/// d(x) = Σ α_i exp(−γ‖x − s_i‖²) − ρ. Positive inside the learned support. Immutable once
/// trained: copies share the trained model, so copying a memory's discriminants (a merge
/// reuses thousands) costs no support vectors.
class OneClassDiscriminant {
 public:
  OneClassDiscriminant() = default;
  /// Restores a trained discriminant. Throws on mismatched sizes or non-finite values.
  OneClassDiscriminant(Eigen::MatrixXf support, Eigen::VectorXf coef, double rho, double gamma);

  /// Trains on the columns of `samples` (dim x n, n ≥ 1). With one sample (or all equal) the
  /// support is a ball of radius given by `gamma` around it. Deterministic.
  static OneClassDiscriminant Train(const Eigen::MatrixXf& samples,
                                    const DiscriminantOptions& options);

  bool trained() const { return model_ != nullptr && model_->support.cols() > 0; }
  double Evaluate(const Eigen::VectorXf& x) const;
  /// Fraction of the columns of `xs` with d > 0, V_N of (3.9)-(3.10).
  double VoteFraction(const Eigen::MatrixXf& xs) const;

  const Eigen::MatrixXf& support() const { return model().support; }  ///< dim x n_sv
  const Eigen::VectorXf& coef() const { return model().coef; }
  double rho() const { return model().rho; }
  double gamma() const { return model().gamma; }

 private:
  struct Model {
    Eigen::MatrixXf support;
    Eigen::VectorXf coef;
    Eigen::VectorXf support_sq_norm;
    double rho = 0.0;
    double gamma = 1.0;
  };
  const Model& model() const;

  std::shared_ptr<const Model> model_;  // null until trained or restored
};

}  // namespace tsc
