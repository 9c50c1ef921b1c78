#include "core/classify/place_classifier.h"

#include <svm.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>

#include "core/median.h"

namespace tsc {
namespace {

void Quiet(const char*) {}
void SilenceLibsvm() {
  static std::once_flag quiet;
  std::call_once(quiet, [] { svm_set_print_string_function(&Quiet); });
}

using ModelPtr = std::unique_ptr<svm_model, void (*)(svm_model*)>;
ModelPtr Own(svm_model* m) {
  return ModelPtr(m, [](svm_model* p) { svm_free_and_destroy_model(&p); });
}

// ‖a_i − b_j‖² for all column pairs, clamped at 0 (one matrix product).
Eigen::MatrixXf SquaredDistances(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  Eigen::MatrixXf d2 = -2.0f * (a.transpose() * b);
  d2.colwise() += a.colwise().squaredNorm().transpose();
  d2.rowwise() += b.colwise().squaredNorm();
  return d2.cwiseMax(0.0f);
}

// libsvm's precomputed-kernel rows over a whole data set: row i is
// [0: serial i+1, j+1: K(i, j) for every j, −1]. A training subset points at some of the rows;
// serials keep indexing the whole set, so one Gram matrix serves every fold.
class KernelRows {
 public:
  explicit KernelRows(int n)
      : n_(n), nodes_(static_cast<size_t>(n) * static_cast<size_t>(n + 2)), rows_(n) {
    for (int i = 0; i < n; ++i) {
      svm_node* row = &nodes_[static_cast<size_t>(i) * static_cast<size_t>(n + 2)];
      row[0] = {0, static_cast<double>(i + 1)};
      for (int j = 0; j < n; ++j) row[j + 1] = {j + 1, 0.0};
      row[n + 1] = {-1, 0.0};
      rows_[i] = row;
    }
  }
  void Fill(const Eigen::MatrixXf& d2, double gamma) {
    for (int i = 0; i < n_; ++i) {
      for (int j = 0; j < n_; ++j) rows_[i][j + 1].value = std::exp(-gamma * d2(i, j));
    }
  }
  svm_node* row(int i) const { return rows_[i]; }

 private:
  int n_;
  std::vector<svm_node> nodes_;
  std::vector<svm_node*> rows_;
};

svm_parameter CsvcParameters(const SvmParameters& p, bool probability) {
  svm_parameter param{};
  param.svm_type = C_SVC;
  param.kernel_type = PRECOMPUTED;
  param.gamma = p.gamma;  // recorded only: the kernel values are precomputed
  param.C = p.c;
  param.cache_size = 64;
  param.eps = 1e-3;
  param.shrinking = 1;
  param.probability = probability ? 1 : 0;
  return param;
}

// Trains on the rows `indices` of `rows`.
ModelPtr TrainOn(const KernelRows& rows, const std::vector<int>& labels,
                 const std::vector<int>& indices, const SvmParameters& p, bool probability) {
  std::vector<svm_node*> x(indices.size());
  std::vector<double> y(indices.size());
  for (size_t k = 0; k < indices.size(); ++k) {
    x[k] = rows.row(indices[k]);
    y[k] = labels[static_cast<size_t>(indices[k])];
  }
  svm_problem problem{static_cast<int>(indices.size()), y.data(), x.data()};
  const svm_parameter param = CsvcParameters(p, probability);
  if (const char* err = svm_check_parameter(&problem, &param)) {
    throw std::invalid_argument(std::string("libsvm: ") + err);
  }
  SilenceLibsvm();
  return Own(svm_train(&problem, &param));
}

std::string Hex(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

std::vector<double> Steps(double from, double to, double step) {
  std::vector<double> out;
  for (int i = 0;; ++i) {
    const double v = from + i * step;
    if (v > to + step * 1e-6) break;
    out.push_back(std::exp2(v));
  }
  return out;
}

}  // namespace

void LabelledDescriptors::Validate() const {
  if (places.size() < 2) {
    throw std::invalid_argument("classification needs at least two places, got " +
                                std::to_string(places.size()));
  }
  if (static_cast<Eigen::Index>(labels.size()) != descriptors.cols()) {
    throw std::invalid_argument(std::to_string(descriptors.cols()) + " descriptors but " +
                                std::to_string(labels.size()) + " labels");
  }
  std::vector<int> count(places.size(), 0);
  for (size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] < 0 || labels[i] >= static_cast<int>(places.size())) {
      throw std::invalid_argument("descriptor " + std::to_string(i) + " has label " +
                                  std::to_string(labels[i]) + ", not a place index");
    }
    if (!descriptors.col(static_cast<Eigen::Index>(i)).allFinite()) {
      throw std::invalid_argument("descriptor " + std::to_string(i) + " is not finite");
    }
    ++count[static_cast<size_t>(labels[i])];
  }
  if (std::count_if(count.begin(), count.end(), [](int c) { return c > 0; }) < 2) {
    throw std::invalid_argument("classification needs descriptors of at least two places");
  }
}

