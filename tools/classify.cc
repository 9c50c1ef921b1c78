#include "tools/classify.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "tools/eval.h"
#include "tools/events_json.h"
#include "tools/frame_view.h"

namespace tsc {
namespace fs = std::filesystem;
namespace {

constexpr const char* kModelMagic = "tsc-classify-model 1";

// The configuration keys that decide a descriptor: what a model must remember.
bool IsDescriptorKey(const std::string& key) {
  return key.rfind("bubble.", 0) == 0 || key.rfind("descriptor.", 0) == 0;
}

std::string Trimmed(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

std::string Fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

FeatureSet ClassifyFeatureSet(const std::string& name) {
  const std::string t = Trimmed(name);
  if (t.size() == 2 && (t[0] == 'L' || t[0] == 'l') && t[1] >= '1' && t[1] <= '5') {
    return FeatureSet::Thesis(t[1] - '0', false);
  }
  return FeatureSet::Parse(t);
}

LabelledFrames ReadLabelledFrames(const std::vector<fs::path>& datasets,
                                  const PipelineOptions& options) {
  // Not PipelineOptions::Validate(): classification needs no intensity (place detection does).
  options.surface.Validate();
  options.descriptor.Validate();
  LabelledFrames out;
  std::vector<Eigen::VectorXf> columns;
  for (const fs::path& folder : datasets) {
    const Dataset dataset = Dataset::Open(folder);
    if (dataset.labels().empty()) {
      throw DatasetError(folder.string() + ": no groundtruth.csv with place labels");
    }
    if (options.features.NeedsDepth() && !dataset.has_depth()) {
      throw DatasetError(folder.string() + ": features " + options.features.ToString() +
                         " need depth, but the dataset has no depth/ folder");
    }
    BubbleSurface surface(options.features, dataset.camera(), options.surface);
    const DescriptorComputer computer(surface.grid(), options.descriptor);
    for (int i = 0; i < dataset.size(); ++i) {
      const std::string& label = dataset.labels()[static_cast<size_t>(i)];
      if (label.empty()) {
        ++out.unlabelled;
        continue;
      }
      const TimedView frame = DescribeFrame(dataset, i, surface, computer);
      columns.push_back(frame.view.descriptor.values());
      out.descriptor_ms.push_back(frame.descriptor_ms);
      out.labels.push_back(label);
    }
  }
  if (columns.empty()) throw DatasetError("no labelled frames in the datasets given");
  out.descriptors.resize(columns.front().size(), static_cast<Eigen::Index>(columns.size()));
  for (size_t j = 0; j < columns.size(); ++j) {
    out.descriptors.col(static_cast<Eigen::Index>(j)) = columns[j];
  }
  return out;
}

LabelledDescriptors ToLabelledDescriptors(const LabelledFrames& frames) {
  LabelledDescriptors out;
  out.places = frames.labels;
  std::sort(out.places.begin(), out.places.end());
  out.places.erase(std::unique(out.places.begin(), out.places.end()), out.places.end());
  out.descriptors = frames.descriptors;
  for (const std::string& label : frames.labels) {
    out.labels.push_back(static_cast<int>(
        std::lower_bound(out.places.begin(), out.places.end(), label) - out.places.begin()));
  }
  return out;
}

void SaveModel(const fs::path& file, const ClassifierModel& model) {
  std::ostringstream text;
  text << kModelMagic << '\n';
  const Settings settings{model.descriptor, DaemonOptions{}};
  for (const ConfigKey& k : ConfigTable()) {
    if (IsDescriptorKey(k.key)) text << k.key << " = " << k.get(settings) << '\n';
  }
  text << model.classifier.Serialize();
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << text.str();
  out.close();
  if (!out) throw std::runtime_error(file.string() + ": cannot write the model");
}

ClassifierModel LoadModel(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot read the model");
  std::string line;
  int line_no = 1;
  if (!std::getline(in, line) || Trimmed(line) != kModelMagic) {
    throw std::runtime_error(file.string() + ": not a tsc classify model (first line is not '" +
                             kModelMagic + "')");
  }
  Settings settings;
  std::string rest;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.rfind("tsc-place-classifier", 0) == 0) {
      std::ostringstream tail;
      tail << line << '\n' << in.rdbuf();
      rest = tail.str();
      break;
    }
    const size_t eq = line.find('=');
    const ConfigKey* key =
        eq == std::string::npos ? nullptr : FindConfigKey(Trimmed(line.substr(0, eq)));
    if (key == nullptr || !IsDescriptorKey(key->key)) {
      throw std::runtime_error(file.string() + ":" + std::to_string(line_no) +
                               ": expected 'bubble.* = value' or 'descriptor.* = value', got '" +
                               line.substr(0, 60) + "'");
    }
    try {
      key->set(settings, Trimmed(line.substr(eq + 1)));
    } catch (const std::exception& e) {
      throw std::runtime_error(file.string() + ":" + std::to_string(line_no) + ": " + key->key +
                               ": " + e.what());
    }
  }
  if (rest.empty()) throw std::runtime_error(file.string() + ": no classifier in the model");
  try {
    return {settings.pipeline, PlaceClassifier::Deserialize(rest)};
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(file.string() + ": " + e.what() + " (counted from line " +
                             std::to_string(line_no) + ")");
  }
}

std::vector<int> TruthIndices(const std::vector<std::string>& labels,
                              const std::vector<std::string>& places) {
  std::map<std::string, int> index;
  for (size_t p = 0; p < places.size(); ++p) index[places[p]] = static_cast<int>(p);
  std::vector<int> out;
  for (const std::string& l : labels) {
    const auto it = index.find(l);
    out.push_back(it == index.end() ? kUnknownPlace : it->second);
  }
  return out;
}

ClassifyRun ScoreRun(std::string name, const std::vector<std::string>& places,
                     const std::vector<std::string>& labels, const Eigen::MatrixXd& probabilities,
                     double tau) {
  ClassifyRun run;
  run.name = std::move(name);
  run.places = places;
  run.tau = tau;
  const std::vector<int> truth = TruthIndices(labels, places);
  run.frames_unknown_place =
      static_cast<int>(std::count(truth.begin(), truth.end(), kUnknownPlace));
  std::vector<int> decided;
  for (Eigen::Index i = 0; i < probabilities.cols(); ++i) {
    decided.push_back(Decide(probabilities.col(i), tau));
  }
  run.score = ScoreClassification(truth, decided, static_cast<int>(places.size()));
  run.curve = SweepTau(truth, probabilities, DefaultTaus());
  run.best_imageclef = run.curve.front().imageclef;
  run.best_tau = run.curve.front().tau;
  for (const TauPoint& p : run.curve) {
    if (p.imageclef > run.best_imageclef) run.best_imageclef = p.imageclef, run.best_tau = p.tau;
  }
  return run;
}

std::string FormatRun(const ClassifyRun& r) {
  std::ostringstream out;
  const ClassificationScore& s = r.score;
  out << r.name << " (" << r.features << "): " << s.frames << " frames, tau " << Fixed(r.tau, 2)
      << ": ImageCLEF score " << s.imageclef << " (" << s.correct << " correct, " << s.wrong
      << " wrong, " << s.unclassified << " unclassified), precision " << Fixed(s.precision, 3)
      << ", recall " << Fixed(s.recall, 3) << "\n";
  out << "  best ImageCLEF score " << r.best_imageclef << " at tau " << Fixed(r.best_tau, 2)
      << "; median per frame " << Fixed(r.descriptor_ms_median, 2) << " ms descriptor";
  if (r.classify_ms_median >= 0)
    out << " + " << Fixed(r.classify_ms_median, 2) << " ms classification";
  out << "\n";
  if (r.frames_unknown_place > 0) {
    out << "  " << r.frames_unknown_place << " frames of places the model does not know (row "
        << "'other')\n";
  }
  size_t w = 12;
  for (const std::string& p : r.places) w = std::max(w, p.size());
  out << "  place" << std::string(w - 5, ' ') << "  frames  precision  recall\n";
  for (size_t p = 0; p < r.places.size(); ++p) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "  %-*s  %6d  %9.3f  %6.3f\n", static_cast<int>(w),
                  r.places[p].c_str(), s.confusion.row(static_cast<Eigen::Index>(p)).sum(),
                  s.place_precision[p], s.place_recall[p]);
    out << buf;
  }
  out << "  confusion (rows true, columns decided; last column unclassified";
  const bool other = s.confusion.row(s.confusion.rows() - 1).sum() > 0;
  out << (other ? ", last row other places):\n" : "):\n");
  const int rows = static_cast<int>(r.places.size()) + (other ? 1 : 0);
  for (int i = 0; i < rows; ++i) {
    const std::string name =
        i < static_cast<int>(r.places.size()) ? r.places[static_cast<size_t>(i)] : "other";
    char buf[64];
    std::snprintf(buf, sizeof buf, "  %-*s", static_cast<int>(w), name.c_str());
    out << buf;
    for (Eigen::Index j = 0; j < s.confusion.cols(); ++j) {
      std::snprintf(buf, sizeof buf, " %5d", s.confusion(i, j));
      out << buf;
    }
    out << "\n";
  }
  out << "  tau sweep (tau precision recall score):";
  for (const TauPoint& p : r.curve) {
    if (static_cast<int>(std::lround(p.tau * 100)) % 10 != 0) continue;
    out << "  " << Fixed(p.tau, 1) << " " << Fixed(p.precision, 2) << " " << Fixed(p.recall, 2)
        << " " << p.imageclef;
  }
  out << "\n";
  return out.str();
}

