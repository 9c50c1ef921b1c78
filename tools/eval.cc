#include "tools/eval.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "drivers/dataset/base_point_picker.h"
#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/lens_response.h"
#include "settings/settings.h"
#include "tools/events_json.h"
#include "tools/frame_view.h"

namespace tsc {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// What one pass of the pipeline did, read from its FrameResults alone (events and closed
// places), so scoring does not depend on the place memory's internals.
class RunRecorder {
 public:
  RunRecorder(EvalRun& run, std::vector<BaseStatus>* status) : run_(run), status_(status) {}

  void Consume(const FrameResult& r) {
    if (r.has_base && status_ != nullptr) status_->push_back(r.base.status);
    for (const DetectedPlace& d : r.closed_places) closed_.emplace(d.index, d);
    for (const TransitionRegion& t : r.transitions) run_.transitions.push_back(t);
    for (const PlaceEvent& e : r.events) {
      // A partial recognition is superseded by the decision taken when the place closes.
      const bool recognized = e.kind == EventKind::kRecognized && !e.partial;
      if (recognized || e.kind == EventKind::kLearned || e.kind == EventKind::kAmbiguous) {
        Decided(e, recognized);
      }
      if (e.kind == EventKind::kRecognized && e.partial) partial_[e.detected_place] = e;
    }
  }
  std::vector<Assignment> assignments;
  std::vector<LoopClosure> loop_closures;

 private:
  // The final decision on a detected place: it founds a learned place or joins one; a
  // recognition makes each of its frames a loop closure naming the nearest member frame.
  void Decided(const PlaceEvent& e, bool recognized) {
    const auto it = closed_.find(e.detected_place);
    if (it == closed_.end()) {
      throw std::logic_error("eval: decision on detected place " +
                             std::to_string(e.detected_place) + " before it closed");
    }
    const DetectedPlace& d = it->second;
    std::vector<int> frames;
    for (BaseIndex k : d.members) frames.push_back(static_cast<int>(k));  // base k = frame k
    // A consolidation folded places into the one recognised: their frames are its own now.
    for (const PlaceId& f : e.folded) mirror_.Fold(*e.place, f);
    if (e.place) FoldFrames(run_.frames_of, *e.place, e.folded);
    assignments.push_back({frames, e.place, recognized, e.folded});
    run_.detected.push_back({e.detected_place, frames, e.place, recognized, e.cost, e.terms,
                             std::nullopt, 0.0, e.neighbour, e.folded});
    if (const auto partial = partial_.find(e.detected_place); partial != partial_.end()) {
      run_.detected.back().partial_place = partial->second.place;
      run_.detected.back().partial_cost = partial->second.cost;
      partial_.erase(partial);
    }
    if (!e.place) {  // ambiguous: no place, no loop closure
      closed_.erase(it);
      return;
    }
    auto& of = run_.frames_of[*e.place];
    of.insert(of.end(), frames.begin(), frames.end());
    if (recognized) {
      const auto named = mirror_.Recognise(*e.place, frames, d.descriptors);
      loop_closures.insert(loop_closures.end(), named.begin(), named.end());
    } else {
      mirror_.Learn(*e.place, frames, d.descriptors);
    }
    closed_.erase(it);  // decided once; the descriptors now live in the mirror
  }

