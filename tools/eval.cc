#include "tools/eval.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "daemon/settings.h"
#include "tools/events_json.h"
#include "tools/frame_view.h"

namespace tsc {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// One pass of a fresh pipeline over the stored descriptors. `step_ms` (optional) receives the
// time of each ProcessDescriptor call; `status` (optional) the status of each base point.
EvalRun Replay(const Dataset& dataset, const PipelineOptions& options,
               const std::vector<BasePointView>& inputs, const GroundTruth& truth, bool keep_memory,
               std::vector<double>* step_ms, std::vector<BaseStatus>* status) {
  Pipeline pipeline(dataset.camera(), options, PlaceMemory(options.robot, options.memory),
                    TopologicalMap{});
  EvalRun run;
  run.tau_r = options.memory.tau_r;
  std::map<DetectedPlaceIndex, std::vector<int>> frames_of_detected;
  std::vector<Assignment> assignments;
  const auto consume = [&](const FrameResult& r) {
    if (r.has_base && status != nullptr) status->push_back(r.base.status);
    for (const DetectedPlace& d : r.closed_places) {
      auto& frames = frames_of_detected[d.index];
      for (BaseIndex k : d.members) frames.push_back(static_cast<int>(k));
    }
    for (const TransitionRegion& t : r.transitions) run.transitions.push_back(t);
    for (const PlaceEvent& e : r.events) {
      const bool recognized = e.kind == EventKind::kRecognized && !e.partial;
      if (recognized || e.kind == EventKind::kLearned) {
        const std::vector<int>& frames = frames_of_detected.at(e.detected_place);
        assignments.push_back({frames, *e.place, recognized});
        run.detected.push_back({e.detected_place, frames, *e.place, recognized});
        auto& of = run.frames_of[*e.place];
        of.insert(of.end(), frames.begin(), frames.end());
      }
    }
  };
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Clock::time_point t0 = Clock::now();
    FrameResult r;
    try {
      r = pipeline.ProcessDescriptor(inputs[i].descriptor, inputs[i].intensity,
                                     inputs[i].coherence.empty() ? nullptr : &inputs[i].coherence);
    } catch (const std::exception& e) {
      throw std::runtime_error("frame " + std::to_string(i + 1) + " (" +
                               dataset.image_path(static_cast<int>(i)).string() + "): " + e.what());
    }
    if (step_ms != nullptr) step_ms->push_back(Ms(Clock::now() - t0));
    consume(r);
  }
  consume(pipeline.Finish());
  run.recognition = ScoreRecognition(truth, assignments);
  run.learned_places = static_cast<int>(pipeline.memory().places().size());
  run.map = pipeline.map();
  if (keep_memory) run.memory = pipeline.memory();
  return run;
}

}  // namespace

void EvalOptions::Validate() const {
  if (!std::isfinite(sweep_from) || sweep_from < 0) {
    throw std::invalid_argument("sweep: start " + std::to_string(sweep_from) + " must be >= 0");
  }
  if (!std::isfinite(sweep_to) || sweep_to < sweep_from) {
    throw std::invalid_argument("sweep: end " + std::to_string(sweep_to) +
                                " must be >= the start " + std::to_string(sweep_from));
  }
  if (!std::isfinite(sweep_step) || sweep_step < 0) {
    throw std::invalid_argument("sweep: step " + std::to_string(sweep_step) + " must be >= 0");
  }
  if (sweep_step > 0 && (sweep_to - sweep_from) / sweep_step > 1e4) {
    throw std::invalid_argument("sweep: more than 10000 values of tau_r");
  }
}

std::vector<double> EvalOptions::SweepValues() const {
  std::vector<double> out;
  if (sweep_step <= 0) return out;
  for (int i = 0;; ++i) {
    const double v = sweep_from + i * sweep_step;
    if (v > sweep_to + sweep_step * 1e-3) break;
    out.push_back(std::round(v * 1e9) / 1e9);  // 1.0 + 6 * 0.05 prints as 1.3, not 1.2999..
  }
  return out;
}

