#pragma once
// `tsc classify`: supervised place classification of thesis chapter 2 over dataset folders
// (core/classify). This part reads datasets into labelled bubble descriptors, keeps models in
// files and scores classifiers; tools/classify_command.cc is the command line.

#include <filesystem>
#include <string>
#include <vector>

#include "core/classify/classification_score.h"
#include "core/classify/place_classifier.h"
#include "core/pipeline/pipeline.h"

namespace tsc {

/// "L1".."L5" are the thesis' feature sets of section 2.3 (no intensity: N_I = 300, 600, 100,
/// 400, 700); "L2+I" etc. add intensity. Throws std::invalid_argument naming the bad name.
FeatureSet ClassifyFeatureSet(const std::string& name);

/// The bubble descriptors of every labelled frame of some datasets, in dataset then frame
/// order. Frames with an empty label (doorways, transitions) are skipped and counted.
struct LabelledFrames {
  std::vector<std::string> labels;
  Eigen::MatrixXf descriptors;        ///< dim x frames
  std::vector<double> descriptor_ms;  ///< per frame: bubble surface + descriptor
  int unlabelled = 0;                 ///< frames skipped
  int size() const { return static_cast<int>(labels.size()); }
};

/// Reads every dataset and computes the descriptors with `options` (features, bubble.*,
/// descriptor.*). Throws DatasetError naming the dataset or frame at fault: no groundtruth.csv,
/// no depth/ when the features need depth, an unreadable frame.
LabelledFrames ReadLabelledFrames(const std::vector<std::filesystem::path>& datasets,
                                  const PipelineOptions& options);

/// Places = the sorted distinct labels; each frame labelled with its place index.
LabelledDescriptors ToLabelledDescriptors(const LabelledFrames& frames);

/// A trained classifier with the descriptor settings it was trained with.
struct ClassifierModel {
  PipelineOptions descriptor;  ///< features, surface and descriptor options used
  PlaceClassifier classifier;
};

/// Model file: "tsc-classify-model 1", the bubble.* and descriptor.* keys as "key = value",
/// then PlaceClassifier::Serialize(). Throws std::runtime_error naming the file.
void SaveModel(const std::filesystem::path& file, const ClassifierModel& model);
/// Throws std::runtime_error naming the file (and line) when it is missing or malformed.
ClassifierModel LoadModel(const std::filesystem::path& file);

/// Scores of one classifier on one test set.
struct ClassifyRun {
  std::string name;      ///< model file stem or feature set
  std::string features;  ///< e.g. "L5-I"
  std::vector<std::string> places;
  double tau = 0.5;
  ClassificationScore score;    ///< at tau
  std::vector<TauPoint> curve;  ///< DefaultTaus()
  int best_imageclef = 0;       ///< over the curve
  double best_tau = 0.0;
  double descriptor_ms_median = 0.0;
  double classify_ms_median = 0.0;  ///< ξ and decision per frame
  int frames_unknown_place = 0;     ///< test frames of places the model was not trained on
};

/// Truth of `labels` against `places`: the place index, or kUnknownPlace.
std::vector<int> TruthIndices(const std::vector<std::string>& labels,
                              const std::vector<std::string>& places);

/// Scores probabilities (rows places, columns frames) against the labels at `tau` and over τ.
ClassifyRun ScoreRun(std::string name, const std::vector<std::string>& places,
                     const std::vector<std::string>& labels, const Eigen::MatrixXd& probabilities,
                     double tau);

/// Plain-text report: totals, per-place precision/recall, confusion matrix, τ sweep.
std::string FormatRun(const ClassifyRun& run);
/// One JSON object (no newline).
std::string RunToJson(const ClassifyRun& run);

}  // namespace tsc
