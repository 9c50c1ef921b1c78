#include "settings/settings.h"

#include <algorithm>
#include <boost/program_options/options_description.hpp>
#include <boost/program_options/parsers.hpp>
#include <boost/program_options/value_semantic.hpp>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <type_traits>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/memory/view_basis.h"

namespace tsc {
namespace fs = std::filesystem;
namespace po = boost::program_options;

namespace {

template <typename T>
std::string FormatNumber(T v) {
  if constexpr (std::is_floating_point_v<T>) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
    return std::string(buf, r.ptr);
  } else {
    return std::to_string(v);
  }
}

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// `text` as '#' comment lines of at most 92 characters.
std::string WrapComment(const std::string& text) {
  std::string out, line = "#";
  std::istringstream words(text);
  for (std::string w; words >> w;) {
    if (line.size() + 1 + w.size() > 92 && line != "#") {
      out += line + "\n";
      line = "#";
    }
    line += " " + w;
  }
  return out + line + "\n";
}

// Parses a number of type T (integers must be whole) and checks the key's range.
template <typename T>
T ParseNumber(const ConfigKey& k, const std::string& text) {
  const std::string s = Trim(text);
  if (s.empty()) throw std::invalid_argument("a number is required");
  double v = 0.0;
  if constexpr (std::is_integral_v<T>) {
    errno = 0;
    char* end = nullptr;
    const long long i = std::strtoll(s.c_str(), &end, 10);
    if (end != s.c_str() + s.size() || errno != 0) {
      throw std::invalid_argument("'" + s + "' is not a whole number");
    }
    v = static_cast<double>(i);
  } else {
    char* end = nullptr;
    v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || !std::isfinite(v)) {
      throw std::invalid_argument("'" + s + "' is not a finite number");
    }
  }
  if (!k.range.Contains(v)) {
    throw std::invalid_argument("out of range " + k.RangeText() +
                                (k.unit.empty() ? "" : " (" + k.unit + ")"));
  }
  return static_cast<T>(v);
}

bool ParseBool(const std::string& text) {
  const std::string s = Trim(text);
  if (s == "true" || s == "1" || s == "yes" || s == "on") return true;
  if (s == "false" || s == "0" || s == "no" || s == "off") return false;
  throw std::invalid_argument("'" + s + "' is not true or false");
}

// `field` is a generic lambda returning a reference to the option inside Settings
// (const or not), so one accessor serves both get and set. `range` is the Options struct's
// declaration where it has one (its Validate() checks the same), else declared here.
template <typename Field>
ConfigKey Number(std::string key, std::string description, std::string unit, Range range,
                 Field field) {
  using T = std::remove_cvref_t<decltype(field(std::declval<Settings&>()))>;
  ConfigKey k;
  k.key = std::move(key);
  k.description = std::move(description);
  k.unit = std::move(unit);
  k.kind = std::is_integral_v<T> ? ConfigKey::Kind::kInteger : ConfigKey::Kind::kReal;
  k.range = range;
  k.get = [field](const Settings& o) { return FormatNumber(field(o)); };
  // The row is copied into the setter so the range check can name it.
  k.set = [field, row = k](Settings& o, const std::string& v) {
    field(o) = ParseNumber<T>(row, v);
  };
  return k;
}

// A numeric key whose range only the configuration declares (no Validate() checks it).
template <typename Field>
ConfigKey Number(std::string key, std::string description, std::string unit, double min, double max,
                 Field field, bool min_open = false, bool max_open = false) {
  return Number(std::move(key), std::move(description), std::move(unit),
                Range{min, max, min_open, max_open}, field);
}

template <typename Field>
ConfigKey Bool(std::string key, std::string description, Field field) {
  ConfigKey k;
  k.key = std::move(key);
  k.description = std::move(description);
  k.kind = ConfigKey::Kind::kBool;
  k.get = [field](const Settings& o) { return std::string(field(o) ? "true" : "false"); };
  k.set = [field](Settings& o, const std::string& v) { field(o) = ParseBool(v); };
  return k;
}

// A text key; `check` throws std::invalid_argument for a value it refuses.
template <typename Field>
ConfigKey Text(std::string key, std::string description, std::string range, Field field,
               std::function<void(const std::string&)> check = {}) {
  ConfigKey k;
  k.key = std::move(key);
  k.description = std::move(description);
  k.kind = ConfigKey::Kind::kText;
  k.text_range = std::move(range);
  k.get = [field](const Settings& o) { return field(o); };
  k.set = [field, check](Settings& o, const std::string& v) {
    const std::string value = Trim(v);
    if (check) check(value);
    field(o) = value;
  };
  return k;
}

// A check that accepts exactly one of `choices`.
std::function<void(const std::string&)> OneOf(std::vector<std::string> choices) {
  return [choices](const std::string& v) {
    for (const std::string& c : choices) {
      if (v == c) return;
    }
    std::string list;
    for (const std::string& c : choices) list += (list.empty() ? "" : " | ") + c;
    throw std::invalid_argument("'" + v + "' is not one of " + list);
  };
}

// The first octet of a dotted IPv4 address, or nothing when `v` is not one.
std::optional<unsigned> FirstOctetOfIPv4(const std::string& v) {
  unsigned a, b, c, d;
  char tail;
  if (std::sscanf(v.c_str(), "%u.%u.%u.%u%c", &a, &b, &c, &d, &tail) != 4 || a > 255 || b > 255 ||
      c > 255 || d > 255) {
    return std::nullopt;
  }
  return a;
}

