#include "core/classify/place_classifier.h"

#include <gtest/gtest.h>

#include <random>

#include "core/classify/classification_score.h"

namespace tsc {
namespace {

// `per_place` points around each of `places` centres that lie `spread` apart in `dim`
// dimensions, with unit-variance-scaled noise `noise`: separable when noise << spread.
LabelledDescriptors Clusters(int places, int per_place, int dim, float spread, float noise,
                             uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  LabelledDescriptors data;
  Eigen::MatrixXf centres(dim, places);
  for (int p = 0; p < places; ++p) {
    data.places.push_back("place" + std::to_string(p));
    centres.col(p) = Eigen::VectorXf::Zero(dim);
    centres(p % dim, p) = spread;  // orthogonal centres
  }
  data.descriptors.resize(dim, places * per_place);
  for (int p = 0; p < places; ++p) {
    for (int j = 0; j < per_place; ++j) {
      const int col = p * per_place + j;
      for (int d = 0; d < dim; ++d) data.descriptors(d, col) = centres(d, p) + noise * normal(rng);
      data.labels.push_back(p);
    }
  }
  return data;
}

class PlaceClassifierTest : public ::testing::Test {
 protected:
  PlaceClassifierTest()
      : train_(Clusters(4, 30, 8, 1.0f, 0.08f, 1)),
        test_(Clusters(4, 20, 8, 1.0f, 0.08f, 2)),
        dut_(PlaceClassifier::Train(train_, GridSearch(train_, {}).best)) {}
  LabelledDescriptors train_, test_;
  PlaceClassifier dut_;
};

TEST_F(PlaceClassifierTest, SeparableToyProblemIsClassifiedPerfectly) {
  const GridSearchResult grid = GridSearch(train_, {});
  EXPECT_EQ(grid.best_accuracy, 1.0);
  EXPECT_EQ(grid.points.size(),
            ClassifierOptions{}.CValues().size() * ClassifierOptions{}.GammaScales().size());
  std::vector<int> decided;
  for (int i = 0; i < test_.size(); ++i)
    decided.push_back(dut_.Classify(test_.descriptors.col(i), 0.0));
  const ClassificationScore s = ScoreClassification(test_.labels, decided, 4);
  EXPECT_EQ(s.correct, test_.size());
  EXPECT_EQ(s.imageclef, test_.size());
  EXPECT_EQ(s.precision, 1.0);
  EXPECT_EQ(s.recall, 1.0);
  for (int p = 0; p < 4; ++p) EXPECT_EQ(s.confusion(p, p), 20);
}

TEST_F(PlaceClassifierTest, ProbabilitiesSumToOneOverAllPlaces) {
  const Eigen::VectorXd xi = dut_.Probabilities(test_.descriptors.col(0));
  ASSERT_EQ(xi.size(), 4);
  EXPECT_NEAR(xi.sum(), 1.0, 1e-9);
  EXPECT_GT(xi[0], 0.5);  // test column 0 is of place 0
}

TEST_F(PlaceClassifierTest, DecisionRuleLeavesFramesBelowTauUnclassified) {
  // Halfway between places 0 and 1: no place is confident.
  Eigen::VectorXf between = Eigen::VectorXf::Zero(8);
  between[0] = 0.5f;
  between[1] = 0.5f;
  const Eigen::VectorXd xi = dut_.Probabilities(between);
  EXPECT_LT(xi.maxCoeff(), 0.9);
  EXPECT_EQ(dut_.Classify(between, 0.9), kUnclassified);
  // Every frame: unclassified exactly when its largest ξ is below τ.
  for (double tau : {0.3, 0.6, 0.95}) {
    for (int i = 0; i < test_.size(); ++i) {
      const Eigen::VectorXd p = dut_.Probabilities(test_.descriptors.col(i));
      const int beta = dut_.Classify(test_.descriptors.col(i), tau);
      EXPECT_EQ(beta == kUnclassified, p.maxCoeff() < tau) << "tau " << tau << " frame " << i;
    }
  }
}

TEST(DecideTest, ArgMaxAtOrAboveTauElseUnclassified) {
  const Eigen::Vector3d xi(0.3, 0.5, 0.2);
  EXPECT_EQ(Decide(xi, 0.0), 1);
  EXPECT_EQ(Decide(xi, 0.5), 1);
  EXPECT_EQ(Decide(xi, 0.51), kUnclassified);
  EXPECT_EQ(Decide(Eigen::Vector2d(0.5, 0.5), 0.5), 0);  // tie: lower index
}

TEST(ClassificationScoreTest, ImageClefScoreOfAHandMadeList) {
  // correct, wrong, correct, unclassified, correct, unknown place classified (wrong),
  // unknown place unclassified.
  const std::vector<int> truth = {0, 0, 1, 1, 2, kUnknownPlace, kUnknownPlace};
  const std::vector<int> decided = {0, 1, 1, kUnclassified, 2, 0, kUnclassified};
  const ClassificationScore s = ScoreClassification(truth, decided, 3);
  EXPECT_EQ(s.correct, 3);
  EXPECT_EQ(s.wrong, 2);
  EXPECT_EQ(s.unclassified, 2);
  EXPECT_EQ(s.imageclef, 1);
  EXPECT_DOUBLE_EQ(s.precision, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(s.recall, 3.0 / 7.0);
  EXPECT_EQ(s.confusion(0, 1), 1);
  EXPECT_EQ(s.confusion(1, 3), 1);              // unclassified column
  EXPECT_EQ(s.confusion(3, 0), 1);              // unknown-place row
  EXPECT_DOUBLE_EQ(s.place_precision[0], 0.5);  // decided 0 twice, once right
  EXPECT_DOUBLE_EQ(s.place_recall[1], 0.5);
  EXPECT_DOUBLE_EQ(s.place_recall[2], 1.0);
  EXPECT_THROW(ScoreClassification({0}, {3}, 3), std::invalid_argument);
}

TEST(ClassificationScoreTest, SweepTauTradesRecallForPrecision) {
  Eigen::MatrixXd xi(2, 3);
  xi << 0.9, 0.4, 0.6,  //
      0.1, 0.6, 0.4;
  const std::vector<int> truth = {0, 0, 1};  // frame 0 sure and right, 1 and 2 unsure and wrong
  const std::vector<TauPoint> curve = SweepTau(truth, xi, {0.0, 0.7});
  EXPECT_EQ(curve[0].imageclef, 1 - 2);
  EXPECT_DOUBLE_EQ(curve[0].precision, 1.0 / 3.0);
  EXPECT_EQ(curve[1].imageclef, 1);
  EXPECT_EQ(curve[1].unclassified, 2);
  EXPECT_DOUBLE_EQ(curve[1].precision, 1.0);
  EXPECT_DOUBLE_EQ(curve[1].recall, 1.0 / 3.0);
}

TEST_F(PlaceClassifierTest, SaveLoadRoundTripGivesIdenticalPredictions) {
  const std::string text = dut_.Serialize();
  const PlaceClassifier loaded = PlaceClassifier::Deserialize(text);
  EXPECT_EQ(loaded.Serialize(), text);
  EXPECT_EQ(loaded.places(), dut_.places());
  EXPECT_EQ(loaded.num_support_vectors(), dut_.num_support_vectors());
  for (int i = 0; i < test_.size(); ++i) {
    const Eigen::VectorXd a = dut_.Probabilities(test_.descriptors.col(i));
    const Eigen::VectorXd b = loaded.Probabilities(test_.descriptors.col(i));
    EXPECT_EQ(a, b) << "frame " << i;  // bit for bit
  }
}

TEST_F(PlaceClassifierTest, DeserializeNamesTheBadLine) {
  std::string text = dut_.Serialize();
  const size_t at = text.find("gamma ");
  text.replace(at, 6, "gamma x");
  try {
    PlaceClassifier::Deserialize(text);
    FAIL() << "accepted a corrupt model";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 8"), std::string::npos) << e.what();
  }
  EXPECT_THROW(PlaceClassifier::Deserialize(dut_.Serialize().substr(0, 300)),
               std::invalid_argument);
  EXPECT_THROW(dut_.Probabilities(Eigen::VectorXf::Zero(3)), std::invalid_argument);
}

TEST(PlaceClassifierTrainTest, TrainingIsRepeatable) {
  const LabelledDescriptors data = Clusters(3, 15, 6, 1.0f, 0.3f, 7);
  const SvmParameters params{4.0, 1.0};
  EXPECT_EQ(PlaceClassifier::Train(data, params, 3).Serialize(),
            PlaceClassifier::Train(data, params, 3).Serialize());
}

TEST(PlaceClassifierTrainTest, BadInputIsRefused) {
  LabelledDescriptors data = Clusters(2, 5, 4, 1.0f, 0.1f, 1);
  data.labels[3] = 7;
  EXPECT_THROW(PlaceClassifier::Train(data, {1.0, 1.0}), std::invalid_argument);
  data.labels[3] = 0;
  EXPECT_THROW(PlaceClassifier::Train(data, {0.0, 1.0}), std::invalid_argument);
  ClassifierOptions o;
  o.folds = 1;
  EXPECT_THROW(GridSearch(data, o), std::invalid_argument);
}

TEST(AssignFoldsTest, EveryPlaceIsSpreadOverTheFolds) {
  std::vector<int> labels;
  for (int p = 0; p < 3; ++p) labels.insert(labels.end(), 10, p);
  const std::vector<int> fold = AssignFolds(labels, 5, 1);
  for (int p = 0; p < 3; ++p) {
    std::vector<int> per_fold(5, 0);
    for (size_t i = 0; i < labels.size(); ++i) per_fold[fold[i]] += labels[i] == p;
    for (int f = 0; f < 5; ++f) EXPECT_EQ(per_fold[f], 2) << "place " << p << " fold " << f;
  }
}

TEST(CrossValidatedProbabilitiesTest, HeldOutFramesOfSeparablePlacesAreRight) {
  const LabelledDescriptors data = Clusters(3, 20, 6, 1.0f, 0.08f, 3);
  const Eigen::MatrixXd xi = CrossValidatedProbabilities(data, {8.0, 2.0}, 5, 1);
  for (int i = 0; i < data.size(); ++i) EXPECT_EQ(Decide(xi.col(i), 0.0), data.labels[i]);
}

}  // namespace
}  // namespace tsc