LabelledDescriptors LabelledDescriptors::Subset(const std::vector<int>& indices) const {
  LabelledDescriptors out;
  out.places = places;
  out.descriptors.resize(descriptors.rows(), static_cast<Eigen::Index>(indices.size()));
  for (size_t k = 0; k < indices.size(); ++k) {
    out.descriptors.col(static_cast<Eigen::Index>(k)) = descriptors.col(indices[k]);
    out.labels.push_back(labels.at(static_cast<size_t>(indices[k])));
  }
  return out;
}

void SvmParameters::Validate() const {
  if (!std::isfinite(c) || c <= 0) {
    throw std::invalid_argument("SVM C must be finite and > 0, got " + std::to_string(c));
  }
  if (!std::isfinite(gamma) || gamma <= 0) {
    throw std::invalid_argument("SVM gamma must be finite and > 0, got " + std::to_string(gamma));
  }
}

void ClassifierOptions::Validate() const {
  const auto range = [](const char* name, double from, double to, double step) {
    if (!std::isfinite(from) || !std::isfinite(to) || !std::isfinite(step) || to < from ||
        step <= 0 || (to - from) / step > 64 || std::abs(from) > 60 || std::abs(to) > 60) {
      throw std::invalid_argument(std::string(name) +
                                  " grid must have from <= to, step > 0, at most 64 steps and "
                                  "|log2| <= 60");
    }
  };
  range("log2 C", log2_c_from, log2_c_to, log2_c_step);
  range("log2 gamma", log2_gamma_from, log2_gamma_to, log2_gamma_step);
  if (folds < 2 || folds > 100) {
    throw std::invalid_argument("folds must be in [2, 100], got " + std::to_string(folds));
  }
}

std::vector<double> ClassifierOptions::CValues() const {
  return Steps(log2_c_from, log2_c_to, log2_c_step);
}
std::vector<double> ClassifierOptions::GammaScales() const {
  return Steps(log2_gamma_from, log2_gamma_to, log2_gamma_step);
}

double MedianGamma(const Eigen::MatrixXf& x) {
  const Eigen::Index n = x.cols();
  std::vector<double> d2;
  const Eigen::Index pairs = std::min<Eigen::Index>(n, 1024);
  for (Eigen::Index i = 0; i < pairs; ++i) {
    const Eigen::Index j = (i + std::max<Eigen::Index>(1, n / 2)) % n;
    if (j != i) d2.push_back((x.col(i) - x.col(j)).squaredNorm());
  }
  if (d2.empty()) return 1.0;
  const double median = UpperMedian(std::move(d2));
  return median > 1e-20 ? 1.0 / median : 1.0;
}

std::vector<int> AssignFolds(const std::vector<int>& labels, int folds, uint32_t seed) {
  if (folds < 1) throw std::invalid_argument("folds must be >= 1");
  std::mt19937 rng(seed);
  std::vector<int> fold(labels.size(), 0);
  const int max_label = labels.empty() ? -1 : *std::max_element(labels.begin(), labels.end());
  int next = 0;  // continue the round-robin across places, so small places spread too
  for (int p = 0; p <= max_label; ++p) {
    std::vector<int> members;
    for (size_t i = 0; i < labels.size(); ++i) {
      if (labels[i] == p) members.push_back(static_cast<int>(i));
    }
    std::shuffle(members.begin(), members.end(), rng);
    for (int i : members) {
      fold[static_cast<size_t>(i)] = next;
      next = (next + 1) % folds;
    }
  }
  return fold;
}