// lcm.url: memq://, or udpm://GROUP:PORT[?options] with a multicast group, a port LCM can
// bind and a ttl it can set, so that a typo is refused when read (exit 78) rather than
// reported at start as a missing multicast route.
void CheckLcmUrl(const std::string& v) {
  if (v.rfind("memq://", 0) == 0) return;
  if (v.rfind("udpm://", 0) != 0) {
    throw std::invalid_argument("'" + v + "' is not a udpm:// or memq:// URL");
  }
  const std::string rest = v.substr(7);
  const size_t query = rest.find('?');
  const std::string where = rest.substr(0, query);
  const size_t colon = where.find(':');
  const std::string group = where.substr(0, colon);
  const std::optional<unsigned> first = FirstOctetOfIPv4(group);
  if (!first || *first < 224 || *first > 239) {
    throw std::invalid_argument("'" + v + "': '" + group +
                                "' is not a multicast group (224.0.0.0-239.255.255.255)");
  }
  const auto whole_in = [&](const std::string& text, long lo, long hi, const char* what) {
    long n = -1;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), n);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size() || n < lo || n > hi) {
      throw std::invalid_argument("'" + v + "': " + what + " '" + text + "' is not in [" +
                                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
  };
  // Without a port LCM binds an ephemeral one and its self test fails at start.
  if (colon == std::string::npos) {
    throw std::invalid_argument("'" + v + "' has no port (udpm://GROUP:PORT, e.g. :7667)");
  }
  whole_in(where.substr(colon + 1), 1, 65535, "port");
  if (query == std::string::npos) return;
  std::string options = rest.substr(query + 1);
  for (size_t start = 0; start <= options.size();) {
    const size_t end = std::min(options.find('&', start), options.size());
    const std::string option = options.substr(start, end - start);
    if (option.rfind("ttl=", 0) == 0) whole_in(option.substr(4), 0, 255, "ttl");
    start = end + 1;
  }
}

// memory.view_basis: "builtin", "none" (null) or a file of ViewBasisBytes' form.
std::shared_ptr<const ViewBasis> NamedOrFileViewBasis(const std::string& value) {
  if (value == "none") return nullptr;
  if (value == "builtin") return BuiltinViewBasis();
  std::ifstream in(value, std::ios::binary);
  if (!in) throw std::invalid_argument("cannot read the basis file '" + value + "'");
  // Bounded before reading: 4096 axes of 4096 floats is far beyond any descriptor.
  constexpr std::streamoff kMaxBytes = 64ll << 20;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0 || size > kMaxBytes) {
    throw std::invalid_argument("basis file '" + value + "' is larger than 64 MiB");
  }
  in.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), size);
  if (!in) throw std::invalid_argument("cannot read the basis file '" + value + "'");
  return std::make_shared<const ViewBasis>(ParseViewBasis(bytes, value));
}