  EvalRun& run_;
  std::vector<BaseStatus>* status_;
  std::map<DetectedPlaceIndex, DetectedPlace> closed_;  // closed, not yet decided
  std::map<DetectedPlaceIndex, PlaceEvent> partial_;    // its recognition when it opened
  PlaceMembersMirror mirror_;
};

// Places per label of the final memory (DESIGN §7.1b), the figure a long run's copies of a
// room raise (issue 23). Each place takes the majority label of its frames; a consolidation
// has moved the frames of the places it folded to the place holding them (FoldFrames).
double PlacesPerLabelOf(const GroundTruth& truth,
                        const std::map<PlaceId, std::vector<int>>& frames_of,
                        const PlaceMemory& memory) {
  std::vector<std::vector<PlaceId>> places;
  places.reserve(memory.places().size());
  std::map<PlaceId, std::string> labels;
  for (const LearnedPlace& p : memory.places()) {
    places.push_back({p.id});
    if (const auto it = frames_of.find(p.id); it != frames_of.end()) {
      labels[p.id] = MajorityLabel(truth, it->second);
    }
  }
  return PlacesPerLabel(places, labels);
}

// One pass of a fresh pipeline over the stored descriptors. `step_ms` (optional) receives the
// time of each ProcessDescriptor call; `status` (optional) the status of each base point.
EvalRun Replay(const Dataset& dataset, const PipelineOptions& options,
               const std::vector<BasePointView>& inputs, const GroundTruth& truth, bool keep_memory,
               std::vector<double>* step_ms, std::vector<BaseStatus>* status) {
  Pipeline pipeline(dataset.camera(), options, PlaceMemory(options.robot, options.memory),
                    TopologicalMap{});
  EvalRun run;
  run.tau_r = options.memory.tau_r;
  RunRecorder recorder(run, status);
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
    recorder.Consume(r);
  }
  recorder.Consume(pipeline.Finish());
  run.recognition = ScoreRecognition(truth, recorder.assignments);
  run.loop_closures = recorder.loop_closures;
  run.loop_closure = ScoreLoopClosures(truth, run.loop_closures, static_cast<int>(inputs.size()));
  run.learned_places = static_cast<int>(pipeline.memory().places().size());
  run.places_per_label = PlacesPerLabelOf(truth, run.frames_of, pipeline.memory());
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

namespace {
// One τ_r of the sweep on each PR curve: place level (labels), view overlap, frame level.
void AddSweepPoint(EvalResult& result, const EvalRun& run) {
  const RecognitionScore& s = run.recognition;
  result.pr_curve.push_back({run.tau_r, s.precision, s.recall});
  result.sweep_counts.push_back({run.tau_r, s.recognitions, s.correct, s.should_be_recognized});
  result.view_pr_curve.push_back({run.tau_r, s.precision, s.view_recall});
  result.loop_closure_pr_curve.push_back(
      {run.tau_r, run.loop_closure.precision, run.loop_closure.recall});
}
}  // namespace

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
  result.truth.poses = dataset.poses();

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

  std::vector<double> steps;
  for (size_t i = 1; i < inputs.size(); ++i) {
    steps.push_back(ChiSquared(inputs[i - 1].judged().values(), inputs[i].judged().values()));
  }
  result.consecutive_chi2_median = steps.empty() ? 0.0 : MedianOf(steps);

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
    AddSweepPoint(result, Replay(dataset, o, inputs, result.truth, false, nullptr, nullptr));
  }
  if (result.pr_curve.empty()) AddSweepPoint(result, result.main);
  result.recall_at_full_precision = RecallAtFullPrecision(result.pr_curve);
  result.view_recall_at_full_precision = RecallAtFullPrecision(result.view_pr_curve);
  result.loop_closure_recall_at_full_precision =
      RecallAtFullPrecision(result.loop_closure_pr_curve);

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
  JsonWriter& Null() { return Raw("null"); }

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

// [[τ_r, precision, recall], ...]
void WriteCurve(JsonWriter& w, const std::vector<PrPoint>& curve) {
  w.Begin('[');
  for (const PrPoint& p : curve) {
    w.Begin('[').Number(p.tau_r).Number(p.precision).Number(p.recall).End(']');
  }
  w.End(']');
}

// "recognition": place level, and with poses the view-overlap recall (DESIGN §7.1b).
void WriteRecognition(JsonWriter& w, const EvalResult& r) {
  const RecognitionScore& s = r.main.recognition;
  w.Key("recognition").Begin('{');
  w.Key("tau_r").Number(r.main.tau_r).Key("recognitions").Int(s.recognitions);
  w.Key("correct").Int(s.correct).Key("should_be_recognized").Int(s.should_be_recognized);
  w.Key("precision").Number(s.precision).Key("recall").Number(s.recall);
  w.Key("recall_at_full_precision").Number(r.recall_at_full_precision);
  WriteCurve(w.Key("pr_curve"), r.pr_curve);
  w.Key("sweep_counts").Begin('[');
  for (const EvalResult::SweepCount& c : r.sweep_counts) {
    w.Begin('[')
        .Number(c.tau_r)
        .Int(c.recognitions)
        .Int(c.correct)
        .Int(c.should_be_recognized)
        .End(']');
  }
  w.End(']');
  if (r.truth.has_poses()) {
    w.Key("view_should_be_recognized").Int(s.view_should_be_recognized);
    w.Key("view_correct").Int(s.view_correct).Key("view_recall").Number(s.view_recall);
    w.Key("view_recall_at_full_precision").Number(r.view_recall_at_full_precision);
    WriteCurve(w.Key("view_pr_curve"), r.view_pr_curve);
  }
  w.End('}');
}