GridSearchResult GridSearch(const LabelledDescriptors& data, const ClassifierOptions& options) {
  data.Validate();
  options.Validate();
  const int n = data.size();
  const std::vector<int> fold = AssignFolds(data.labels, options.folds, options.seed);
  const Eigen::MatrixXf d2 = SquaredDistances(data.descriptors, data.descriptors);
  GridSearchResult result;
  result.gamma0 = MedianGamma(data.descriptors);
  KernelRows rows(n);
  result.best_accuracy = -1.0;
  for (double scale : options.GammaScales()) {
    const double gamma = result.gamma0 * scale;
    rows.Fill(d2, gamma);
    for (double c : options.CValues()) {
      int correct = 0;
      for (int f = 0; f < options.folds; ++f) {
        std::vector<int> train, held_out;
        for (int i = 0; i < n; ++i)
          (fold[static_cast<size_t>(i)] == f ? held_out : train).push_back(i);
        if (held_out.empty() || train.empty()) continue;
        const ModelPtr model = TrainOn(rows, data.labels, train, {c, gamma}, false);
        for (int h : held_out) {
          correct += static_cast<int>(svm_predict(model.get(), rows.row(h))) ==
                     data.labels[static_cast<size_t>(h)];
        }
      }
      const double accuracy = static_cast<double>(correct) / n;
      result.points.push_back({c, gamma, accuracy});
      // Strictly better only: the grid is walked from small γ and C, so ties keep the simpler.
      if (accuracy > result.best_accuracy) {
        result.best_accuracy = accuracy;
        result.best = {c, gamma};
      }
    }
  }
  return result;
}

int Decide(const Eigen::VectorXd& probabilities, double tau) {
  if (probabilities.size() == 0) return kUnclassified;
  Eigen::Index best = 0;
  probabilities.maxCoeff(&best);  // first maximum: the lower index on ties
  return probabilities[best] >= tau ? static_cast<int>(best) : kUnclassified;
}

PlaceClassifier PlaceClassifier::Train(const LabelledDescriptors& data, const SvmParameters& params,
                                       uint32_t seed) {
  data.Validate();
  params.Validate();
  const int n = data.size();
  KernelRows rows(n);
  rows.Fill(SquaredDistances(data.descriptors, data.descriptors), params.gamma);
  std::vector<int> all(static_cast<size_t>(n));
  std::iota(all.begin(), all.end(), 0);
  // libsvm shuffles the internal folds of its probability fit with rand().
  std::srand(seed);
  const ModelPtr model = TrainOn(rows, data.labels, all, params, true);

  PlaceClassifier out;
  out.places_ = data.places;
  out.params_ = params;
  const int k = model->nr_class, l = model->l;
  out.support_.resize(data.descriptors.rows(), l);
  for (int s = 0; s < l; ++s) {
    const auto serial = static_cast<Eigen::Index>(model->SV[s][0].value);  // 1-based
    out.support_.col(s) = data.descriptors.col(serial - 1);
  }
  out.class_sv_count_.assign(model->nSV, model->nSV + k);
  out.class_label_.assign(model->label, model->label + k);
  out.sv_coef_.resize(std::max(k - 1, 0), l);
  for (int r = 0; r < k - 1; ++r) {
    for (int s = 0; s < l; ++s) out.sv_coef_(r, s) = model->sv_coef[r][s];
  }
  const int pairs = k * (k - 1) / 2;
  out.rho_.assign(model->rho, model->rho + pairs);
  out.prob_a_.assign(model->probA, model->probA + pairs);
  out.prob_b_.assign(model->probB, model->probB + pairs);
  out.CheckAndPrepare();
  return out;
}