double MedianOf(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t mid = v.size() / 2;
  return v.size() % 2 == 1 ? v[mid] : (v[mid - 1] + v[mid]) / 2;
}

EvalResult Evaluate(const Dataset& dataset, const PipelineOptions& options,
                    const EvalOptions& eval) {
  options.Validate();
  eval.Validate();
  EvalResult result;
  result.dataset = dataset.folder().string();
  result.frames = dataset.size();
  result.options = options;
  result.eval = eval;
  result.truth.labels = dataset.labels();
  result.truth.revisits = dataset.revisits();

  // Descriptors once per frame.
  BubbleSurface surface(options.features, dataset.camera(), options.surface);
  const DescriptorComputer computer(surface.grid(), options.descriptor);
  std::vector<BasePointView> inputs;
  inputs.reserve(static_cast<size_t>(dataset.size()));
  std::vector<double> descriptor_ms;
  for (int i = 0; i < dataset.size(); ++i) {
    TimedView frame = DescribeFrame(dataset, i, surface, computer);
    inputs.push_back(std::move(frame.view));
    descriptor_ms.push_back(frame.descriptor_ms);
  }

  // The main run at the configured τ_r.
  std::vector<double> step_ms;
  result.main = Replay(dataset, options, inputs, result.truth, true, &step_ms, &result.status);
  std::vector<double> frame_ms(descriptor_ms.size());
  for (size_t i = 0; i < frame_ms.size(); ++i) frame_ms[i] = descriptor_ms[i] + step_ms[i];
  result.descriptor_ms_median = MedianOf(descriptor_ms);
  result.frame_ms_median = MedianOf(frame_ms);
  for (BaseStatus s : result.status) {
    result.good += s == BaseStatus::kGood;
    result.uninformative += s == BaseStatus::kUninformative;
    result.incoherent += s == BaseStatus::kIncoherent;
  }

  // The sweep.
  for (double tau_r : eval.SweepValues()) {
    PipelineOptions o = options;
    o.memory.tau_r = tau_r;
    const EvalRun run = Replay(dataset, o, inputs, result.truth, false, nullptr, nullptr);
    result.pr_curve.push_back({tau_r, run.recognition.precision, run.recognition.recall});
  }
  if (result.pr_curve.empty()) {
    result.pr_curve.push_back(
        {options.memory.tau_r, result.main.recognition.precision, result.main.recognition.recall});
  }
  result.recall_at_full_precision = RecallAtFullPrecision(result.pr_curve);

  if (result.truth.has_labels()) {
    std::vector<std::vector<int>> places;
    for (const EvalDetectedPlace& d : result.main.detected) places.push_back(d.frames);
    result.boundaries = ScoreBoundaries(TrueBoundaries(result.truth.labels),
                                        DetectedBoundaries(places), result.frames);
    result.edges = ScoreMapEdges(result.truth, result.main.frames_of, result.main.map);
  }
  return result;
}

namespace {

// A minimal JSON writer: nested objects and arrays, commas handled, numbers through
// JsonNumber (shortest round trip, null when not finite).
class JsonWriter {
 public:
  explicit JsonWriter(std::ostream& out) : out_(out) {}
  JsonWriter& Key(const std::string& k) {
    Comma();
    out_ << JsonString(k) << ':';
    after_key_ = true;
    return *this;
  }
  JsonWriter& Begin(char bracket) {
    Comma();
    out_ << bracket;
    first_ = true;
    return *this;
  }
  JsonWriter& End(char bracket) {
    out_ << bracket;
    first_ = false;
    return *this;
  }
  JsonWriter& Number(double v) { return Raw(JsonNumber(v)); }
  JsonWriter& Int(long long v) { return Raw(std::to_string(v)); }
  JsonWriter& Bool(bool v) { return Raw(v ? "true" : "false"); }
  JsonWriter& String(const std::string& s) { return Raw(JsonString(s)); }