// "decisions": the main run's decision on each detected place with its cost terms and how
// the scoring judged it, so a miss or a wrong recognition can be read off.
void WriteDecisions(JsonWriter& w, const EvalResult& r) {
  const std::vector<RecognitionScore::Verdict>& verdicts = r.main.recognition.verdicts;
  w.Key("decisions").Begin('[');
  for (size_t i = 0; i < r.main.detected.size(); ++i) {
    const EvalDetectedPlace& d = r.main.detected[i];
    w.Begin('{');
    w.Key("detected_place").Int(d.index);
    w.Key("first_frame").Int(d.frames.empty() ? -1 : d.frames.front());
    w.Key("last_frame").Int(d.frames.empty() ? -1 : d.frames.back());
    w.Key("base_points").Int(static_cast<long long>(d.frames.size()));
    if (r.truth.has_labels()) w.Key("label").String(MajorityLabel(r.truth, d.frames));
    w.Key("decision").String(d.recognized ? "recognized" : d.place ? "learned" : "ambiguous");
    if (d.recognized) w.Key("neighbour").Bool(d.neighbour);
    if (!d.folded.empty()) {
      w.Key("folded").Begin('[');
      for (const PlaceId& f : d.folded) w.String(f.ToString());
      w.End(']');
    }
    if (d.place) w.Key("place").String(d.place->ToString());
    w.Key("cost").Number(d.cost);
    w.Key("terms").Begin('{');
    w.Key("distance").Number(d.terms.distance).Key("ratio").Number(d.terms.ratio);
    w.Key("vote").Number(d.terms.vote).Key("agreement").Number(d.terms.agreement);
    w.End('}');
    if (d.partial_place) {
      w.Key("partial").Begin('{');
      w.Key("place").String(d.partial_place->ToString()).Key("cost").Number(d.partial_cost);
      w.End('}');
    }
    if (i < verdicts.size()) {
      w.Key("should_be_recognized").Bool(verdicts[i].should);
      if (r.truth.has_poses()) w.Key("view_should_be_recognized").Bool(verdicts[i].view_should);
      w.Key("correct").Bool(verdicts[i].correct);
    }
    w.End('}');
  }
  w.End(']');
}

// "loop_closure": frame level (DESIGN §7.1b); only ground truth can tell a revisit.
void WriteLoopClosure(JsonWriter& w, const EvalResult& r) {
  if (!r.truth.has_labels() && !r.truth.has_revisits()) return;
  const LoopClosureScore& c = r.main.loop_closure;
  w.Key("loop_closure").Begin('{');
  w.Key("detections").Int(c.detections).Key("correct").Int(c.correct);
  w.Key("not_judged").Int(c.not_judged);
  w.Key("frames_with_revisit").Int(c.frames_with_revisit);
  w.Key("precision").Number(c.precision).Key("recall").Number(c.recall);
  w.Key("recall_at_full_precision").Number(r.loop_closure_recall_at_full_precision);
  WriteCurve(w.Key("pr_curve"), r.loop_closure_pr_curve);
  w.End('}');
}

// "spacing": how far apart the base points were taken, on what evidence, and any caution.
void WriteSpacing(JsonWriter& w, const EvalResult& r) {
  if (r.spacing) {
    const EvalSpacing& sp = *r.spacing;
    w.Key("spacing").Begin('{');
    w.Key("metres").Number(sp.base_points.metres).Key("basis").String(sp.base_points.basis);
    w.Key("keyframes").Bool(sp.base_points.keyframes).Key("assumed").Bool(sp.base_points.assumed);
    w.Key("stride").Int(sp.stride).Key("dataset_frames").Int(sp.dataset_frames);
    w.Key("tau_p").Int(r.options.detector.EffectiveTauP());
    w.Key("caution");
    if (sp.caution) {
      w.String(*sp.caution);
    } else {
      w.Null();
    }
    w.End('}');
  }
}

// "lens": the field of view the thresholds were adapted to, and what they came to.
void WriteLens(JsonWriter& w, const EvalResult& r) {
  if (!r.lens) return;
  w.Key("lens").Begin('{');
  w.Key("hfov_deg").Number(r.lens->lens.hfov_deg());
  w.Key("views").Int(r.lens->lens.views_per_base_point());
  w.Key("tau_kappa").Number(r.options.reliability.tau_kappa);
  w.Key("distance_unit").Number(r.options.memory.distance_unit);
  w.Key("caution");
  if (r.lens->caution) {
    w.String(*r.lens->caution);
  } else {
    w.Null();
  }
  w.End('}');
}