void PlaceClassifier::CheckAndPrepare() {
  const int k = static_cast<int>(class_label_.size());
  const auto l = support_.cols();
  const size_t pairs = static_cast<size_t>(k * (k - 1) / 2);
  if (places_.size() < 2) throw std::invalid_argument("classifier: fewer than two places");
  params_.Validate();
  if (k < 2 || static_cast<int>(class_sv_count_.size()) != k) {
    throw std::invalid_argument("classifier: needs at least two classes with SV counts");
  }
  for (int label : class_label_) {
    if (label < 0 || label >= static_cast<int>(places_.size())) {
      throw std::invalid_argument("classifier: class label " + std::to_string(label) +
                                  " is not a place index");
    }
  }
  if (std::accumulate(class_sv_count_.begin(), class_sv_count_.end(), Eigen::Index{0}) != l ||
      std::any_of(class_sv_count_.begin(), class_sv_count_.end(), [](int c) { return c < 0; })) {
    throw std::invalid_argument("classifier: per-class support vector counts do not add up");
  }
  if (sv_coef_.rows() != k - 1 || sv_coef_.cols() != l || rho_.size() != pairs ||
      prob_a_.size() != pairs || prob_b_.size() != pairs) {
    throw std::invalid_argument("classifier: coefficient arrays of the wrong size");
  }
  const auto finite = [](const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  if (!support_.allFinite() || !sv_coef_.allFinite() || !finite(rho_) || !finite(prob_a_) ||
      !finite(prob_b_)) {
    throw std::invalid_argument("classifier: non-finite values");
  }
  support_sq_norm_ = support_.colwise().squaredNorm().transpose();
}

Eigen::VectorXd PlaceClassifier::Probabilities(const Eigen::VectorXf& descriptor) const {
  if (descriptor.size() != support_.rows()) {
    throw std::invalid_argument("descriptor of dimension " + std::to_string(descriptor.size()) +
                                ", the classifier expects " + std::to_string(support_.rows()));
  }
  const int k = static_cast<int>(class_label_.size());
  const int l = static_cast<int>(support_.cols());
  // K(x, s_i) for every support vector at once; libsvm reads them as a precomputed kernel.
  const Eigen::VectorXf d2 = (support_sq_norm_.array() + descriptor.squaredNorm() -
                              2.0f * (support_.transpose() * descriptor).array())
                                 .max(0.0f)
                                 .matrix();
  std::vector<svm_node> x(static_cast<size_t>(l) + 2);
  x[0] = {0, 0.0};
  for (int s = 0; s < l; ++s)
    x[static_cast<size_t>(s) + 1] = {s + 1, std::exp(-params_.gamma * d2[s])};
  x[static_cast<size_t>(l) + 1] = {-1, 0.0};

  // A read-only view of the model for libsvm: support vector s is "training sample s+1".
  std::vector<svm_node> sv_nodes(static_cast<size_t>(l) * 2);
  std::vector<svm_node*> sv(static_cast<size_t>(l));
  for (int s = 0; s < l; ++s) {
    sv_nodes[2 * static_cast<size_t>(s)] = {0, static_cast<double>(s + 1)};
    sv_nodes[2 * static_cast<size_t>(s) + 1] = {-1, 0.0};
    sv[static_cast<size_t>(s)] = &sv_nodes[2 * static_cast<size_t>(s)];
  }
  std::vector<std::vector<double>> coef_rows(static_cast<size_t>(k - 1));
  std::vector<double*> coef(static_cast<size_t>(k - 1));
  for (int r = 0; r < k - 1; ++r) {
    coef_rows[static_cast<size_t>(r)].resize(static_cast<size_t>(l));
    for (int s = 0; s < l; ++s)
      coef_rows[static_cast<size_t>(r)][static_cast<size_t>(s)] = sv_coef_(r, s);
    coef[static_cast<size_t>(r)] = coef_rows[static_cast<size_t>(r)].data();
  }
  std::vector<double> rho = rho_, prob_a = prob_a_, prob_b = prob_b_;
  std::vector<int> label = class_label_, nsv = class_sv_count_;
  svm_model model{};
  model.param = CsvcParameters(params_, true);
  model.nr_class = k;
  model.l = l;
  model.SV = sv.data();
  model.sv_coef = coef.data();
  model.rho = rho.data();
  model.probA = prob_a.data();
  model.probB = prob_b.data();
  model.sv_indices = nullptr;
  model.label = label.data();
  model.nSV = nsv.data();
  model.free_sv = 0;

  std::vector<double> estimates(static_cast<size_t>(k));
  svm_predict_probability(&model, x.data(), estimates.data());
  Eigen::VectorXd out = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(places_.size()));
  for (int c = 0; c < k; ++c)
    out[class_label_[static_cast<size_t>(c)]] = estimates[static_cast<size_t>(c)];
  return out;
}

int PlaceClassifier::Classify(const Eigen::VectorXf& descriptor, double tau) const {
  return Decide(Probabilities(descriptor), tau);
}

std::string PlaceClassifier::Serialize() const {
  std::ostringstream out;
  const auto list = [&](const char* key, const std::vector<double>& v) {
    out << key;
    for (double x : v) out << ' ' << Hex(x);
    out << '\n';
  };
  out << "tsc-place-classifier 1\n";
  out << "places " << places_.size() << '\n';
  for (const std::string& p : places_) out << "place " << p << '\n';
  out << "c " << Hex(params_.c) << "\ngamma " << Hex(params_.gamma) << '\n';
  out << "dim " << support_.rows() << '\n';
  out << "classes " << class_label_.size() << '\n';
  for (size_t c = 0; c < class_label_.size(); ++c) {
    out << "class " << class_label_[c] << ' ' << class_sv_count_[c] << '\n';
  }
  list("rho", rho_);
  list("prob_a", prob_a_);
  list("prob_b", prob_b_);
  out << "support_vectors " << support_.cols() << '\n';
  for (Eigen::Index s = 0; s < support_.cols(); ++s) {
    out << "sv";
    for (Eigen::Index r = 0; r < sv_coef_.rows(); ++r) out << ' ' << Hex(sv_coef_(r, s));
    out << " :";
    for (Eigen::Index d = 0; d < support_.rows(); ++d) out << ' ' << Hex(support_(d, s));
    out << '\n';
  }
  out << "end\n";
  return out.str();
}