std::vector<ConfigKey> BuildTable() {
  std::vector<ConfigKey> t;
  // [robot]
  t.push_back(Number(
      "robot.id", "robot id, the first part of every place id <robot>:<n>", "", 1, 4294967295.0,
      [](auto& o) -> auto& { return o.pipeline.robot; }));
  // [bubble] — bubble space, appendix A and chapter 2
  {
    ConfigKey k;
    k.key = "bubble.features";
    k.description =
        "feature set, in descriptor block order: a list of hue, hue_cos, hue_sin, vertical, "
        "horizontal, hyperbolic, polar, concentric, orient_0, orient_45, orient_90, "
        "orient_135, intensity, depth (place detection needs intensity); or a thesis set "
        "(section 2.3): L1 hue + Cartesian gratings, L2 = L1 + non-Cartesian gratings, L3 "
        "depth, L4 = L1 + depth, L5 = L2 + depth, +I appends intensity, -I leaves it out";
    k.kind = ConfigKey::Kind::kText;
    k.text_range = "L1..L5 with optional +I or -I, or a comma-separated feature list";
    k.get = [](const Settings& o) { return o.pipeline.features.ToString(); };
    k.set = [](Settings& o, const std::string& v) {
      o.pipeline.features = FeatureSet::Parse(Trim(v));
    };
    t.push_back(std::move(k));
  }
  {
    ConfigKey k = Number(
        "bubble.d_phi_deg", "d_phi, spacing of the grid of viewing directions; must divide 180",
        "degrees", BubbleSurfaceOptions::kDPhiDegRange,
        [](auto& o) -> auto& { return o.pipeline.surface.d_phi_deg; });
    k.set = [in_range = k.set](Settings& o, const std::string& v) {
      in_range(o, v);
      const double steps = 180.0 / o.pipeline.surface.d_phi_deg;
      if (std::abs(steps - std::round(steps)) > 1e-9 * steps) {
        throw std::invalid_argument("does not divide 180 into whole steps (e.g. 1, 2.5, 5)");
      }
    };
    t.push_back(std::move(k));
  }
  t.push_back(Number(
      "bubble.rest_radius", "rho_0, radius of directions never observed", "feature value",
      BubbleSurfaceOptions::kRestRadiusRange,
      [](auto& o) -> auto& { return o.pipeline.surface.rest_radius; }));
  t.push_back(Number(
      "bubble.max_depth_m", "range that maps to depth feature value 1", "m",
      BubbleSurfaceOptions::kMaxDepthMRange,
      [](auto& o) -> auto& { return o.pipeline.surface.max_depth_m; }));
  t.push_back(Number(
      "bubble.patch_px", "side of the resampled d_phi x d_phi image patch", "pixels",
      BubbleSurfaceOptions::kPatchPxRange,
      [](auto& o) -> auto& { return o.pipeline.surface.patch_px; }));
  t.push_back(Number(
      "bubble.orientation_blur_deg",
      "sigma of the Gaussian blur before the orientation gradients (0 = none; 1.25 keeps dim "
      "revisits legible, not yet adopted: docs/calibration.md, fifteenth pass)",
      "degrees", BubbleSurfaceOptions::kOrientationBlurDegRange,
      [](auto& o) -> auto& { return o.pipeline.surface.orientation_blur_deg; }));
  // [descriptor] — (A.3)-(A.7)
  t.push_back(Number(
      "descriptor.harmonics_pan", "H1, harmonics of the Fourier series in pan", "",
      DescriptorOptions::kHarmonicsRange,
      [](auto& o) -> auto& { return o.pipeline.descriptor.h1; }));
  t.push_back(Number(
      "descriptor.harmonics_tilt", "H2, harmonics of the Fourier series in tilt", "",
      DescriptorOptions::kHarmonicsRange,
      [](auto& o) -> auto& { return o.pipeline.descriptor.h2; }));
  t.push_back(Bool(
      "descriptor.amplitude",
      "true: entries sqrt(z^T z) (amplitude); false: z^T z as in (A.7) (energy)",
      [](auto& o) -> auto& { return o.pipeline.descriptor.amplitude; }));
  t.push_back(Bool(
      "descriptor.block_sum",
      "true: each feature block sums to 1/N_v; false: fixed scale keeping feature levels",
      [](auto& o) -> auto& { return o.pipeline.descriptor.block_sum; }));
  // [detection] — section 3.4, appendix C
  t.push_back(Number(
      "detection.tau_mu", "tau_mu, mean intensity at or below which a base point is uninformative",
      "intensity", ReliabilityOptions::kTauMuRange,
      [](auto& o) -> auto& { return o.pipeline.reliability.tau_mu; }));
  t.push_back(Number(
      "detection.tau_sigma",
      "tau_sigma, intensity variance at or below which a base point is "
      "uninformative",
      "intensity^2", ReliabilityOptions::kTauSigmaRange,
      [](auto& o) -> auto& { return o.pipeline.reliability.tau_sigma; }));
  t.push_back(Number(
      "detection.tau_kappa",
      "tau_kappa, chi^2 to the previous descriptor above which a base point is "
      "incoherent",
      "chi^2", ReliabilityOptions::kTauKappaRange,
      [](auto& o) -> auto& { return o.pipeline.reliability.tau_kappa; }));
  t.push_back(Number(
      "detection.tau_n",
      "tau_n, a bad base point within this many points extends the temporal "
      "window",
      "base points", DetectorOptions::kTauNRange,
      [](auto& o) -> auto& { return o.pipeline.detector.tau_n; }));
  t.push_back(Number(
      "detection.tau_w",
      "tau_w, temporal windows this long or longer are transitions, shorter ones "
      "noise",
      "base points", DetectorOptions::kTauWRange,
      [](auto& o) -> auto& { return o.pipeline.detector.tau_w; }));
  t.push_back(Number(
      "detection.tau_p",
      "tau_p, detected places with this many base points or fewer are pruned; -1 = from "
      "tau_p_m and the base-point spacing (camera.spacing_m)",
      "base points", DetectorOptions::kTauPRange,
      [](auto& o) -> auto& { return o.pipeline.detector.tau_p; }));
  t.push_back(Number(
      "detection.tau_p_m",
      "tau_p as a length of travel: detected places spanning this many metres or fewer are "
      "pruned (used when tau_p = -1)",
      "m", DetectorOptions::kTauPMRange,
      [](auto& o) -> auto& { return o.pipeline.detector.tau_p_m; }));
  // [memory] — sections 3.3, 3.5, 3.6
  t.push_back(Number(
      "memory.tau_r", "tau_r, recognition threshold on the cost g_N of (3.8)", "",
      PlaceMemoryOptions::kTauRRange, [](auto& o) -> auto& { return o.pipeline.memory.tau_r; }));
  t.push_back(Number(
      "memory.neighbour_margin",
      "g_N may exceed tau_r by this much on the way to a place the topological map joins to the "
      "previous place; 0 = tau_r alone",
      "", PlaceMemoryOptions::kNeighbourMarginRange,
      [](auto& o) -> auto& { return o.pipeline.memory.neighbour_margin; }));
  t.push_back(Number(
      "memory.vote_radius",
      "a base point of D votes for N1 when its squared distance to N1's nearest member view is "
      "at most this many distance units u",
      "units u", RecognitionCostOptions::kVoteRadiusRange,
      [](auto& o) -> auto& { return o.pipeline.memory.cost.vote_radius; }));
  t.push_back(Number(
      "memory.distance_unit",
      "unit u of the distance term of g_N and of the vote radius; 0 = the memory's median view "
      "spacing, > 0 = a fixed unit for a camera kind",
      "descriptor distance^2", PlaceMemoryOptions::kDistanceUnitRange,
      [](auto& o) -> auto& { return o.pipeline.memory.distance_unit; }));
  t.push_back(Number(
      "memory.step_unit",
      "the unit u of the distance term is at least this multiple of D's median squared step "
      "between consecutive base points (0: distance_unit alone)",
      "", PlaceMemoryOptions::kStepUnitRange,
      [](auto& o) -> auto& { return o.pipeline.memory.step_unit; }));
  t.push_back(Number(
      "memory.mean_distance_unit",
      "unit of the squared distance between D's mean and N1's centroid when the distance term "
      "of g_N may come from the means (the smaller counts; a pan sweep's preset); 0 = views only",
      "descriptor distance^2", RecognitionCostOptions::kMeanUnitRange,
      [](auto& o) -> auto& { return o.pipeline.memory.cost.mean_unit; }));
  t.push_back(Number(
      "memory.coincide_factor",
      "two children of N hold one place (the ratio's N2 skips the copy) when their views "
      "nearest D lie, in the median, within the larger of memory.vote_radius and this factor "
      "times g_N's distance term; 0 = the vote radius alone",
      "", RecognitionCostOptions::kCoincideFactorRange,
      [](auto& o) -> auto& { return o.pipeline.memory.cost.coincide_factor; }));
  t.push_back(Number(
      "memory.min_agreement",
      "a place is recognised (or absorbs one in a merge) only when at least this share of D's "
      "points agree with it: their nearest place is it or a copy of it, or it lies within "
      "memory.agreement_slack of that place; 0 = the cost alone decides",
      "", RecognitionCostOptions::kMinAgreementRange,
      [](auto& o) -> auto& { return o.pipeline.memory.cost.min_agreement; }));
  t.push_back(Number(
      "memory.agreement_slack",
      "a point of D also agrees with N1 when N1's nearest view lies within this factor of the "
      "nearest place's squared distance",
      "", RecognitionCostOptions::kAgreementSlackRange,
      [](auto& o) -> auto& { return o.pipeline.memory.cost.agreement_slack; }));
  t.push_back(Bool(
      "memory.svm_vote",
      "vote V_N of (3.8) from the thesis' one-class SVM d_N (trained per node) instead of the "
      "member views",
      [](auto& o) -> auto& { return o.pipeline.memory.svm_vote; }));
  t.push_back(Bool(
      "memory.learn_disagreed",
      "a detected place within tau_r whose points do not agree with the place "
      "(memory.min_agreement) is learned as a new place; false leaves it without a place "
      "(an 'ambiguous' event)",
      [](auto& o) -> auto& { return o.pipeline.memory.learn_disagreed; }));
  t.push_back(Number(
      "memory.near_miss_margin",
      "a detected place not recognised whose g_N is at most tau_r plus this margin while at "
      "least memory.near_miss_vote of its points vote for N1, and N1 is nearer than another "
      "place (ratio below 1), is left without a place (an 'ambiguous' event) instead of "
      "learned as a copy; 0 = every such place is learned",
      "", PlaceMemoryOptions::kNearMissMarginRange,
      [](auto& o) -> auto& { return o.pipeline.memory.near_miss_margin; }));
  t.push_back(Number(
      "memory.near_miss_vote", "the vote V of N1 a near miss (memory.near_miss_margin) needs", "",
      PlaceMemoryOptions::kNearMissVoteRange,
      [](auto& o) -> auto& { return o.pipeline.memory.near_miss_vote; }));
  t.push_back(Bool(
      "memory.copies_keep_outer_ratio",
      "where every other child of N holds N1's place again, the ratio term is the one N1's node "
      "had one level up instead of 1",
      [](auto& o) -> auto& { return o.pipeline.memory.copies_keep_outer_ratio; }));
  t.push_back(Number(
      "memory.tau_l", "tau_l, levels the hybrid traversal climbs", "levels",
      PlaceMemoryOptions::kTauLRange, [](auto& o) -> auto& { return o.pipeline.memory.tau_l; }));
  t.push_back(Number(
      "memory.tau_h",
      "tau_h, relative merge-height gap under which the tree simplification folds "
      "a node into its parent",
      "", PlaceMemoryOptions::kTauHRange,
      [](auto& o) -> auto& { return o.pipeline.memory.tau_h; }));
  t.push_back(Number(
      "memory.max_samples_per_place",
      "member views (descriptors) kept per visit of a learned place", "descriptors",
      PlaceMemoryOptions::kMaxSamplesRange,
      [](auto& o) -> auto& { return o.pipeline.memory.max_samples_per_place; }));
  t.push_back(Number(
      "memory.sample_visits",
      "a place keeps max_samples_per_place member views for each of its visits (detected "
      "places and places it absorbed), of at most this many visits",
      "visits", PlaceMemoryOptions::kSampleVisitsRange,
      [](auto& o) -> auto& { return o.pipeline.memory.sample_visits; }));
  t.push_back(Number(
      "memory.max_vote_points",
      "base points of a detected place the recognition cost is measured on (evenly spaced)",
      "base points", PlaceMemoryOptions::kMaxVotePointsRange,
      [](auto& o) -> auto& { return o.pipeline.memory.max_vote_points; }));
  t.push_back(Number(
      "memory.shortlist",
      "places measured exactly per recognition once the memory holds more: those whose keys "
      "in the view index come nearest the detected place; 0 = every place",
      "places", PlaceMemoryOptions::kShortlistRange,
      [](auto& o) -> auto& { return o.pipeline.memory.shortlist; }));
  {
    ConfigKey k;
    k.key = "memory.view_basis";
    k.description =
        "space member views are kept and measured in: builtin, the principal basis compiled "
        "into tscd (128 axes, fitted for the default features; docs/decisions.md); none, the "
        "descriptors themselves (the only choice for other feature sets unless a basis is "
        "fitted for them); or a basis file written by 'tsc basis'. A team must share it";
    k.kind = ConfigKey::Kind::kText;
    k.text_range = "builtin | none | a path";
    k.get = [](const Settings& o) {
      return o.pipeline.memory.view_basis ? o.pipeline.memory.view_basis->name() : "none";
    };
    k.set = [](Settings& o, const std::string& v) {
      o.pipeline.memory.view_basis = NamedOrFileViewBasis(Trim(v));
    };
    t.push_back(std::move(k));
  }
  t.push_back(Number(
      "memory.svm_nu", "nu of the one-class SVM discriminants d_N", "",
      DiscriminantOptions::kNuRange,
      [](auto& o) -> auto& { return o.pipeline.memory.discriminant.nu; }));
  t.push_back(Number(
      "memory.svm_gamma", "RBF gamma of d_N; 0 = 1 / median squared distance of the training set",
      "1/descriptor distance^2", DiscriminantOptions::kGammaRange,
      [](auto& o) -> auto& { return o.pipeline.memory.discriminant.gamma; }));
  t.push_back(Number(
      "memory.svm_max_training", "cap of training vectors per node (deterministic subsample)",
      "descriptors", DiscriminantOptions::kMaxTrainingRange,
      [](auto& o) -> auto& { return o.pipeline.memory.discriminant.max_training; }));
  // [pipeline]
  t.push_back(Bool(
      "pipeline.recognize_partial",
      "try recognition when a place opens (its extent passes tau_p), before it "
      "closes",
      [](auto& o) -> auto& { return o.pipeline.recognize_partial; }));
  t.push_back(Number(
      "pipeline.whereabouts_points",
      "base points of the window on which the robot recognises known places while a maximal "
      "neighbourhood is still shorter than a place (extent <= tau_p), so the map records a "
      "pruned passage through a known place; 0 = off",
      "base points", PipelineOptions::kWhereaboutsPointsRange,
      [](auto& o) -> auto& { return o.pipeline.whereabouts_points; }));
  t.push_back(Bool(
      "pipeline.split_known_tails",
      "while a place is open, recognise its last tau_p + 1 base points; when they show a "
      "learned place the rest does not, split the place where they begin",
      [](auto& o) -> auto& { return o.pipeline.split_known_tails; }));
  t.push_back(Number(
      "pipeline.consolidate_after",
      "fold two learned places into one once this many revisits (not consecutive) showed them "
      "holding one room: a sibling in the memory whose views lie within the vote radius of the "
      "recognised place's, not joined to it by the map and sharing a map neighbour with it; "
      "0 = never",
      "revisits", PipelineOptions::kConsolidateAfterRange,
      [](auto& o) -> auto& { return o.pipeline.consolidate_after; }));
  const size_t pipeline_keys = t.size();
  // [daemon] — tscd itself (DESIGN §6)
  t.push_back(Text(
      "daemon.state_dir", "folder of the robot's SQLite memory (memory.db)", "a path",
      [](auto& o) -> auto& { return o.daemon.state_dir; },
      [](const std::string& v) {
        if (v.empty()) throw std::invalid_argument("a folder is required");
      }));
  t.push_back(Number(
      "daemon.queue_frames",
      "base points waiting for the pipeline (a pan sweep's views count as one); when full the "
      "oldest is dropped, all its views, and counted once (frames_dropped)",
      "base points", DaemonOptions::kQueueFramesRange,
      [](auto& o) -> auto& { return o.daemon.queue_frames; }));
  t.push_back(Number(
      "daemon.max_pending_results",
      "results kept in memory while the store cannot be written; beyond it the oldest base "
      "point records are dropped (learned places and map edges are always kept)",
      "results", DaemonOptions::kMaxPendingResultsRange,
      [](auto& o) -> auto& { return o.daemon.max_pending_results; }));
  t.push_back(Number(
      "daemon.merge_threads",
      "threads a merge of a peer's memory recognises on (the pipeline waits for the merge); "
      "0 = one per core. The merge is the same for any number",
      "threads", DaemonOptions::kMergeThreadsRange,
      [](auto& o) -> auto& { return o.daemon.merge_threads; }));
  t.push_back(Number(
      "daemon.stop_store_wait_s",
      "at stop, how long a failing store is tried before what is not in it is spilled to a "
      "file the next start takes in (memory.db.spill.*, beside memory.db or in "
      "$RUNTIME_DIRECTORY); keep it below the unit's TimeoutStopSec",
      "s", 0, 3600, [](auto& o) -> auto& { return o.daemon.stop_store_wait_s; }));
  t.push_back(Text(
      "daemon.log_level", "least severe log level written", "trace|debug|info|warn|error",
      [](auto& o) -> auto& { return o.daemon.log_level; },
      OneOf({"trace", "debug", "info", "warn", "error"})));
  // [store] — retention of memory.db (store/store_options.h)
  t.push_back(Number(
      "store.budget_mb",
      "size memory.db may use before the oldest base point records (the raw descriptor stream, "
      "~4 KiB each) are deleted and their space handed back, in small steps; learned places, "
      "the map, detected places and peers' versions are always kept; 0 = keep everything",
      "MiB", StoreOptions::kBudgetMbRange,
      [](auto& o) -> auto& { return o.daemon.store.budget_mb; }));
  t.push_back(Number(
      "store.maintenance_pages",
      "at most this many base point records deleted and pages (4 KiB) handed back to the file "
      "system per maintenance step (one a second, five while behind): bounds how long the "
      "pipeline waits (~40 ms for 1024)",
      "pages", StoreOptions::kMaintenancePagesRange,
      [](auto& o) -> auto& { return o.daemon.store.maintenance_pages; }));
  // [camera] — drivers/camera
  t.push_back(Text(
      "camera.source",
      "where frames come from: the simulated world rendered live (tests and demos), a dataset "
      "folder, a video file, a V4L2/USB device, or an Axis network camera (VAPIX MJPEG and "
      "PTZ); none: not chosen yet, tscd refuses to start (the installed tscd.ini says none)",
      "sim|folder|video|device|axis|none", [](auto& o) -> auto& { return o.daemon.camera.source; },
      OneOf({"sim", "folder", "video", "device", "axis", "none"})));
  t.push_back(Text(
      "camera.path", "folder or video file; for a device /dev/videoN or its number N", "a path",
      [](auto& o) -> auto& { return o.daemon.camera.path; }));
  t.push_back(Number(
      "camera.fps",
      "frames per second delivered to the pipeline; 0 = as fast as the source, and a folder, "
      "video or sim route then waits for the pipeline (every frame processed, none dropped)",
      "1/s", CameraOptions::kFpsRange, [](auto& o) -> auto& { return o.daemon.camera.fps; }));
  t.push_back(Bool(
      "camera.loop", "folder and video: start again at the end instead of stopping",
      [](auto& o) -> auto& { return o.daemon.camera.loop; }));
  t.push_back(Number(
      "camera.hfov_deg",
      "horizontal field of view of video, device and axis frames (folders use camera.json)",
      "degrees", 0, 180, [](auto& o) -> auto& { return o.daemon.camera.hfov_deg; }, true, true));
  t.push_back(Number(
      "camera.spacing_m",
      "metres of travel between frames; 0 = what the source declares (a folder's camera.json "
      "fps, spacing_m or keyframes, or its poses; undeclared: keyframes 1 m apart), else "
      "camera.fps at 1.5 m/s, or what a motor base's odometry measures. Frames closer than "
      "0.1 m are thinned to base points about 0.15 m apart (one in 3 at 0.05 m)",
      "m", 0, 1000, [](auto& o) -> auto& { return o.daemon.camera.spacing_m; }));
  t.push_back(Number(
      "camera.width", "axis: requested resolution; device: requested capture size", "pixels", 16,
      8192, [](auto& o) -> auto& { return o.daemon.camera.width; }));
  t.push_back(Number(
      "camera.height", "axis: requested resolution; device: requested capture size", "pixels", 16,
      8192, [](auto& o) -> auto& { return o.daemon.camera.height; }));
  t.push_back(Number(
      "camera.max_image_pixels",
      "largest image decoded, width x height as its header claims (folder and dataset frames, "
      "axis MJPEG frames, video size); a larger one is refused before it is decoded, named in "
      "the log and counted, and reading goes on (default 4096x4096)",
      "pixels", 1, 268435456, [](auto& o) -> auto& { return o.daemon.camera.max_image_pixels; }));
  t.push_back(Number(
      "camera.reconnect_min_s", "device, axis: first wait before reconnecting a lost camera", "s",
      0, 3600, [](auto& o) -> auto& { return o.daemon.camera.reconnect_min_s; }, true));
  t.push_back(Number(
      "camera.reconnect_max_s", "device, axis: the reconnect wait doubles up to this", "s", 0, 3600,
      [](auto& o) -> auto& { return o.daemon.camera.reconnect_max_s; }, true));
  t.push_back(Text(
      "camera.axis_host", "axis: the camera's address (name or IP)", "a host",
      [](auto& o) -> auto& { return o.daemon.camera.axis_host; }));
  t.push_back(Number(
      "camera.axis_port", "axis: the camera's HTTP port", "", 1, 65535,
      [](auto& o) -> auto& { return o.daemon.camera.axis_port; }));
  t.push_back(Text(
      "camera.axis_user", "axis: user for HTTP Basic/Digest authentication; empty = anonymous",
      "a user name", [](auto& o) -> auto& { return o.daemon.camera.axis_user; }));
  t.push_back(Text(
      "camera.axis_password_file",
      "axis: file holding the password, readable by its owner only (mode 0600 or 0400)", "a path",
      [](auto& o) -> auto& { return o.daemon.camera.axis_password_file; }));
  t.push_back(Number(
      "camera.axis_compression", "axis: JPEG compression the camera applies", "", 0, 100,
      [](auto& o) -> auto& { return o.daemon.camera.axis_compression; }));
  t.push_back(Bool(
      "camera.axis_pan_clockwise",
      "axis: the camera's pan grows clockwise seen from above (false when mounted upside down)",
      [](auto& o) -> auto& { return o.daemon.camera.axis_pan_clockwise; }));
  t.push_back(Number(
      "camera.axis_timeout_s", "axis: connect, request and between-frames timeout", "s", 0, 600,
      [](auto& o) -> auto& { return o.daemon.camera.axis_timeout_s; }, true));
  t.push_back(Number(
      "camera.sweep_steps",
      "axis and sim: views per base point (a pan sweep accumulated into one bubble surface); "
      "1 = no sweep",
      "views", 1, 360, [](auto& o) -> auto& { return o.daemon.camera.sweep_steps; }));
  t.push_back(Number(
      "camera.sweep_deg",
      "axis and sim: pan covered by a sweep; views are sweep_deg / sweep_steps apart", "degrees", 0,
      360, [](auto& o) -> auto& { return o.daemon.camera.sweep_deg; }, true));
  t.push_back(Number(
      "camera.sweep_start_deg", "axis: camera pan of a sweep's first view (Axis convention)",
      "degrees", -360, 360, [](auto& o) -> auto& { return o.daemon.camera.sweep_start_deg; }));
  t.push_back(Number(
      "camera.sweep_tilt_deg", "axis: camera tilt during a sweep", "degrees", -90, 90,
      [](auto& o) -> auto& { return o.daemon.camera.sweep_tilt_deg; }));
  t.push_back(Number(
      "camera.sweep_settle_s",
      "axis: after each PTZ move, frames completed within this time (and one more) are dropped",
      "s", 0, 60, [](auto& o) -> auto& { return o.daemon.camera.sweep_settle_s; }));
  // [sim] — the simulated world camera and base (drivers/world)
  t.push_back(Number(
      "sim.world_seed", "seed of the generated world, shared by the whole team", "", 0,
      4294967295.0, [](auto& o) -> auto& { return o.daemon.sim.world_seed; }));
  t.push_back(Text(
      "sim.world", "kind of generated world", "office|corridors|outdoor",
      [](auto& o) -> auto& { return o.daemon.sim.world; },
      OneOf({"office", "corridors", "outdoor"})));
  t.push_back(Number(
      "sim.team_size", "robots sharing the simulated world (its rooms are dealt among them)",
      "robots", 1, 64, [](auto& o) -> auto& { return o.daemon.sim.team_size; }));
  t.push_back(Number(
      "sim.route", "this robot's route among the team's, 0-based; below sim.team_size", "", 0, 63,
      [](auto& o) -> auto& { return o.daemon.sim.route; }));
  t.push_back(Number(
      "sim.revisit_fraction", "fraction of its rooms a robot revisits after its first tour", "", 0,
      1, [](auto& o) -> auto& { return o.daemon.sim.revisit_fraction; }));
  t.push_back(Number(
      "sim.start_frame",
      "route: the frame of the route to start at (modulo its length), where a robot started "
      "again stands",
      "frames", 0, 1e15, [](auto& o) -> auto& { return o.daemon.sim.start_frame; }));
  t.push_back(Text(
      "sim.lighting", "lighting of the simulated world", "day|dim|mixed",
      [](auto& o) -> auto& { return o.daemon.sim.lighting; }, OneOf({"day", "dim", "mixed"})));
  t.push_back(Text(
      "sim.drive",
      "route: follow the scripted route; commands: a simulated base driven by "
      "JAGUAR_CMD_<robot> (odometry on JAGUAR_STATE_<robot>) carries the camera",
      "route|commands", [](auto& o) -> auto& { return o.daemon.sim.drive; },
      OneOf({"route", "commands"})));
  t.push_back(Number(
      "sim.width", "rendered frame width", "pixels", 16, 4096,
      [](auto& o) -> auto& { return o.daemon.sim.width; }));
  t.push_back(Number(
      "sim.height", "rendered frame height", "pixels", 16, 4096,
      [](auto& o) -> auto& { return o.daemon.sim.height; }));
  // [lcm] — the bus (DESIGN §4)
  t.push_back(Text(
      "lcm.url", "LCM provider URL; ttl=0 keeps multicast on this host",
      "udpm://GROUP:PORT[?ttl=N] or memq://", [](auto& o) -> auto& { return o.daemon.bus.url; },
      CheckLcmUrl));
  t.push_back(Number(
      "lcm.announce_period_s", "seconds between announces on TSC_ANNOUNCE", "s", 0.05, 3600,
      [](auto& o) -> auto& { return o.daemon.bus.announce_period_s; }));
  t.push_back(Number(
      "lcm.join_wait_s",
      "with an empty memory, seconds to listen for peers (and take back this robot's places "
      "from them) before learning; 0 = learn at once",
      "s", 0, 600, [](auto& o) -> auto& { return o.daemon.bus.join_wait_s; }));
  t.push_back(Number(
      "lcm.memory_period_s",
      "least time between two broadcasts of a changed memory on TSC_MEMORY_<robot>; requests "
      "are answered at once",
      "s", 0, 3600, [](auto& o) -> auto& { return o.daemon.bus.memory_period_s; }));
  t.push_back(Number(
      "lcm.portion_bytes",
      "upper bound of one encoded memory portion; keep it below one UDP datagram", "bytes",
      BusOptions::kPortionBytesRange, [](auto& o) -> auto& { return o.daemon.bus.portion_bytes; }));
  t.push_back(Text(
      "lcm.team_key_file",
      "file holding the team's HMAC key, readable only by tscd's user (mode 0600); "
      "empty: exchange messages are not signed",
      "a path or empty", [](auto& o) -> auto& { return o.daemon.bus.team_key_file; }));
  // [motor] — the motor channel (drivers/base, drivers/motor); uncertain protocol facts are
  // calibration keys (docs/decisions.md, "Jaguar drivers")
  t.push_back(Text(
      "motor.driver",
      "sim: the simulated base (with camera.source = sim, sim.drive = commands); jaguar-v2: "
      "Jaguar V2/V4 board, binary protocol over UDP; jaguar-ascii: Jaguar 4x4/V6 boards, ASCII "
      "protocol over TCP. Commands from JAGUAR_CMD_<robot>, odometry on JAGUAR_STATE_<robot>",
      "sim|jaguar-v2|jaguar-ascii", [](auto& o) -> auto& { return o.daemon.motor.driver; },
      OneOf({"sim", "jaguar-v2", "jaguar-ascii"})));
  t.push_back(Text(
      "motor.address", "IPv4 address of the Jaguar board", "dotted IPv4",
      [](auto& o) -> auto& { return o.daemon.motor.address; },
      [](const std::string& v) {
        if (!FirstOctetOfIPv4(v)) {
          throw std::invalid_argument("'" + v + "' is not a dotted IPv4 address");
        }
      }));
  t.push_back(Number(
      "motor.port", "UDP (jaguar-v2) or TCP (jaguar-ascii) port of the board", "", 1, 65535,
      [](auto& o) -> auto& { return o.daemon.motor.port; }));
  t.push_back(Number(
      "motor.max_linear_mps", "forward speed limit; commands are clamped", "m/s", 0, 20,
      [](auto& o) -> auto& { return o.daemon.motor.max_linear_mps; }, true));
  t.push_back(Number(
      "motor.max_angular_radps", "turn rate limit; commands are clamped", "rad/s", 0, 20,
      [](auto& o) -> auto& { return o.daemon.motor.max_angular_radps; }, true));
  t.push_back(Number(
      "motor.watchdog_s", "no command for this long: the motors stop", "s", 0, 60,
      [](auto& o) -> auto& { return o.daemon.motor.watchdog_s; }, true));
  t.push_back(Number(
      "motor.link_timeout_s", "board silent for this long: link lost, motors stopped", "s", 0, 60,
      [](auto& o) -> auto& { return o.daemon.motor.link_timeout_s; }, true));
  t.push_back(Number(
      "motor.full_power_mps", "calibration: side speed at full power (PWM +-16383, +-1000)", "m/s",
      0, 20, [](auto& o) -> auto& { return o.daemon.motor.full_power_mps; }, true));
  t.push_back(Number(
      "motor.track_width_m", "calibration: distance between left and right tracks", "m", 0, 5,
      [](auto& o) -> auto& { return o.daemon.motor.track_width_m; }, true));
  t.push_back(Number(
      "motor.counts_per_metre",
      "calibration: encoder counts per metre of side travel (undocumented; ~640 on a V2)",
      "counts/m", 0, 1e7, [](auto& o) -> auto& { return o.daemon.motor.counts_per_metre; }, true));
  t.push_back(Number(
      "motor.left_sign", "calibration: sign of the left side's power and encoder (1 or -1)", "", -1,
      1, [](auto& o) -> auto& { return o.daemon.motor.left_sign; }));
  t.push_back(Number(
      "motor.right_sign",
      "calibration: sign of the right side's power and encoder (1 or -1; mirrored sides: -1)", "",
      -1, 1, [](auto& o) -> auto& { return o.daemon.motor.right_sign; }));
  t.push_back(Number(
      "motor.forward_sign", "jaguar-v2: ch3 PWM above 16384 drives forward (1) or back (-1)", "",
      -1, 1, [](auto& o) -> auto& { return o.daemon.motor.forward_sign; }));
  t.push_back(Number(
      "motor.turn_sign",
      "jaguar-v2: ch4 PWM above 16384 turns counter-clockwise (1) or clockwise (-1)", "", -1, 1,
      [](auto& o) -> auto& { return o.daemon.motor.turn_sign; }));
  for (size_t i = pipeline_keys; i < t.size(); ++i) t[i].scope = ConfigKey::Scope::kDaemon;
  return t;
}

