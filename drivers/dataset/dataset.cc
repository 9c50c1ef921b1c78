#include "drivers/dataset/dataset.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <system_error>
#include <utility>

#include "core/median.h"
#include "drivers/dataset/json_reader.h"
#include "drivers/dataset/revisit_bitmap.h"
#include "drivers/image/bounded_decode.h"
#include "drivers/image/image_header.h"

namespace tsc {
namespace fs = std::filesystem;

namespace {

constexpr double kDefaultHfovDeg = 60.0;
// Largest image side camera.json may state (width, height), in pixels.
constexpr int kMaxImageSide = 65535;

[[noreturn]] void Fail(const fs::path& where, const std::string& what) {
  throw DatasetError(where, what);
}

// The bytes of `file` (empty when it cannot be read).
std::vector<uint8_t> ReadBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
}

// Decodes `file` as a JPEG or PNG (DecodeBounded: by its first bytes, never another decoder —
// cv::imread picked one by content, and GDCM aborted the process on a malformed "*.png" holding
// "DICM", found by fuzz/dataset_fuzz, regression in fuzz/regressions/fuzz_dataset_image) and
// only once its header passes `limits`: a 1 MB PNG claiming 20000x20000 is refused before
// anything is allocated for it. Throws DatasetError naming the file, its claimed size and
// `what` it is ("image", "depth image").
cv::Mat ReadJpegOrPng(const fs::path& file, PixelLayout layout, const ImageLimits& limits,
                      const char* what) {
  const std::vector<uint8_t> bytes = ReadBytes(file);
  if (bytes.empty()) Fail(file, std::string("unreadable ") + what + " (missing or empty)");
  if (!LooksLikePngOrJpeg(bytes)) {
    Fail(file, std::string("unreadable ") + what + " (not a JPEG/PNG by its first bytes)");
  }
  DecodedImage decoded = DecodeBounded(bytes, layout, limits);
  if (!decoded.ok()) Fail(file, std::string("unreadable ") + what + ": " + decoded.error);
  return std::move(decoded.image);
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool IsImageFile(const fs::directory_entry& entry) {
  std::error_code ec;
  if (!entry.is_regular_file(ec)) return false;
  const std::string ext = Lower(entry.path().extension().string());
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png";
}

std::vector<fs::path> ListImages(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) Fail(dir, "cannot list folder: " + ec.message());
  for (const fs::directory_entry& entry : it) {
    if (IsImageFile(entry)) out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end(), [](const fs::path& a, const fs::path& b) {
    return NaturalLess(a.filename().string(), b.filename().string());
  });
  return out;
}

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::string Unquote(const std::string& s) {
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') return s.substr(1, s.size() - 2);
  return s;
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(Unquote(Trim(field)));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

bool ParseInt(const std::string& s, long* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (errno != 0 || end != s.c_str() + s.size()) return false;
  *out = v;
  return true;
}

bool ParseDouble(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

/// Reads the non-empty lines of a CSV file; drops a header line (first field not a number).
std::vector<std::pair<int, std::vector<std::string>>> ReadCsv(const fs::path& file) {
  std::ifstream in(file);
  if (!in) Fail(file, "cannot open");
  std::vector<std::pair<int, std::vector<std::string>>> rows;
  std::string line;
  int number = 0;
  bool first = true;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (Trim(line).empty() || Trim(line)[0] == '#') continue;
    std::vector<std::string> fields = SplitCsv(line);
    long ignored;
    if (first && !ParseInt(fields.front(), &ignored)) {  // header line
      first = false;
      continue;
    }
    first = false;
    rows.emplace_back(number, std::move(fields));
  }
  return rows;
}

/// The 1-based frame number in `field` as a 0-based index, checked against the frame count.
int FrameIndex(const fs::path& file, int line, const std::string& field, int frames) {
  long v;
  if (!ParseInt(field, &v)) {
    Fail(file, "line " + std::to_string(line) + ": frame '" + field + "' is not a number");
  }
  if (v < 1 || v > frames) {
    Fail(file, "line " + std::to_string(line) + ": frame " + field + " outside 1.." +
                   std::to_string(frames) + " (the dataset's frames)");
  }
  return static_cast<int>(v - 1);
}

// ---- camera.json: a JSON object; its numeric members and "keyframes" are read (others are
// ignored).

// The JSON object of `text`; fails naming `file` when it is not one.
JsonValue ReadObject(const fs::path& file, const std::string& text) {
  JsonValue root;
  try {
    root = ParseJson(text);
  } catch (const std::runtime_error& e) {
    Fail(file, e.what());
  }
  if (root.kind != JsonValue::Kind::kObject) Fail(file, "expected a JSON object");
  return root;
}

// The numeric members of `root` (others are ignored).
std::map<std::string, double> Numbers(const JsonValue& root) {
  std::map<std::string, double> out;
  for (size_t i = 0; i < root.keys.size(); ++i) {
    if (root.items[i].kind == JsonValue::Kind::kNumber) out[root.keys[i]] = root.items[i].number;
  }
  return out;
}

struct CameraFile {
  CameraIntrinsics camera;  ///< of one view
  PanSweep sweep;
  std::optional<BasePointSpacing> spacing;  ///< when declared
};

// "spacing_m", "fps" or "keyframes" of camera.json; nullopt when none is given.
std::optional<BasePointSpacing> DeclaredSpacing(const fs::path& file, const JsonValue& root) {
  std::optional<BasePointSpacing> out;
  for (size_t i = 0; i < root.keys.size(); ++i) {
    const std::string& key = root.keys[i];
    const JsonValue& v = root.items[i];
    if (key != "spacing_m" && key != "fps" && key != "keyframes") continue;
    if (out) Fail(file, "give one of \"spacing_m\", \"fps\" and \"keyframes\"");
    if (key == "keyframes") {
      if (v.kind != JsonValue::Kind::kBool || !v.boolean) {
        Fail(file, "\"keyframes\" must be true when given");
      }
      out = BasePointSpacing{kKeyframeSpacingM, "camera.json keyframes", /*keyframes=*/true};
      continue;
    }
    const double most = key == "fps" ? 1000.0 : 100.0;
    if (v.kind != JsonValue::Kind::kNumber || !(v.number > 0.0 && v.number <= most)) {
      Fail(file, "\"" + key + "\" must be a number in (0, " +
                     std::to_string(static_cast<int>(most)) + "]");
    }
    out = key == "fps" ? BasePointSpacing{kAssumedSpeedMps / v.number, "camera.json fps"}
                       : BasePointSpacing{v.number, "camera.json spacing_m"};
  }
  return out;
}

// Median distance between consecutive posed frames while the camera moves: steps under a
// quarter of the 90th percentile are a camera standing still or turning on the spot (its pose
// jitters, it does not travel) and say nothing of its spacing. nullopt with fewer than two
// steps or none that moves.
std::optional<double> MedianPoseStep(const std::vector<std::optional<GroundTruthPose>>& poses) {
  std::vector<double> steps;
  for (size_t i = 1; i < poses.size(); ++i) {
    if (poses[i] && poses[i - 1]) {
      steps.push_back(std::hypot(poses[i]->x - poses[i - 1]->x, poses[i]->y - poses[i - 1]->y));
    }
  }
  if (steps.size() < 2) return std::nullopt;
  const auto p90 = steps.begin() + static_cast<long>(steps.size() * 9 / 10);
  std::nth_element(steps.begin(), p90, steps.end());
  const double moving = *p90 / 4.0;
  std::erase_if(steps, [moving](double s) { return !(s > moving); });
  if (steps.empty()) return std::nullopt;
  return UpperMedian(std::move(steps));
}

CameraFile ReadCamera(const fs::path& file, int image_width, int height) {
  std::ifstream in(file);
  if (!in) Fail(file, "cannot open");
  std::stringstream text;
  text << in.rdbuf();
  const JsonValue root = ReadObject(file, text.str());
  const std::map<std::string, double> v = Numbers(root);
  const std::optional<BasePointSpacing> spacing = DeclaredSpacing(file, root);
  const auto has = [&](const char* k) { return v.count(k) > 0; };
  // A whole-number member in [1, most] (`fallback` when absent), checked before it becomes
  // an int: a value beyond int's range would be undefined behaviour.
  const auto whole = [&](const char* k, int most, int fallback) {
    if (!has(k)) return fallback;
    const double x = v.at(k);
    if (x != std::floor(x) || x < 1 || x > most) {
      Fail(file, "\"" + std::string(k) + "\" must be a whole number in [1, " +
                     std::to_string(most) + "]");
    }
    return static_cast<int>(x);
  };
  PanSweep sweep;
  try {
    if (has("sweep_views") || has("sweep_deg")) {
      sweep = PanSweep(whole("sweep_views", 360, 1), has("sweep_deg") ? v.at("sweep_deg") : 360.0);
    }
  } catch (const std::invalid_argument& e) {
    Fail(file, e.what());
  }
  if (image_width % sweep.views() != 0) {
    Fail(file, "images are " + std::to_string(image_width) + " pixels wide, not a multiple of " +
                   std::to_string(sweep.views()) + " sweep views");
  }
  const int width = image_width / sweep.views();  // one view's
  const int cam_w = whole("width", kMaxImageSide, width);
  const int cam_h = whole("height", kMaxImageSide, height);
  try {
    std::optional<CameraIntrinsics> camera;
    if (has("fx") && has("fy") && has("cx") && has("cy")) {
      camera.emplace(cam_w, cam_h, v.at("fx"), v.at("fy"), v.at("cx"), v.at("cy"));
    } else if (has("hfov_deg")) {
      camera = CameraIntrinsics::FromHorizontalFov(cam_w, cam_h, v.at("hfov_deg"));
    } else {
      Fail(file, "needs \"hfov_deg\" or all of \"fx\", \"fy\", \"cx\", \"cy\"");
    }
    if (cam_w == width && cam_h == height) return CameraFile{*camera, sweep, spacing};
    // Calibrated at another resolution: scale when the aspect ratio is the same.
    const double ratio =
        (static_cast<double>(cam_w) / cam_h) / (static_cast<double>(width) / height);
    if (std::abs(ratio - 1.0) > 0.01) {
      Fail(file, "camera is " + std::to_string(cam_w) + "x" + std::to_string(cam_h) +
                     " but the images' views are " + std::to_string(width) + "x" +
                     std::to_string(height));
    }
    return CameraFile{camera->Scaled(width, height), sweep, spacing};
  } catch (const std::invalid_argument& e) {
    Fail(file, e.what());
  }
}

}  // namespace

bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      size_t ei = i, ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei]))) ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej]))) ++ej;
      // Compare by value: skip leading zeros, then the longer run is larger.
      size_t zi = i, zj = j;
      while (zi + 1 < ei && a[zi] == '0') ++zi;
      while (zj + 1 < ej && b[zj] == '0') ++zj;
      if (ei - zi != ej - zj) return ei - zi < ej - zj;
      const int c = a.compare(zi, ei - zi, b, zj, ej - zj);
      if (c != 0) return c < 0;
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return a.size() - i < b.size() - j;
  return a < b;  // equal by value ("01" vs "1"): a total order all the same
}