PlaceClassifier PlaceClassifier::Deserialize(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  const auto fail = [&](const std::string& what) -> std::invalid_argument {
    return std::invalid_argument("classifier line " + std::to_string(line_no) + ": " + what);
  };
  // Next line, which must start with `key`; returns the rest after one space.
  const auto expect = [&](const std::string& key) {
    if (!std::getline(in, line)) {
      ++line_no;
      throw fail("ends early, expected '" + key + "'");
    }
    ++line_no;
    if (line.compare(0, key.size(), key) != 0 ||
        (line.size() > key.size() && line[key.size()] != ' ')) {
      throw fail("expected '" + key + "', got '" + line.substr(0, 40) + "'");
    }
    return line.size() > key.size() ? line.substr(key.size() + 1) : std::string();
  };
  const auto number = [&](const std::string& s) {
    const char* begin = s.c_str();
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin || *end != '\0' || !std::isfinite(v)) throw fail("bad number '" + s + "'");
    return v;
  };
  const auto count = [&](const std::string& s, long max) {
    const double v = number(s);
    if (v < 0 || v > static_cast<double>(max) || v != std::floor(v)) {
      throw fail("bad count '" + s + "'");
    }
    return static_cast<int>(v);
  };
  const auto numbers = [&](const std::string& s, size_t expected) {
    std::istringstream words(s);
    std::vector<double> v;
    std::string w;
    while (words >> w) v.push_back(number(w));
    if (v.size() != expected) {
      throw fail("expected " + std::to_string(expected) + " numbers, got " +
                 std::to_string(v.size()));
    }
    return v;
  };

  if (expect("tsc-place-classifier") != "1") throw fail("unknown classifier format version");
  PlaceClassifier out;
  const int n_places = count(expect("places"), 1 << 20);
  for (int p = 0; p < n_places; ++p) out.places_.push_back(expect("place"));
  out.params_.c = number(expect("c"));
  out.params_.gamma = number(expect("gamma"));
  const int dim = count(expect("dim"), 1 << 24);
  const int k = count(expect("classes"), 1 << 20);
  for (int c = 0; c < k; ++c) {
    const std::vector<double> v = numbers(expect("class"), 2);
    out.class_label_.push_back(static_cast<int>(v[0]));
    out.class_sv_count_.push_back(static_cast<int>(v[1]));
  }
  const size_t pairs = static_cast<size_t>(k) * static_cast<size_t>(std::max(k - 1, 0)) / 2;
  out.rho_ = numbers(expect("rho"), pairs);
  out.prob_a_ = numbers(expect("prob_a"), pairs);
  out.prob_b_ = numbers(expect("prob_b"), pairs);
  const int l = count(expect("support_vectors"), 1 << 24);
  out.support_.resize(dim, l);
  out.sv_coef_.resize(std::max(k - 1, 0), l);
  for (int s = 0; s < l; ++s) {
    const std::string rest = expect("sv");
    const size_t colon = rest.find(':');
    if (colon == std::string::npos) throw fail("support vector without ':'");
    const std::vector<double> coef = numbers(rest.substr(0, colon), static_cast<size_t>(k - 1));
    const std::vector<double> values = numbers(rest.substr(colon + 1), static_cast<size_t>(dim));
    for (int r = 0; r < k - 1; ++r) out.sv_coef_(r, s) = coef[static_cast<size_t>(r)];
    for (int d = 0; d < dim; ++d)
      out.support_(d, s) = static_cast<float>(values[static_cast<size_t>(d)]);
  }
  expect("end");
  try {
    out.CheckAndPrepare();
  } catch (const std::invalid_argument& e) {
    throw fail(e.what());
  }
  return out;
}

Eigen::MatrixXd CrossValidatedProbabilities(const LabelledDescriptors& data,
                                            const SvmParameters& params, int folds, uint32_t seed) {
  data.Validate();
  if (folds < 2) throw std::invalid_argument("folds must be >= 2, got " + std::to_string(folds));
  const std::vector<int> fold = AssignFolds(data.labels, folds, seed);
  Eigen::MatrixXd out =
      Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(data.places.size()), data.size());
  for (int f = 0; f < folds; ++f) {
    std::vector<int> train, held_out;
    for (int i = 0; i < data.size(); ++i) {
      (fold[static_cast<size_t>(i)] == f ? held_out : train).push_back(i);
    }
    if (held_out.empty()) continue;
    const PlaceClassifier model = PlaceClassifier::Train(data.Subset(train), params, seed);
    for (int h : held_out) out.col(h) = model.Probabilities(data.descriptors.col(h));
  }
  return out;
}

}  // namespace tsc