void Apply(const ConfigKey& k, const std::string& value, Settings& options,
           const std::string& source) {
  try {
    k.set(options, value);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(source + ": " + k.key + " = " + Trim(value) + ": " + e.what());
  }
}

}  // namespace

std::string ConfigKey::RangeText() const {
  switch (kind) {
    case Kind::kBool:
      return "true|false";
    case Kind::kText:
      return text_range;
    case Kind::kInteger:
    case Kind::kReal:
      return range.Text();
  }
  return "";
}

const std::vector<ConfigKey>& ConfigTable() {
  static const std::vector<ConfigKey> table = BuildTable();
  return table;
}

const ConfigKey* FindConfigKey(const std::string& key) {
  for (const ConfigKey& k : ConfigTable()) {
    if (k.key == key) return &k;
  }
  return nullptr;
}

namespace {

// ConfigTable() as boost's INI parser sees it: every key a string option. Built once per
// process, like the table (the parser only reads it); rebuilt per file it was ~15 % of the
// configuration fuzz target's CPU time.
const po::options_description& IniOptions() {
  struct Ini {
    po::options_description desc;
    Ini() {
      for (const ConfigKey& k : ConfigTable()) {
        desc.add_options()(k.key.c_str(), po::value<std::string>());
      }
    }
  };
  static const Ini ini;
  return ini.desc;
}

}  // namespace

