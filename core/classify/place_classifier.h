#pragma once
// Supervised place classification of thesis chapter 2 (section 2.4, DESIGN §3.7): a multi-class
// C-SVC with an RBF kernel (libsvm, one-against-one, probability estimates ξ_p), its C and γ
// chosen by a grid search with k-fold cross-validation, and the decision rule with confidence τ.
// Pure computation: models are serialised to and from text; files are the tools' business.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace tsc {

/// Bubble descriptors of frames taken at known places. Invariants (Validate): at least two
/// places, one label per column, labels in [0, places.size()), finite values, at least one
/// descriptor per place.
struct LabelledDescriptors {
  std::vector<std::string> places;  ///< place names; class p is places[p]
  Eigen::MatrixXf descriptors;      ///< dim x n, one descriptor I(x_j) per column
  std::vector<int> labels;          ///< n class indices
  int size() const { return static_cast<int>(labels.size()); }
  /// Throws std::invalid_argument naming what is wrong (and the column at fault).
  void Validate() const;
  /// The columns `indices` (labels and places kept).
  LabelledDescriptors Subset(const std::vector<int>& indices) const;
};

/// C of the C-SVC and γ of the RBF kernel exp(−γ‖x − y‖²).
struct SvmParameters {
  double c = 8.0;
  double gamma = 1.0;
  void Validate() const;  ///< both finite and > 0
};

/// The grid search. γ is searched relative to γ0 = 1 / median squared distance between
/// descriptors of the training set, so the grid does not depend on the descriptor scale (see
/// docs/decisions.md); C absolutely.
struct ClassifierOptions {
  double log2_c_from = -1.0;  ///< C = 2^from, 2^(from+step), ... 2^to
  double log2_c_to = 9.0;
  double log2_c_step = 2.0;
  double log2_gamma_from = -3.0;  ///< γ = γ0 · 2^from, ... γ0 · 2^to
  double log2_gamma_to = 3.0;
  double log2_gamma_step = 1.5;
  int folds = 5;          ///< k of the k-fold cross-validation, ≥ 2
  uint32_t seed = 1;      ///< fold assignment and libsvm's probability folds
  void Validate() const;  ///< throws std::invalid_argument naming the bad field
  std::vector<double> CValues() const;
  std::vector<double> GammaScales() const;  ///< the 2^k multiplying γ0
};

/// One cell of the grid: cross-validated accuracy (fraction of held-out descriptors whose
/// most probable class by the pairwise vote is right).
struct GridPoint {
  double c = 0.0;
  double gamma = 0.0;
  double accuracy = 0.0;
};

struct GridSearchResult {
  double gamma0 = 0.0;  ///< 1 / median squared distance of the training set
  std::vector<GridPoint> points;
  SvmParameters best;  ///< highest accuracy; ties to the smaller γ, then the smaller C
  double best_accuracy = 0.0;
};

/// 1 / median squared distance over a fixed set of descriptor pairs (deterministic).
double MedianGamma(const Eigen::MatrixXf& descriptors);

/// Stratified fold of every descriptor (0..folds−1): each place's descriptors are shuffled with
/// `seed` and dealt round-robin, so every fold holds about 1/folds of each place.
std::vector<int> AssignFolds(const std::vector<int>& labels, int folds, uint32_t seed);

/// Grid search of C and γ by k-fold cross-validation (section 2.5: "iterative 5-fold
/// cross-validation"). Throws std::invalid_argument for bad data or options.
GridSearchResult GridSearch(const LabelledDescriptors& data, const ClassifierOptions& options);

/// Marks ξ below the confidence threshold: the decision rule of section 2.4 returns this.
inline constexpr int kUnclassified = -1;

/// β = arg max_p ξ_p when max_p ξ_p ≥ τ, else kUnclassified (section 2.4). Ties go to the lower
/// class index.
int Decide(const Eigen::VectorXd& probabilities, double tau);

/// A trained one-against-one C-SVC with probability estimates. The model keeps its support
/// vectors and libsvm's coefficients; libsvm evaluates it through a precomputed kernel whose
/// values are computed here with Eigen (dense descriptors).
class PlaceClassifier {
 public:
  /// Trains on every descriptor of `data` with `params`. libsvm draws the folds of its
  /// probability fit from rand(): it is seeded with `seed` first, so training is repeatable.
  static PlaceClassifier Train(const LabelledDescriptors& data, const SvmParameters& params,
                               uint32_t seed = 1);

  const std::vector<std::string>& places() const { return places_; }
  int num_places() const { return static_cast<int>(places_.size()); }
  int dim() const { return static_cast<int>(support_.rows()); }
  int num_support_vectors() const { return static_cast<int>(support_.cols()); }
  const SvmParameters& parameters() const { return params_; }

  /// ξ_p(I) for every place p, summing to 1 (libsvm's pairwise coupling, [62] of the thesis).
  /// Throws std::invalid_argument when the dimension differs from the model's.
  Eigen::VectorXd Probabilities(const Eigen::VectorXf& descriptor) const;
  /// Decide(Probabilities(descriptor), tau).
  int Classify(const Eigen::VectorXf& descriptor, double tau) const;

  /// Text form: every number written so that it reads back exactly (identical predictions).
  std::string Serialize() const;
  /// Parses Serialize()'s text. Throws std::invalid_argument naming the line at fault.
  static PlaceClassifier Deserialize(const std::string& text);

 private:
  PlaceClassifier() = default;
  // Checks sizes, labels and finiteness (throws std::invalid_argument); caches ‖s_i‖².
  void CheckAndPrepare();

  std::vector<std::string> places_;
  SvmParameters params_;
  Eigen::MatrixXf support_;                    // dim x l, grouped by class as libsvm orders them
  Eigen::VectorXf support_sq_norm_;            // ‖s_i‖²
  std::vector<int> class_sv_count_;            // nSV[k], libsvm class order
  std::vector<int> class_label_;               // label[k]: place index of libsvm class k
  Eigen::MatrixXd sv_coef_;                    // (k−1) x l
  std::vector<double> rho_, prob_a_, prob_b_;  // k(k−1)/2 each
};

/// Each descriptor's ξ from a model trained on the other folds (columns: descriptors, rows:
/// places). For scoring a single data set as in the thesis' second experiment.
Eigen::MatrixXd CrossValidatedProbabilities(const LabelledDescriptors& data,
                                            const SvmParameters& params, int folds, uint32_t seed);

}  // namespace tsc