 private:
  JsonWriter& Raw(const std::string& text) {
    Comma();
    out_ << text;
    return *this;
  }
  void Comma() {
    if (after_key_) {
      after_key_ = false;
    } else if (!first_) {
      out_ << ',';
    }
    first_ = false;
  }
  std::ostream& out_;
  bool first_ = true;
  bool after_key_ = false;
};

}  // namespace

void WriteEvalJson(std::ostream& out, const EvalResult& r) {
  JsonWriter w(out);
  w.Begin('{');
  w.Key("dataset").String(r.dataset);
  w.Key("frames").Int(r.frames);
  w.Key("base_points").Begin('{');
  w.Key("good").Int(r.good).Key("uninformative").Int(r.uninformative);
  w.Key("incoherent").Int(r.incoherent);
  w.End('}');
  w.Key("detected_places").Int(static_cast<long long>(r.main.detected.size()));
  w.Key("learned_places").Int(r.main.learned_places);
  w.Key("ground_truth").Begin('{');
  w.Key("labels").Bool(r.truth.has_labels()).Key("revisits").Bool(r.truth.has_revisits());
  w.End('}');
  if (r.boundaries) {
    const BoundaryScore& b = *r.boundaries;
    w.Key("detection").Begin('{');
    w.Key("boundary_f1").Number(b.f1).Key("precision").Number(b.precision);
    w.Key("recall").Number(b.recall).Key("true_boundaries").Int(b.true_boundaries);
    w.Key("detected_boundaries").Int(b.detected_boundaries).Key("matched").Int(b.matched);
    w.Key("tolerance_frames").Int(b.tolerance);
    w.End('}');
  }
  const RecognitionScore& s = r.main.recognition;
  w.Key("recognition").Begin('{');
  w.Key("tau_r").Number(r.main.tau_r).Key("recognitions").Int(s.recognitions);
  w.Key("correct").Int(s.correct).Key("should_be_recognized").Int(s.should_be_recognized);
  w.Key("precision").Number(s.precision).Key("recall").Number(s.recall);
  w.Key("recall_at_full_precision").Number(r.recall_at_full_precision);
  w.Key("pr_curve").Begin('[');
  for (const PrPoint& p : r.pr_curve) {
    w.Begin('[').Number(p.tau_r).Number(p.precision).Number(p.recall).End(']');
  }
  w.End(']');
  w.End('}');
  w.Key("map").Begin('{');
  w.Key("places").Int(static_cast<long long>(r.main.map.places().size()));
  w.Key("edges").Int(static_cast<long long>(r.main.map.edges().size()));
  if (r.edges)
    w.Key("edge_precision").Number(r.edges->precision).Key("correct_edges").Int(r.edges->correct);
  w.End('}');
  w.Key("timing").Begin('{');
  w.Key("descriptor_ms_median").Number(r.descriptor_ms_median);
  w.Key("frame_ms_median").Number(r.frame_ms_median);
  w.End('}');
  w.Key("sweep").Begin('{');
  w.Key("from").Number(r.eval.sweep_from).Key("to").Number(r.eval.sweep_to);
  w.Key("step").Number(r.eval.sweep_step);
  w.End('}');
  w.Key("config").Begin('{');
  const Settings settings{r.options, DaemonOptions{}};
  for (const ConfigKey& k : ConfigTable()) {
    if (k.scope != ConfigKey::Scope::kPipeline) continue;
    const std::string v = k.get(settings);
    w.Key(k.key);
    if (k.kind == ConfigKey::Kind::kBool) {
      w.Bool(v == "true");
    } else if (k.kind == ConfigKey::Kind::kText) {
      w.String(v);
    } else {
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (end != v.c_str() && *end == '\0') {
        w.Number(x);
      } else {
        w.String(v);
      }
    }
  }
  w.End('}');
  w.End('}');
  out << "\n";
}

}  // namespace tsc