namespace {

// `text` with its control bytes (below 0x20, and 0x7F) written as \xNN: a config file's bytes
// quoted in an error reach a terminal or the journal, where an escape sequence would act.
std::string Printable(const std::string& text) {
  std::string out;
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte != 0x7F) {
      out += c;
      continue;
    }
    char escaped[5];
    std::snprintf(escaped, sizeof escaped, "\\x%02X", byte);
    out += escaped;
  }
  return out;
}

void ApplyConfigFileUnchecked(const fs::path& file, Settings& options) {
  const std::string name = file.string();
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw ConfigError(name + ": is a folder, not a config file");
  std::ifstream in(file);
  if (!in) throw ConfigError(name + ": cannot open config file");
  const po::options_description& desc = IniOptions();
  po::parsed_options parsed(&desc);
  try {
    parsed = po::parse_config_file(in, desc, /*allow_unregistered=*/true);
  } catch (const po::error& e) {
    throw ConfigError(name + ": " + e.what());
  }
  std::set<std::string> seen;
  for (const po::option& opt : parsed.options) {
    const ConfigKey* k = FindConfigKey(opt.string_key);
    if (opt.unregistered || k == nullptr) {
      throw ConfigError(name + ": unknown key '" + opt.string_key +
                        "' (`tsc config` lists every key)");
    }
    if (!seen.insert(k->key).second) throw ConfigError(name + ": key '" + k->key + "' given twice");
    Apply(*k, opt.value.empty() ? std::string() : opt.value.front(), options, name);
  }
}

}  // namespace