// "config": every pipeline key with its value, numbers as numbers.
void WriteConfig(JsonWriter& w, const PipelineOptions& options) {
  w.Key("config").Begin('{');
  const Settings settings{options, DaemonOptions{}};
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
  // What detection.tau_p = -1 came to for this dataset (docs/decisions.md, "Frame rate").
  w.Key("base_point_spacing_m").Number(options.detector.spacing_m);
  w.Key("effective_tau_p").Number(options.detector.EffectiveTauP());
  w.End('}');
}

}  // namespace

DatasetOptions DatasetOptionsOf(const Settings& settings) {
  DatasetOptions out;
  out.max_image_pixels = settings.daemon.camera.max_image_pixels;
  return out;
}

PreparedDataset PrepareDataset(const Settings& settings, const Dataset& opened, std::ostream* say) {
  const auto [stride, spacing] =
      BasePointsOf(ResolveSpacing(settings.daemon.camera.spacing_m, &opened.spacing(), 0.0));
  // Poses stand in for the odometry by which tscd skips a robot standing still. A keyframe
  // sequence keeps every frame: its frames were kept for what they show.
  const std::vector<int> frames =
      spacing.keyframes ? std::vector<int>{} : FramesOfRoute(opened.poses(), stride);
  const CameraLens lens = CameraLens::Of(opened.camera(), opened.sweep().views());
  PreparedDataset out{frames.empty() ? opened.EveryNth(stride) : opened.Subset(frames),
                      settings.pipeline,
                      spacing,
                      stride,
                      {lens, LensCaution(lens)}};
  if (out.options.features.NeedsDepth() && !out.dataset.has_depth()) {
    throw DatasetError(opened.folder().string() +
                       ": bubble.features = " + out.options.features.ToString() +
                       " needs depth, but the dataset has no depth/ folder");
  }
  AdaptToSpacing(out.options, spacing);
  AdaptToLens(out.options, lens);
  if (say != nullptr) {
    *say << "  base points     " << spacing.metres << " m apart (" << spacing.basis
         << "): places of " << out.options.detector.EffectiveTauP()
         << " base points or fewer are pruned\n";
    if (out.dataset.size() < opened.size()) {
      *say << "  base points     " << out.dataset.size() << " of " << opened.size()
           << " frames (every " << stride
           << (frames.empty() ? "" : ", frames standing still skipped")
           << "), and they are what is scored\n";
    }
    if (const std::optional<std::string> note = SparseCameraNote(out.options, spacing)) {
      *say << "  sparse camera   " << *note << "\n";
    }
    if (const std::optional<std::string> caution = SpacingCaution(spacing)) {
      *say << "  caution         " << *caution << "\n";
    }
    if (const std::optional<std::string> note = LensNote(out.options, lens)) {
      *say << "  lens            " << *note << "\n";
    }
    if (out.lens.caution) *say << "  caution         " << *out.lens.caution << "\n";
  }
  return out;
}

void WriteEvalJson(std::ostream& out, const EvalResult& r) {
  JsonWriter w(out);
  w.Begin('{');
  w.Key("dataset").String(r.dataset);
  w.Key("frames").Int(r.frames);
  w.Key("base_points").Begin('{');
  w.Key("good").Int(r.good).Key("uninformative").Int(r.uninformative);
  w.Key("incoherent").Int(r.incoherent);
  w.Key("consecutive_chi2_median").Number(r.consecutive_chi2_median);
  w.End('}');
  w.Key("detected_places").Int(static_cast<long long>(r.main.detected.size()));
  w.Key("learned_places").Int(r.main.learned_places);
  w.Key("places_per_label");
  if (r.truth.has_labels()) {
    w.Number(r.main.places_per_label);
  } else {
    w.Null();
  }
  w.Key("ground_truth").Begin('{');
  w.Key("labels").Bool(r.truth.has_labels()).Key("revisits").Bool(r.truth.has_revisits());
  w.Key("poses").Bool(r.truth.has_poses());
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
  WriteRecognition(w, r);
  WriteDecisions(w, r);
  WriteLoopClosure(w, r);
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
  WriteSpacing(w, r);
  WriteLens(w, r);
  WriteConfig(w, r.options);
  w.End('}');
  out << "\n";
}

}  // namespace tsc
