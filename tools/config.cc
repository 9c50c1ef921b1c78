#include "tools/config.h"

#include <boost/program_options/options_description.hpp>
#include <boost/program_options/parsers.hpp>
#include <boost/program_options/value_semantic.hpp>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <type_traits>

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

std::string FormatBound(double v) {
  if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  return FormatNumber(v);
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

bool InRange(const ConfigKey& k, double v) {
  if (k.min_open ? v <= k.min : v < k.min) return false;
  if (k.max_open ? v >= k.max : v > k.max) return false;
  return true;
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
  if (!InRange(k, v)) {
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

// `field` is a generic lambda returning a reference to the option inside PipelineOptions
// (const or not), so one accessor serves both get and set.
template <typename Field>
ConfigKey Number(std::string key, std::string description, std::string unit, double min, double max,
                 Field field, bool min_open = false, bool max_open = false) {
  using T = std::remove_cvref_t<decltype(field(std::declval<PipelineOptions&>()))>;
  ConfigKey k;
  k.key = std::move(key);
  k.description = std::move(description);
  k.unit = std::move(unit);
  k.kind = std::is_integral_v<T> ? ConfigKey::Kind::kInteger : ConfigKey::Kind::kReal;
  k.min = min;
  k.max = max;
  k.min_open = min_open;
  k.max_open = max_open;
  k.get = [field](const PipelineOptions& o) { return FormatNumber(field(o)); };
  // The row is copied into the setter so the range check can name it.
  k.set = [field, row = k](PipelineOptions& o, const std::string& v) {
    field(o) = ParseNumber<T>(row, v);
  };
  return k;
}

template <typename Field>
ConfigKey Bool(std::string key, std::string description, Field field) {
  ConfigKey k;
  k.key = std::move(key);
  k.description = std::move(description);
  k.kind = ConfigKey::Kind::kBool;
  k.get = [field](const PipelineOptions& o) { return std::string(field(o) ? "true" : "false"); };
  k.set = [field](PipelineOptions& o, const std::string& v) { field(o) = ParseBool(v); };
  return k;
}

std::vector<ConfigKey> BuildTable() {
  std::vector<ConfigKey> t;
  // [robot]
  t.push_back(Number(
      "robot.id", "robot id, the first part of every place id <robot>:<n>", "", 1, 4294967295.0,
      [](auto& o) -> auto& { return o.robot; }));
  // [bubble] — bubble space, appendix A and chapter 2
  {
    ConfigKey k;
    k.key = "bubble.features";
    k.description =
        "feature set (section 2.3): L1 hue + Cartesian gratings, L2 = L1 + non-Cartesian "
        "gratings, L3 depth, L4 = L1 + depth, L5 = L2 + depth; +I appends intensity (the "
        "default, place detection needs it), -I leaves it out";
    k.kind = ConfigKey::Kind::kText;
    k.text_range = "L1..L5, optionally followed by +I or -I";
    k.get = [](const PipelineOptions& o) { return o.features.ToString(); };
    k.set = [](PipelineOptions& o, const std::string& v) {
      o.features = FeatureSet::Parse(Trim(v));
    };
    t.push_back(std::move(k));
  }
  {
    ConfigKey k = Number(
        "bubble.d_phi_deg", "d_phi, spacing of the grid of viewing directions; must divide 180",
        "degrees", 0, 90, [](auto& o) -> auto& { return o.surface.d_phi_deg; },
        /*min_open=*/true);
    k.set = [in_range = k.set](PipelineOptions& o, const std::string& v) {
      in_range(o, v);
      const double steps = 180.0 / o.surface.d_phi_deg;
      if (std::abs(steps - std::round(steps)) > 1e-9 * steps) {
        throw std::invalid_argument("does not divide 180 into whole steps (e.g. 1, 2.5, 5)");
      }
    };
    t.push_back(std::move(k));
  }
  t.push_back(Number(
      "bubble.rest_radius", "rho_0, radius of directions never observed", "feature value", 0, 1,
      [](auto& o) -> auto& { return o.surface.rest_radius; }));
  t.push_back(Number(
      "bubble.max_depth_m", "range that maps to depth feature value 1", "m", 0, 1000,
      [](auto& o) -> auto& { return o.surface.max_depth_m; },
      /*min_open=*/true));
  t.push_back(Number(
      "bubble.patch_px", "side of the resampled d_phi x d_phi image patch", "pixels", 6, 64,
      [](auto& o) -> auto& { return o.surface.patch_px; }));
  // [descriptor] — (A.3)-(A.7)
  t.push_back(Number(
      "descriptor.harmonics_pan", "H1, harmonics of the Fourier series in pan", "", 0, 64,
      [](auto& o) -> auto& { return o.descriptor.h1; }));
  t.push_back(Number(
      "descriptor.harmonics_tilt", "H2, harmonics of the Fourier series in tilt", "", 0, 64,
      [](auto& o) -> auto& { return o.descriptor.h2; }));
  t.push_back(Bool(
      "descriptor.amplitude",
      "true: entries sqrt(z^T z) (amplitude); false: z^T z as in (A.7) (energy)",
      [](auto& o) -> auto& { return o.descriptor.amplitude; }));
  t.push_back(Bool(
      "descriptor.block_sum",
      "true: each feature block sums to 1/N_v; false: fixed scale keeping feature levels",
      [](auto& o) -> auto& { return o.descriptor.block_sum; }));
  // [detection] — section 3.4, appendix C
  t.push_back(Number(
      "detection.tau_mu", "tau_mu, mean intensity at or below which a base point is uninformative",
      "intensity", 0, 1, [](auto& o) -> auto& { return o.reliability.tau_mu; }));
  t.push_back(Number(
      "detection.tau_sigma",
      "tau_sigma, intensity variance at or below which a base point is "
      "uninformative",
      "intensity^2", 0, 0.25, [](auto& o) -> auto& { return o.reliability.tau_sigma; }));
  t.push_back(Number(
      "detection.tau_kappa",
      "tau_kappa, chi^2 to the previous descriptor above which a base point is "
      "incoherent",
      "chi^2", 0, 1, [](auto& o) -> auto& { return o.reliability.tau_kappa; }));
  t.push_back(Number(
      "detection.tau_n",
      "tau_n, a bad base point within this many points extends the temporal "
      "window",
      "base points", 1, 100000, [](auto& o) -> auto& { return o.detector.tau_n; }));
  t.push_back(Number(
      "detection.tau_w",
      "tau_w, temporal windows this long or longer are transitions, shorter ones "
      "noise",
      "base points", 1, 100000, [](auto& o) -> auto& { return o.detector.tau_w; }));
  t.push_back(Number(
      "detection.tau_p", "tau_p, detected places with this many base points or fewer are pruned",
      "base points", 0, 100000, [](auto& o) -> auto& { return o.detector.tau_p; }));
  // [memory] — sections 3.3, 3.5, 3.6
  t.push_back(Number(
      "memory.tau_r", "tau_r, recognition threshold on the cost g_N of (3.8)", "", 0, 1000,
      [](auto& o) -> auto& { return o.memory.tau_r; },
      /*min_open=*/true));
  t.push_back(Number(
      "memory.tau_l", "tau_l, levels the hybrid traversal climbs", "levels", 0, 1000,
      [](auto& o) -> auto& { return o.memory.tau_l; }));
  t.push_back(Number(
      "memory.tau_h",
      "tau_h, relative merge-height gap under which the tree simplification folds "
      "a node into its parent",
      "", 0, 1, [](auto& o) -> auto& { return o.memory.tau_h; }, false,
      /*max_open=*/true));
  t.push_back(Number(
      "memory.max_samples_per_place", "representative member descriptors kept per learned place",
      "descriptors", 1, 100000, [](auto& o) -> auto& { return o.memory.max_samples_per_place; }));
  t.push_back(Number(
      "memory.max_vote_points",
      "base points of a detected place used for the vote V_N (evenly spaced)", "base points", 1,
      100000, [](auto& o) -> auto& { return o.memory.max_vote_points; }));
  t.push_back(Number(
      "memory.svm_nu", "nu of the one-class SVM discriminants d_N", "", 0, 1,
      [](auto& o) -> auto& { return o.memory.discriminant.nu; },
      /*min_open=*/true));
  t.push_back(Number(
      "memory.svm_gamma", "RBF gamma of d_N; 0 = 1 / median squared distance of the training set",
      "1/descriptor distance^2", 0, 1e9,
      [](auto& o) -> auto& { return o.memory.discriminant.gamma; }));
  t.push_back(Number(
      "memory.svm_max_training", "cap of training vectors per node (deterministic subsample)",
      "descriptors", 2, 10000000,
      [](auto& o) -> auto& { return o.memory.discriminant.max_training; }));
  // [pipeline]
  t.push_back(Bool(
      "pipeline.recognize_partial",
      "try recognition when a place opens (its extent passes tau_p), before it "
      "closes",
      [](auto& o) -> auto& { return o.recognize_partial; }));
  return t;
}

void Apply(const ConfigKey& k, const std::string& value, PipelineOptions& options,
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
      return std::string(min_open ? "(" : "[") + FormatBound(min) + ", " + FormatBound(max) +
             (max_open ? ")" : "]");
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

void ApplyConfigFile(const fs::path& file, PipelineOptions& options) {
  const std::string name = file.string();
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw ConfigError(name + ": is a folder, not a config file");
  std::ifstream in(file);
  if (!in) throw ConfigError(name + ": cannot open config file");
  po::options_description desc;
  for (const ConfigKey& k : ConfigTable()) {
    desc.add_options()(k.key.c_str(), po::value<std::string>());
  }
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

void ApplyOverride(const std::string& assignment, PipelineOptions& options) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos) {
    throw ConfigError("--set " + assignment + ": expected section.key=value");
  }
  const std::string key = Trim(assignment.substr(0, eq));
  const ConfigKey* k = FindConfigKey(key);
  if (k == nullptr) {
    throw ConfigError("--set: unknown key '" + key + "' (`tsc config` lists every key)");
  }
  Apply(*k, assignment.substr(eq + 1), options, "--set");
}

PipelineOptions LoadPipelineOptions(const std::optional<fs::path>& file,
                                    const std::vector<std::string>& overrides) {
  PipelineOptions options;
  if (file) ApplyConfigFile(*file, options);
  for (const std::string& o : overrides) ApplyOverride(o, options);
  try {
    options.Validate();
  } catch (const std::exception& e) {
    std::string source = file ? file->string() : std::string();
    if (!overrides.empty()) source += source.empty() ? "--set" : " with --set";
    if (source.empty()) source = "built-in defaults";
    throw ConfigError(source + ": invalid configuration: " + e.what());
  }
  return options;
}

std::string DumpConfig(const PipelineOptions& options) {
  const PipelineOptions defaults;
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