Dataset::Dataset(fs::path folder, std::vector<fs::path> images, std::vector<fs::path> depths,
                 CameraIntrinsics camera, PanSweep sweep, cv::Size frame_size,
                 DatasetOptions options)
    : folder_(std::move(folder)),
      images_(std::move(images)),
      depths_(std::move(depths)),
      camera_(camera),
      sweep_(sweep),
      frame_size_(frame_size),
      options_(options) {}

void DatasetOptions::Validate() const {
  if (max_image_pixels < 1) {
    throw std::invalid_argument("dataset: max_image_pixels " + std::to_string(max_image_pixels) +
                                " must be at least 1");
  }
}

Dataset Dataset::Open(const fs::path& folder, const DatasetOptions& options) {
  options.Validate();
  std::error_code ec;
  if (!fs::exists(folder, ec)) Fail(folder, "no such dataset folder");
  if (!fs::is_directory(folder, ec)) Fail(folder, "not a folder (a dataset is a folder of images)");

  const fs::path rgb = folder / "rgb";
  const fs::path frame_dir = fs::is_directory(rgb, ec) ? rgb : folder;
  std::vector<fs::path> images = ListImages(frame_dir);
  if (images.empty()) Fail(frame_dir, "no images (*.jpg, *.jpeg, *.png) in the folder");
  // The frame that gives the size: the first, or with kLoadFails the first that is not empty.
  const fs::path* sized = nullptr;
  for (const fs::path& p : images) {
    const auto bytes = fs::file_size(p, ec);
    if (ec) Fail(p, "cannot read: " + ec.message());
    if (bytes == 0 && options.empty_images == EmptyImages::kRefuse) {
      Fail(p, "empty image file (0 bytes)");
    }
    if (bytes > 0 && sized == nullptr) sized = &p;
  }
  if (sized == nullptr) Fail(frame_dir, "every image file is empty (0 bytes)");

  // The first frame that is not empty sets the dataset's frame size; it is decoded (bounded)
  // to be sure it can be.
  ImageLimits first_limits;
  first_limits.max_pixels = options.max_image_pixels;
  const cv::Mat first = ReadJpegOrPng(*sized, PixelLayout::kBgr, first_limits, "image");

  std::vector<fs::path> depths;
  const fs::path depth_dir = folder / "depth";
  if (fs::is_directory(depth_dir, ec)) {
    depths.reserve(images.size());
    for (const fs::path& p : images) {
      fs::path d = depth_dir / p.filename().replace_extension(".png");
      if (!fs::is_regular_file(d, ec)) {
        Fail(d, "missing depth image for frame " + p.filename().string());
      }
      depths.push_back(std::move(d));
    }
  }

  const fs::path camera_file = folder / "camera.json";
  const CameraFile camera =
      fs::exists(camera_file, ec)
          ? ReadCamera(camera_file, first.cols, first.rows)
          : CameraFile{CameraIntrinsics::FromHorizontalFov(first.cols, first.rows, kDefaultHfovDeg),
                       PanSweep(), std::nullopt};

  Dataset ds(folder, std::move(images), std::move(depths), camera.camera, camera.sweep,
             cv::Size(first.cols, first.rows), options);
  const int n = ds.size();

  const fs::path truth_file = folder / "groundtruth.csv";
  if (fs::exists(truth_file, ec)) {
    ds.labels_.assign(n, "");
    for (const auto& [line, fields] : ReadCsv(truth_file)) {
      const int f = FrameIndex(truth_file, line, fields[0], n);
      if (fields.size() >= 2) ds.labels_[f] = fields[1];
      if (fields.size() >= 5) {
        GroundTruthPose pose;
        if (!ParseDouble(fields[2], &pose.x) || !ParseDouble(fields[3], &pose.y) ||
            !ParseDouble(fields[4], &pose.heading)) {
          Fail(truth_file, "line " + std::to_string(line) + ": x,y,heading must be numbers");
        }
        if (ds.poses_.empty()) ds.poses_.assign(n, std::nullopt);
        ds.poses_[f] = pose;
      } else if (fields.size() > 2 && !(fields.size() == 3 && fields[2].empty())) {
        Fail(truth_file,
             "line " + std::to_string(line) + ": expected frame,place or frame,place,x,y,heading");
      }
    }
  }

  if (camera.spacing) {
    ds.spacing_ = *camera.spacing;
  } else if (const std::optional<double> step = MedianPoseStep(ds.poses_)) {
    ds.spacing_ = BasePointSpacing{*step, "poses (median step)"};
  } else {
    ds.spacing_ =
        BasePointSpacing{kKeyframeSpacingM, "undeclared: keyframes assumed", /*keyframes=*/true,
                         /*assumed=*/true};
  }

  const fs::path revisits_file = folder / "revisits.csv";
  if (fs::exists(revisits_file, ec)) {
    ds.revisits_file_ = revisits_file.filename().string();
    ds.revisits_.assign(n, {});
    for (const auto& [line, fields] : ReadCsv(revisits_file)) {
      const int f = FrameIndex(revisits_file, line, fields[0], n);
      if (fields.size() < 2) continue;
      std::istringstream in(fields[1]);
      std::string token;
      while (in >> token) {
        const int r = FrameIndex(revisits_file, line, token, n);
        if (r >= f) {
          Fail(revisits_file, "line " + std::to_string(line) + ": frame " + token +
                                  " is not earlier than frame " + fields[0]);
        }
        ds.revisits_[f].push_back(r);
      }
    }
  } else if (const fs::path bitmap = folder / kRevisitBitmapName; fs::exists(bitmap, ec)) {
    ds.revisits_ = ReadRevisitBitmap(bitmap, n);
    ds.revisits_file_ = kRevisitBitmapName;
  }
  return ds;
}