std::string RunToJson(const ClassifyRun& r) {
  std::ostringstream out;
  const ClassificationScore& s = r.score;
  out << "{\"name\":" << JsonString(r.name) << ",\"features\":" << JsonString(r.features)
      << ",\"frames\":" << s.frames << ",\"tau\":" << JsonNumber(r.tau)
      << ",\"imageclef\":" << s.imageclef << ",\"correct\":" << s.correct
      << ",\"wrong\":" << s.wrong << ",\"unclassified\":" << s.unclassified
      << ",\"precision\":" << JsonNumber(s.precision) << ",\"recall\":" << JsonNumber(s.recall)
      << ",\"best\":{\"imageclef\":" << r.best_imageclef << ",\"tau\":" << JsonNumber(r.best_tau)
      << "},\"frames_unknown_place\":" << r.frames_unknown_place << ",\"places\":[";
  for (size_t p = 0; p < r.places.size(); ++p) {
    out << (p ? "," : "") << "{\"place\":" << JsonString(r.places[p])
        << ",\"frames\":" << s.confusion.row(static_cast<Eigen::Index>(p)).sum()
        << ",\"precision\":" << JsonNumber(s.place_precision[p])
        << ",\"recall\":" << JsonNumber(s.place_recall[p]) << "}";
  }
  out << "],\"confusion\":[";
  for (Eigen::Index i = 0; i < s.confusion.rows(); ++i) {
    out << (i ? "," : "") << "[";
    for (Eigen::Index j = 0; j < s.confusion.cols(); ++j)
      out << (j ? "," : "") << s.confusion(i, j);
    out << "]";
  }
  out << "],\"pr_curve\":[";
  for (size_t i = 0; i < r.curve.size(); ++i) {
    const TauPoint& p = r.curve[i];
    out << (i ? "," : "") << "[" << JsonNumber(p.tau) << "," << JsonNumber(p.precision) << ","
        << JsonNumber(p.recall) << "," << p.imageclef << "]";
  }
  out << "],\"timing\":{\"descriptor_ms_median\":" << JsonNumber(r.descriptor_ms_median)
      << ",\"classify_ms_median\":" << JsonNumber(r.classify_ms_median) << "}}";
  return out.str();
}

}  // namespace tsc