void ApplyConfigFile(const fs::path& file, Settings& options) {
  try {
    ApplyConfigFileUnchecked(file, options);
  } catch (const ConfigError& e) {
    throw ConfigError(Printable(e.what()));
  }
}

void ApplyOverride(const std::string& assignment, Settings& options, const std::string& origin) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos) {
    throw ConfigError(origin + " " + assignment + ": expected section.key=value");
  }
  const std::string key = Trim(assignment.substr(0, eq));
  const ConfigKey* k = FindConfigKey(key);
  if (k == nullptr) {
    throw ConfigError(origin + ": unknown key '" + key + "' (`tsc config` lists every key)");
  }
  Apply(*k, assignment.substr(eq + 1), options, origin);
}

Settings LoadSettings(const std::optional<fs::path>& file,
                      const std::vector<std::string>& overrides) {
  Settings options;
  if (file) ApplyConfigFile(*file, options);
  for (const std::string& o : overrides) ApplyOverride(o, options);
  try {
    options.pipeline.Validate();
    options.daemon.Validate();
  } catch (const std::exception& e) {
    std::string source = file ? file->string() : std::string();
    if (!overrides.empty()) source += source.empty() ? "--set" : " with --set";
    if (source.empty()) source = "built-in defaults";
    throw ConfigError(source + ": invalid configuration: " + e.what());
  }
  return options;
}

PipelineOptions LoadPipelineOptions(const std::optional<fs::path>& file,
                                    const std::vector<std::string>& overrides) {
  return LoadSettings(file, overrides).pipeline;
}

std::string DumpConfig(const Settings& options) {
  const Settings defaults;
  std::ostringstream out;
  out << "# tscd configuration. INI syntax: [section] headers, key = value, '#' comments.\n"
         "# Every key is optional; a key left out keeps its built-in default. Override any\n"
         "# key on the command line with --set section.key=value. Ranges are inclusive\n"
         "# unless marked with ( or ). Symbols follow the thesis (chapter 3, appendices A, C).\n";
  std::string section;
  for (const ConfigKey& k : ConfigTable()) {
    const size_t dot = k.key.find('.');
    const std::string sec = k.key.substr(0, dot);
    if (sec != section) {
      out << "\n[" << sec << "]\n";
      section = sec;
    }
    out << WrapComment(k.description + ".") << "#   ";
    if (!k.unit.empty()) out << "unit: " << k.unit << "; ";
    out << "range: " << k.RangeText() << "; default: " << k.get(defaults) << "\n";
    out << k.key.substr(dot + 1) << " = " << k.get(options) << "\n";
  }
  return out.str();
}

}  // namespace tsc