std::vector<Observation> Dataset::Load(int i) const {
  if (i < 0 || i >= size()) {
    throw DatasetError(folder_.string() + ": frame index " + std::to_string(i) + " out of range");
  }
  const fs::path& file = images_[i];
  // Every frame must have the first frame's size: by its header, before it is decoded.
  ImageLimits limits;
  limits.max_pixels = options_.max_image_pixels;
  limits.exact_size = frame_size_;
  Observation obs;
  obs.bgr = ReadJpegOrPng(file, PixelLayout::kBgr, limits, "image");
  if (obs.bgr.size() != frame_size_) {  // a JPEG turned by its EXIF orientation
    Fail(file, "image is " + std::to_string(obs.bgr.cols) + "x" + std::to_string(obs.bgr.rows) +
                   " but the dataset's frames are " + std::to_string(frame_size_.width) + "x" +
                   std::to_string(frame_size_.height));
  }
  if (has_depth()) {
    const fs::path& dfile = depths_[i];
    const cv::Mat raw = ReadJpegOrPng(dfile, PixelLayout::kUnchanged, limits, "depth image");
    if (raw.type() != CV_16UC1) Fail(dfile, "depth must be a single-channel 16-bit PNG (mm)");
    if (raw.size() != obs.bgr.size()) {
      Fail(dfile, "depth is " + std::to_string(raw.cols) + "x" + std::to_string(raw.rows) +
                      " but its frame " + file.filename().string() + " is " +
                      std::to_string(obs.bgr.cols) + "x" + std::to_string(obs.bgr.rows));
    }
    raw.convertTo(obs.depth_m, CV_32F, 0.001);  // mm → m; 0 stays "no reading"
  }
  return SplitSweep(std::move(obs), sweep_);
}

std::vector<Observation> SplitSweep(Observation strip, const PanSweep& sweep) {
  const int views = sweep.views();
  if (views == 1) return {std::move(strip)};
  const int width = strip.bgr.cols / views;
  std::vector<Observation> out(static_cast<size_t>(views));
  for (int j = 0; j < views; ++j) {
    const cv::Rect roi(j * width, 0, width, strip.bgr.rows);
    Observation& view = out[static_cast<size_t>(j)];
    view.bgr = strip.bgr(roi).clone();
    if (!strip.depth_m.empty()) view.depth_m = strip.depth_m(roi).clone();
    view.pan_tilt = sweep.View(j);
  }
  return out;
}

Dataset Dataset::EveryNth(int stride) const {
  if (stride < 1) throw std::invalid_argument("dataset stride " + std::to_string(stride));
  if (stride == 1) return *this;
  std::vector<int> frames;
  for (int i = 0; i < size(); i += stride) frames.push_back(i);
  Dataset out = Subset(frames);
  out.spacing_ = tsc::EveryNth(spacing_, stride);
  return out;
}

Dataset Dataset::Subset(const std::vector<int>& frames) const {
  for (size_t j = 0; j < frames.size(); ++j) {
    if (frames[j] < 0 || frames[j] >= size() || (j > 0 && frames[j] <= frames[j - 1])) {
      throw std::invalid_argument("dataset subset: frame " + std::to_string(frames[j]) +
                                  " out of order or outside 0.." + std::to_string(size() - 1));
    }
  }
  Dataset out = *this;
  const auto take = [&frames](auto& v) {
    if (v.empty()) return;
    std::remove_reference_t<decltype(v)> kept;
    kept.reserve(frames.size());
    for (int f : frames) kept.push_back(std::move(v[static_cast<size_t>(f)]));
    v = std::move(kept);
  };
  take(out.images_);
  take(out.depths_);
  take(out.labels_);
  take(out.poses_);
  take(out.revisits_);
  // A revisit names the taken frame nearest it (the later one on a tie).
  const auto nearest_taken = [&frames](int r) {
    const auto after = std::lower_bound(frames.begin(), frames.end(), r);
    if (after == frames.begin()) return 0;
    if (after == frames.end()) return static_cast<int>(frames.size()) - 1;
    const auto before = after - 1;
    return static_cast<int>((r - *before < *after - r ? before : after) - frames.begin());
  };
  for (size_t i = 0; i < out.revisits_.size(); ++i) {
    std::vector<int> nearest;
    for (int r : out.revisits_[i]) {
      const int taken = nearest_taken(r);
      if (static_cast<size_t>(taken) < i) nearest.push_back(taken);
    }
    std::sort(nearest.begin(), nearest.end());
    nearest.erase(std::unique(nearest.begin(), nearest.end()), nearest.end());
    out.revisits_[i] = std::move(nearest);
  }
  return out;
}

}  // namespace tsc
