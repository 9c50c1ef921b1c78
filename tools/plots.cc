#include "tools/plots.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "drivers/dataset/json_reader.h"
#include "tools/inspect.h"
#include "tools/label_placer.h"

namespace tsc {
namespace fs = std::filesystem;

namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kText(30, 30, 30);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kAxis(90, 90, 90);
const cv::Scalar kUninformative(240, 200, 150);  // light blue (BGR)
const cv::Scalar kIncoherent(190, 110, 40);      // dark blue
const cv::Scalar kTransition(70, 70, 225);       // red
const cv::Scalar kRevisit(120, 120, 120);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// Qualitative palette, BGR, without the blues and reds that mark status and transitions.
cv::Scalar Palette(size_t i) {
  static const cv::Scalar colours[] = {
      {14, 127, 255},  {44, 160, 44},  {189, 103, 148}, {34, 189, 188},  {75, 86, 140},
      {194, 119, 227}, {207, 190, 23}, {120, 187, 255}, {138, 223, 152}, {213, 176, 197},
      {148, 156, 196}, {0, 200, 255},  {141, 219, 219}, {229, 218, 158}, {127, 127, 127},
      {60, 120, 60},   {160, 60, 120}, {0, 140, 200},   {100, 160, 140}, {199, 199, 199}};
  return colours[i % (sizeof(colours) / sizeof(colours[0]))];
}

// Dark text on light colours, white text on dark ones.
cv::Scalar TextOn(const cv::Scalar& bg) {
  const double luma = 0.114 * bg[0] + 0.587 * bg[1] + 0.299 * bg[2];
  return luma > 140 ? kText : kWhite;
}

void Text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.45,
          const cv::Scalar& colour = kText, int thickness = 1) {
  cv::putText(img, s, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

cv::Size TextSize(const std::string& s, double scale = 0.45, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, scale, thickness, &baseline);
}

// A place's name beside its marker (where `labels` finds room), on white so that it reads over
// edges and walls. A name moved off the marker's row gets a thin line to the marker.
void PlaceLabel(cv::Mat& img, LabelPlacer& labels, const std::string& s, cv::Point at, int radius) {
  const cv::Size t = TextSize(s, 0.42);
  const cv::Rect box = labels.Place({t.width + 4, t.height + 7}, at, radius);
  if (at.y < box.y || at.y >= box.y + box.height) {
    const cv::Point near(std::clamp(at.x, box.x, box.x + box.width - 1),
                         std::clamp(at.y, box.y, box.y + box.height - 1));
    const cv::Point2d d = near - at;
    const double length = std::hypot(d.x, d.y);
    if (length > radius) {
      const cv::Point from =
          at + cv::Point(cvRound(d.x * radius / length), cvRound(d.y * radius / length));
      cv::line(img, from, near, kAxis, 1, cv::LINE_AA);
    }
  }
  cv::rectangle(img, box, kWhite, cv::FILLED);
  Text(img, s, {box.x + 2, box.y + t.height + 3}, 0.42);
}

// Text centred in `box` when it fits.
void CentredText(cv::Mat& img, const std::string& s, const cv::Rect& box, const cv::Scalar& bg,
                 double scale = 0.4) {
  const cv::Size t = TextSize(s, scale);
  if (t.width + 4 > box.width) return;
  Text(img, s, {box.x + (box.width - t.width) / 2, box.y + (box.height + t.height) / 2}, scale,
       TextOn(bg));
}

std::string Fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// 1, 2, 5, 10, 20, 50, ... so that about `target` ticks cover `range`.
int TickStep(int range, int target) {
  int step = 1;
  for (int scale = 1;; scale *= 10) {
    for (int m : {1, 2, 5}) {
      step = m * scale;
      if (range / step <= target) return step;
    }
  }
}

// Text rotated by 90° counter-clockwise, drawn with its top-left corner at `at`.
void VerticalText(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5) {
  const cv::Size t = TextSize(s, scale);
  cv::Mat patch(t.height + 8, t.width + 4, CV_8UC3, kWhite);
  Text(patch, s, {2, t.height + 2}, scale);
  cv::Mat rotated;
  cv::rotate(patch, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect roi(at.x, at.y, rotated.cols, rotated.rows);
  if ((roi & cv::Rect(0, 0, img.cols, img.rows)) == roi) rotated.copyTo(img(roi));
}

// Index of each learned place (by id order) for its colour. A place a consolidation folded
// into another (pipeline.consolidate_after) is no learned place at the end, yet the detected
// places that learned or recognised it name it: it takes the colour of the place holding it.
std::map<PlaceId, size_t> PlaceColours(const EvalRun& run) {
  std::map<PlaceId, size_t> out;
  for (const auto& [id, frames] : run.frames_of) {
    const size_t i = out.size();
    out[id] = i;
  }
  std::map<PlaceId, PlaceId> into;
  for (const EvalDetectedPlace& d : run.detected) {
    for (const PlaceId& f : d.folded) {
      if (d.place) into[f] = *d.place;
    }
  }
  for (const auto& [folded, first] : into) {
    PlaceId holder = first;
    for (size_t hops = 0; hops < into.size() && into.contains(holder); ++hops) {
      holder = into.at(holder);
    }
    const auto colour = out.find(holder);
    if (colour != out.end()) out.emplace(folded, colour->second);
  }
  return out;
}

// A legend entry at `at`, which moves on; wraps to a new line starting at `line_x` when the
// entry would leave the image.
void Swatch(cv::Mat& img, cv::Point& at, const cv::Scalar& colour, const std::string& label,
            int line_x) {
  if (at.x + 50 + TextSize(label).width > img.cols && at.x > line_x) at = {line_x, at.y + 24};
  const cv::Rect box(at.x, at.y - 11, 22, 14);
  cv::rectangle(img, box, colour, cv::FILLED);
  cv::rectangle(img, box, kAxis, 1);
  Text(img, label, {at.x + 28, at.y});
  at.x += 28 + TextSize(label).width + 22;
}

// Colours of the floor plan.
const cv::Scalar kRoomFloor(247, 247, 247), kOutdoorFloor(240, 247, 240);
const cv::Scalar kBox(205, 205, 205), kWall(70, 70, 70), kDoor(150, 205, 240);
const cv::Scalar kRoomLabel(160, 160, 160);
const cv::Scalar kMapEdgeOverWorld(150, 70, 130);

// The drawing area of a floor plan: the extent of what is drawn (points, then the world's
// rooms and walls), one scale along x and y, y up, the plan centred horizontally.
class PlanLayout {
 public:
  void Extend(double x, double y) {
    min_x_ = std::min(min_x_, x), max_x_ = std::max(max_x_, x);
    min_y_ = std::min(min_y_, y), max_y_ = std::max(max_y_, y);
  }
  bool empty() const { return min_x_ > max_x_; }
  /// A white image with the plan's longer side `area` pixels, `top` pixels of title above and
  /// `bottom` of legend below, at least `min_width` wide. Precondition: !empty().
  cv::Mat Canvas(const WorldPlan* world, int area, int top, int bottom, int min_width) {
    if (world) {
      for (const WorldPlan::Room& room : world->rooms) {
        Extend(room.rect.x0, room.rect.y0), Extend(room.rect.x1, room.rect.y1);
      }
      for (const WorldPlan::Rect& w : world->walls) Extend(w.x0, w.y0), Extend(w.x1, w.y1);
    }
    const double span = std::max({max_x_ - min_x_, max_y_ - min_y_, 1e-9});
    scale_ = area / span;  // pixels per unit, the same along x and y
    const int plan_w = static_cast<int>(std::lround((max_x_ - min_x_) * scale_));
    plan_h_ = static_cast<int>(std::lround((max_y_ - min_y_) * scale_));
    const int w = std::max(plan_w + 2 * kMargin, min_width);
    x_off_ = (w - plan_w) / 2;
    top_ = top;
    return cv::Mat(top + plan_h_ + 2 * kMargin + bottom, w, CV_8UC3, kWhite);
  }
  cv::Point Px(double x, double y) const {
    return cv::Point(
        x_off_ + static_cast<int>(std::lround((x - min_x_) * scale_)),
        top_ + kMargin + plan_h_ - static_cast<int>(std::lround((y - min_y_) * scale_)));
  }
  cv::Rect RectPx(const WorldPlan::Rect& rc) const {
    return cv::Rect(Px(std::min(rc.x0, rc.x1), std::max(rc.y0, rc.y1)),
                    Px(std::max(rc.x0, rc.x1), std::min(rc.y0, rc.y1)));
  }
  double scale() const { return scale_; }
  /// The first row below the plan: where the legend starts.
  int legend_top() const { return top_ + plan_h_ + 2 * kMargin; }

 private:
  static constexpr int kMargin = 40;
  double min_x_ = 1e300, max_x_ = -1e300, min_y_ = 1e300, max_y_ = -1e300;
  double scale_ = 1.0;
  int x_off_ = 0, top_ = 0, plan_h_ = 0;
};

// The floor plan of `world`: room floors, boxes, doors and walls, where `layout` puts them (the
// rooms' names: DrawRoomLabels).
void DrawWorldPlan(cv::Mat& img, const WorldPlan& world, const PlanLayout& layout) {
  const auto px = [&](double x, double y) { return layout.Px(x, y); };
  const auto rect_px = [&](const WorldPlan::Rect& rc) { return layout.RectPx(rc); };
  for (const WorldPlan::Room& room : world.rooms) {
    cv::rectangle(img, rect_px(room.rect), room.outdoor ? kOutdoorFloor : kRoomFloor, cv::FILLED);
  }
  for (const WorldPlan::Room& room : world.rooms) {
    for (const WorldPlan::Rect& b : room.boxes) {
      cv::rectangle(img, rect_px(b), kBox, cv::FILLED);
      cv::rectangle(img, rect_px(b), cv::Scalar(175, 175, 175), 1);
    }
  }
  const int wall_px = std::clamp(static_cast<int>(std::lround(0.12 * layout.scale())), 3, 6);
  for (const WorldPlan::Rect& d : world.doors) {
    cv::line(img, px(d.x0, d.y0), px(d.x1, d.y1), kDoor, 2, cv::LINE_AA);
  }
  for (const WorldPlan::Rect& wl : world.walls) {
    cv::line(img, px(wl.x0, wl.y0), px(wl.x1, wl.y1), kWall, wall_px, cv::LINE_AA);
  }
}

// The rooms' names, drawn once the place markers are known to `labels`: centred, a little above
// the centre where the markers usually sit, or moved inside the room off them.
void DrawRoomLabels(cv::Mat& img, const WorldPlan& world, const PlanLayout& layout,
                    LabelPlacer& labels) {
  constexpr double kScale = 0.65;
  for (const WorldPlan::Room& room : world.rooms) {
    const cv::Rect inside = layout.RectPx(room.rect);
    int baseline = 0;
    const cv::Size t = cv::getTextSize(room.label, kFont, kScale, 2, &baseline);
    const cv::Size box(t.width, t.height + baseline);
    cv::Point centre(inside.x + (inside.width - t.width) / 2,
                     inside.y + (inside.height - t.height) / 2);
    if (inside.height > 4 * t.height + 60) centre.y -= 30;
    std::vector<cv::Rect> candidates = {cv::Rect(centre, box)};
    // Up or down first (a room), then left or right (a corridor is too low to move in).
    for (const bool across : {false, true}) {
      for (int k = 1; k <= 4; ++k) {
        for (const int sign : {-1, 1}) {
          const cv::Point step = across ? cv::Point(sign * k * (box.width + 12), 0)
                                        : cv::Point(0, sign * k * (box.height + 6));
          const cv::Rect moved(centre + step, box);
          if ((moved & inside) == moved) candidates.push_back(moved);
        }
      }
    }
    const cv::Rect at = labels.PlaceFirstFree(candidates);
    Text(img, room.label, {at.x, at.y + t.height}, kScale, kRoomLabel, 2);
  }
}

// A scale bar of 1, 2, 5, 10, ... metres (or units), about 100-250 pixels long, at the left of
// row `y`, and "north up" at the right.
void ScaleBar(cv::Mat& img, double scale, int y, const std::string& unit) {
  double bar = 1e-6;
  for (double u = 1e-6; bar * scale < 100; u *= 10) {
    for (double m : {1.0, 2.0, 5.0}) {
      bar = m * u;
      if (bar * scale >= 100) break;
    }
  }
  const int bar_px = static_cast<int>(std::lround(bar * scale));
  cv::line(img, {20, y}, {20 + bar_px, y}, kText, 2);
  for (int x : {20, 20 + bar_px}) cv::line(img, {x, y - 6}, {x, y + 6}, kText, 2);
  std::ostringstream bar_text;
  bar_text << bar << unit;
  Text(img, bar_text.str(), {30 + bar_px, y + 5}, 0.45);
  Text(img, "north up", {img.cols - 20 - TextSize("north up").width, y + 5}, 0.45, kAxis);
}

// Field access for ParseWorldPlan; `where` names the element, e.g. "rooms[2]".
const JsonValue& Field(const JsonValue& obj, const std::string& key, const std::string& where,
                       JsonValue::Kind kind, const char* type) {
  const JsonValue* v = obj.kind == JsonValue::Kind::kObject ? obj.Find(key) : nullptr;
  if (!v) throw std::runtime_error(where + ": missing \"" + key + "\"");
  if (v->kind != kind) throw std::runtime_error(where + ": \"" + key + "\" is not " + type);
  return *v;
}
double NumberField(const JsonValue& obj, const std::string& key, const std::string& where) {
  return Field(obj, key, where, JsonValue::Kind::kNumber, "a number").number;
}
const std::vector<JsonValue>& ArrayField(const JsonValue& obj, const std::string& key,
                                         const std::string& where) {
  return Field(obj, key, where, JsonValue::Kind::kArray, "an array").items;
}
WorldPlan::Rect RectOf(const JsonValue& obj, const std::string& where) {
  return {NumberField(obj, "x0", where), NumberField(obj, "y0", where),
          NumberField(obj, "x1", where), NumberField(obj, "y1", where)};
}

void Write(const fs::path& path, const cv::Mat& img) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), img);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path.string() + ": cannot write PNG: " + e.what());
  }
  if (!ok) throw std::runtime_error(path.string() + ": cannot write PNG");
}

}  // namespace

WorldPlan ParseWorldPlan(const std::string& text, const fs::path& file) {
  try {
    const JsonValue root = ParseJson(text);
    if (root.kind != JsonValue::Kind::kObject) throw std::runtime_error("not a JSON object");
    WorldPlan plan;
    if (const JsonValue* kind = root.Find("kind"); kind && kind->kind == JsonValue::Kind::kString) {
      plan.kind = kind->text;
    }
    const std::vector<JsonValue>& rooms = ArrayField(root, "rooms", "top level");
    for (size_t i = 0; i < rooms.size(); ++i) {
      const std::string where = "rooms[" + std::to_string(i) + "]";
      WorldPlan::Room room;
      room.label = Field(rooms[i], "label", where, JsonValue::Kind::kString, "a string").text;
      room.rect = RectOf(rooms[i], where);
      if (const JsonValue* o = rooms[i].Find("outdoor")) room.outdoor = o->boolean;
      if (rooms[i].Find("boxes")) {
        const std::vector<JsonValue>& boxes = ArrayField(rooms[i], "boxes", where);
        for (size_t j = 0; j < boxes.size(); ++j) {
          room.boxes.push_back(RectOf(boxes[j], where + ".boxes[" + std::to_string(j) + "]"));
        }
      }
      plan.rooms.push_back(std::move(room));
    }
    if (plan.rooms.empty()) throw std::runtime_error("\"rooms\" is empty");
    const std::vector<JsonValue>& walls = ArrayField(root, "walls", "top level");
    for (size_t i = 0; i < walls.size(); ++i) {
      plan.walls.push_back(RectOf(walls[i], "walls[" + std::to_string(i) + "]"));
    }
    if (root.Find("doors")) {
      const std::vector<JsonValue>& doors = ArrayField(root, "doors", "top level");
      for (size_t i = 0; i < doors.size(); ++i) {
        plan.doors.push_back(RectOf(doors[i], "doors[" + std::to_string(i) + "]"));
      }
    }
    return plan;
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(file.string() + ": " + e.what());
  }
}

std::optional<WorldPlan> ReadWorldPlan(const fs::path& file, std::ostream& warnings) {
  std::error_code ec;
  if (!fs::exists(file, ec)) return std::nullopt;
  try {
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file.string() + ": cannot open");
    std::stringstream text;
    text << in.rdbuf();
    return ParseWorldPlan(text.str(), file);
  } catch (const std::runtime_error& e) {
    warnings << "warning: " << e.what() << "; floor_plan.png is drawn without the walls\n";
    return std::nullopt;
  }
}

namespace {

// The timeline's geometry: one column of pixels per frame range, rows of equal height.
struct Timeline {
  int n;  // frames (at least 1)
  int left = 120, right = 30;
  int plot_w;
  int row_h = 26, gap = 8, top = 60;

  explicit Timeline(int frames) : n(std::max(1, frames)), plot_w(std::clamp(n * 12, 900, 2400)) {}
  int width() const { return left + plot_w + right; }
  int x_of(int f) const { return left + static_cast<int>(std::lround(1.0 * f * plot_w / n)); }
  // The box of the inclusive frame range [first, last] in the row at y.
  cv::Rect col(int first, int last, int y) const {
    return cv::Rect(x_of(first), y, std::max(1, x_of(last + 1) - x_of(first)), row_h);
  }
  // Starts the row at y: its label and frame; the next row's y.
  int Row(cv::Mat& img, const std::string& label, int y) const {
    Text(img, label, {10, y + row_h / 2 + 5}, 0.45);
    cv::rectangle(img, cv::Rect(left, y, plot_w, row_h), kGrid, 1);
    return y + row_h + gap;
  }
};

// Learned / recognised place of each detected place.
void DrawPlaceRow(cv::Mat& img, const Timeline& tl, const EvalResult& r, int y) {
  const std::map<PlaceId, size_t> colour_of = PlaceColours(r.main);
  for (const EvalDetectedPlace& d : r.main.detected) {
    if (d.frames.empty() || !d.place) continue;  // an ambiguous place has no place to show
    const auto colour = colour_of.find(*d.place);
    const cv::Scalar c = colour != colour_of.end() ? Palette(colour->second) : kRevisit;
    const cv::Rect box = tl.col(d.frames.front(), d.frames.back(), y);
    cv::rectangle(img, box, c, cv::FILLED);
    CentredText(img, std::string(d.recognized ? "R " : "L ") + d.place->ToString(), box, c);
  }
}

// Detected places: their member frames, one colour per detected place.
void DrawDetectedRow(cv::Mat& img, const Timeline& tl, const EvalResult& r, int y) {
  for (size_t m = 0; m < r.main.detected.size(); ++m) {
    const EvalDetectedPlace& d = r.main.detected[m];
    const cv::Scalar c = Palette(m + 7);
    for (int f : d.frames) cv::rectangle(img, tl.col(f, f, y), c, cv::FILLED);
    if (d.frames.empty()) continue;
    CentredText(img, "D" + std::to_string(d.index), tl.col(d.frames.front(), d.frames.back(), y),
                c);
  }
}

void DrawStatusRow(cv::Mat& img, const Timeline& tl, const EvalResult& r, int y) {
  for (int f = 0; f < static_cast<int>(r.status.size()); ++f) {
    if (r.status[static_cast<size_t>(f)] == BaseStatus::kGood) continue;
    const bool uninformative = r.status[static_cast<size_t>(f)] == BaseStatus::kUninformative;
    cv::rectangle(img, tl.col(f, f, y), uninformative ? kUninformative : kIncoherent, cv::FILLED);
  }
}

void DrawTransitionRow(cv::Mat& img, const Timeline& tl, const EvalResult& r, int y) {
  for (const TransitionRegion& t : r.main.transitions) {
    if (t.empty()) continue;
    cv::rectangle(img, tl.col(static_cast<int>(t.first), static_cast<int>(t.last), y), kTransition,
                  cv::FILLED);
  }
}

// The ground truth's labels: one box per run of frames with the same label.
void DrawLabelRow(cv::Mat& img, const Timeline& tl, const EvalResult& r, int y) {
  std::map<std::string, size_t> label_colour;
  for (const std::string& l : r.truth.labels) {
    if (!l.empty() && !label_colour.count(l)) {
      const size_t i = label_colour.size();
      label_colour[l] = i;
    }
  }
  const auto& ls = r.truth.labels;
  for (int f = 0; f < static_cast<int>(ls.size());) {
    int g = f;
    while (g + 1 < static_cast<int>(ls.size()) &&
           ls[static_cast<size_t>(g + 1)] == ls[static_cast<size_t>(f)])
      ++g;
    const std::string& l = ls[static_cast<size_t>(f)];
    if (!l.empty()) {
      const cv::Scalar c = Palette(label_colour.at(l) + 2);
      const cv::Rect box = tl.col(f, g, y);
      cv::rectangle(img, box, c, cv::FILLED);
      CentredText(img, l, box, c);
    }
    f = g + 1;
  }
}

void DrawRevisitRow(cv::Mat& img, const Timeline& tl, const EvalResult& r, int y) {
  const auto& rv = r.truth.revisits;
  for (int f = 0; f < static_cast<int>(rv.size()); ++f) {
    if (!rv[static_cast<size_t>(f)].empty()) {
      cv::rectangle(img, tl.col(f, f, y), kRevisit, cv::FILLED);
    }
  }
}

void DrawFrameAxis(cv::Mat& img, const Timeline& tl, int axis_y) {
  cv::line(img, {tl.left, axis_y}, {tl.left + tl.plot_w, axis_y}, kAxis, 1);
  const int step = TickStep(tl.n, std::max(5, tl.plot_w / 70));
  for (int f = 0; f <= tl.n; f += step) {
    const int x = tl.x_of(f);
    cv::line(img, {x, axis_y}, {x, axis_y + 6}, kAxis, 1);
    const std::string s = std::to_string(f);
    Text(img, s, {x - TextSize(s, 0.4).width / 2, axis_y + 22}, 0.4);
  }
  Text(img, "frame (0-based)", {tl.left + tl.plot_w / 2 - 60, axis_y + 44}, 0.45);
}

}  // namespace

cv::Mat DrawTimeline(const EvalResult& r) {
  const Timeline tl(r.frames);
  const bool labels = r.truth.has_labels(), revisits = r.truth.has_revisits();
  const int rows = 4 + (labels ? 1 : 0) + (revisits ? 1 : 0);
  const int axis_y = tl.top + rows * (tl.row_h + tl.gap) + 2;
  cv::Mat img(axis_y + 120, tl.width(), CV_8UC3, kWhite);
  Text(img,
       "detection timeline: " + fs::path(r.dataset).filename().string() + " (" +
           std::to_string(r.frames) + " frames, tau_r = " + Fixed(r.main.tau_r, 2) + ", " +
           std::to_string(r.main.detected.size()) + " detected, " +
           std::to_string(r.main.learned_places) + " learned places)",
       {tl.left, 28}, 0.6, kText, 1);
  int y = tl.top;
  const auto row = [&](const char* label, auto draw) {
    const int at = y;
    y = tl.Row(img, label, y);
    draw(img, tl, r, at);
  };
  row("place (L/R)", DrawPlaceRow);
  row("detected", DrawDetectedRow);
  row("status", DrawStatusRow);
  row("transitions", DrawTransitionRow);
  if (labels) row("truth: labels", DrawLabelRow);
  if (revisits) row("truth: revisit", DrawRevisitRow);
  DrawFrameAxis(img, tl, axis_y);

  cv::Point at(tl.left, axis_y + 80);
  Swatch(img, at, kWhite, "good", tl.left);
  Swatch(img, at, kUninformative, "uninformative", tl.left);
  Swatch(img, at, kIncoherent, "incoherent", tl.left);
  Swatch(img, at, kTransition, "transition region", tl.left);
  Swatch(img, at, Palette(7), "detected place Dm (its good frames)", tl.left);
  Swatch(img, at, Palette(0), "place it went to: L learned, R recognised", tl.left);
  if (revisits) Swatch(img, at, kRevisit, "frame revisits an earlier one", tl.left);
  return img;
}

namespace {

// The square plot area of a precision-recall plot (tsc eval's curve over tau_r, tsc classify's
// curves over the confidence tau): recall to the right, precision up, both in [0, 1].
struct PrAxes {
  int x0 = 80, y0 = 60;  ///< top-left corner of the plot area, px
  int size = 440;        ///< side of the plot area, px
  cv::Point operator()(double recall, double precision) const {
    return cv::Point(x0 + static_cast<int>(std::lround(recall * size)),
                     y0 + size - static_cast<int>(std::lround(precision * size)));
  }
};

// Grid every 0.2 with its tick labels, the frame and the axis titles.
void DrawPrAxes(cv::Mat& img, const PrAxes& px) {
  for (int i = 0; i <= 5; ++i) {
    const double v = i / 5.0;
    cv::line(img, px(v, 0), px(v, 1), kGrid, 1);
    cv::line(img, px(0, v), px(1, v), kGrid, 1);
    const std::string s = Fixed(v, 1);
    Text(img, s, px(v, 0) + cv::Point(-TextSize(s, 0.4).width / 2, 20), 0.4);
    Text(img, s, px(0, v) + cv::Point(-TextSize(s, 0.4).width - 8, 5), 0.4);
  }
  cv::rectangle(img, px(0, 1), px(1, 0), kAxis, 1);
  Text(img, "recall", px(0.5, 0) + cv::Point(-25, 44), 0.5);
  VerticalText(img, "precision", {12, px.y0 + px.size / 2 - 40}, 0.5);
}

}  // namespace

namespace {

// One sweep curve: its points joined in τ_r order, the main run's point (configured τ_r,
// which need not be a sweep value) ringed.
void DrawSweepCurve(cv::Mat& img, const PrAxes& px, const std::vector<PrPoint>& curve,
                    const cv::Scalar& colour, const PrPoint& configured) {
  for (size_t i = 1; i < curve.size(); ++i) {
    cv::line(img, px(curve[i - 1].recall, curve[i - 1].precision),
             px(curve[i].recall, curve[i].precision), colour, 2, cv::LINE_AA);
  }
  for (const PrPoint& p : curve) {
    cv::circle(img, px(p.recall, p.precision), 4, colour, cv::FILLED, cv::LINE_AA);
  }
  cv::circle(img, px(configured.recall, configured.precision), 9, colour, 2, cv::LINE_AA);
}

// Each run of sweep points with the same precision and recall, labelled with its τ_r range
// under its point (the place-level curve only: three sets of labels would be unreadable).
void LabelSweepPoints(cv::Mat& img, const PrAxes& px, const std::vector<PrPoint>& curve,
                      const cv::Scalar& colour) {
  for (size_t i = 0; i < curve.size();) {
    size_t j = i;
    while (j + 1 < curve.size() && curve[j + 1].precision == curve[i].precision &&
           curve[j + 1].recall == curve[i].recall) {
      ++j;
    }
    const PrPoint& p = curve[i];
    const std::string s =
        j > i ? Fixed(p.tau_r, 2) + "-" + Fixed(curve[j].tau_r, 2) : Fixed(p.tau_r, 2);
    const cv::Size t = TextSize(s, 0.38);
    cv::Point at = px(p.recall, p.precision) + cv::Point(-t.width / 2, 20);
    at.x = std::clamp(at.x, px.x0 + 2, px.x0 + px.size + 78 - t.width);
    at.y = std::min(at.y, px.y0 + px.size - 4);
    Text(img, s, at, 0.38, colour);
    i = j + 1;
  }
}

}  // namespace

// Place level (labels / revisits), view overlap (with poses) and frame level (loop closures)
// over the same τ_r sweep; each curve's point at the configured τ_r is ringed.
cv::Mat DrawPrCurve(const EvalResult& r) {
  const PrAxes px;
  const int x0 = px.x0, y0 = px.y0, size = px.size;
  const bool views = r.truth.has_poses() && !r.view_pr_curve.empty();
  const bool frames = r.truth.has_labels() || r.truth.has_revisits();
  cv::Mat img(y0 + size + 96 + 24 * (views + frames), x0 + size + 80, CV_8UC3, kWhite);
  Text(img, "recognition PR curves over tau_r", {x0, 26}, 0.6);
  Text(img,
       "sweep " + Fixed(r.eval.sweep_from, 2) + ".." + Fixed(r.eval.sweep_to, 2) + " step " +
           Fixed(r.eval.sweep_step, 2) + "; ring: configured tau_r = " + Fixed(r.main.tau_r, 2),
       {x0, 46}, 0.42);
  DrawPrAxes(img, px);

  const RecognitionScore& s = r.main.recognition;
  const LoopClosureScore& c = r.main.loop_closure;
  const double tau = r.main.tau_r;
  const cv::Scalar place(180, 119, 31), view = Palette(0), frame = Palette(1);
  if (views) DrawSweepCurve(img, px, r.view_pr_curve, view, {tau, s.precision, s.view_recall});
  if (frames) DrawSweepCurve(img, px, r.loop_closure_pr_curve, frame, {tau, c.precision, c.recall});
  DrawSweepCurve(img, px, r.pr_curve, place, {tau, s.precision, s.recall});
  LabelSweepPoints(img, px, r.pr_curve, place);

  cv::Point legend(x0, y0 + size + 72);
  Swatch(img, legend, place,
         "places (labelled tau_r): P " + Fixed(s.precision, 2) + ", R " + Fixed(s.recall, 2) +
             ", R at P=1 " + Fixed(r.recall_at_full_precision, 2),
         x0);
  if (views) {
    legend = {x0, legend.y + 24};
    Swatch(img, legend, view,
           "places sharing a view: R " + Fixed(s.view_recall, 2) + ", R at P=1 " +
               Fixed(r.view_recall_at_full_precision, 2),
           x0);
  }
  if (frames) {
    legend = {x0, legend.y + 24};
    Swatch(img, legend, frame,
           "frames (loop closures): P " + Fixed(c.precision, 2) + ", R " + Fixed(c.recall, 2) +
               ", R at P=1 " + Fixed(r.loop_closure_recall_at_full_precision, 2),
           x0);
  }
  return img;
}

cv::Mat DrawTauPrCurves(const std::vector<NamedTauCurve>& curves, const std::string& title) {
  const PrAxes px;
  const int x0 = px.x0, y0 = px.y0, size = px.size;
  const int legend_rows = static_cast<int>(curves.size());
  cv::Mat img(y0 + size + 80 + 24 * legend_rows, x0 + size + 60, CV_8UC3, kWhite);
  Text(img, title, {x0, 26}, 0.6);
  Text(img, "one point per confidence threshold tau; ring: tau = 0.5", {x0, 46}, 0.42);
  DrawPrAxes(img, px);
  cv::Point legend(x0, y0 + size + 72);
  for (size_t c = 0; c < curves.size(); ++c) {
    const cv::Scalar colour = Palette(c);
    const std::vector<TauPoint>& pts = curves[c].points;
    for (size_t i = 1; i < pts.size(); ++i) {
      cv::line(img, px(pts[i - 1].recall, pts[i - 1].precision),
               px(pts[i].recall, pts[i].precision), colour, 2, cv::LINE_AA);
    }
    int best = 0;
    for (const TauPoint& p : pts) {
      cv::circle(img, px(p.recall, p.precision), 3, colour, cv::FILLED, cv::LINE_AA);
      if (std::abs(p.tau - 0.5) < 1e-9) cv::circle(img, px(p.recall, p.precision), 8, colour, 2);
      best = std::max(best, p.imageclef);
    }
    legend = {x0, legend.y};
    Swatch(img, legend, colour,
           curves[c].name + " (best ImageCLEF score " + std::to_string(best) + ")", x0);
    legend.y += 24;
  }
  return img;
}

cv::Mat DrawConfusionMatrix(const Eigen::MatrixXi& confusion,
                            const std::vector<std::string>& places, const std::string& title) {
  const int n = static_cast<int>(places.size());
  const bool other = confusion.rows() > n && confusion.row(n).sum() > 0;
  const int rows = n + (other ? 1 : 0), cols = n + 1;
  int label_w = TextSize("unclassified", 0.45).width;
  for (const std::string& p : places) label_w = std::max(label_w, TextSize(p).width);
  const int cell = 44, x0 = label_w + 20, y0 = 60 + label_w + 10;
  cv::Mat img(y0 + rows * cell + 40, x0 + cols * cell + 20, CV_8UC3, kWhite);
  Text(img, title, {10, 24}, 0.55);
  Text(img, "rows: true place, columns: decided place; shade = fraction of the row", {10, 44}, 0.4);
  const auto name = [&](int i, bool column) {
    if (i < n) return places[static_cast<size_t>(i)];
    return std::string(column ? "unclassified" : "other");
  };
  for (int c = 0; c < cols; ++c) {
    VerticalText(img, name(c, true), {x0 + c * cell + cell / 2 - 10, 56}, 0.45);
  }
  for (int r = 0; r < rows; ++r) {
    const std::string s = name(r, false);
    Text(img, s, {x0 - 8 - TextSize(s).width, y0 + r * cell + cell / 2 + 5});
    const int total = confusion.row(r).sum();
    for (int c = 0; c < cols; ++c) {
      const int count = confusion(r, c);
      const double f = total > 0 ? static_cast<double>(count) / total : 0.0;
      const cv::Scalar bg = r == c ? cv::Scalar(255 - 155 * f, 255 - 75 * f, 255 - 215 * f)
                                   : cv::Scalar(255 - 200 * f, 255 - 200 * f, 255 - 40 * f);
      const cv::Rect box(x0 + c * cell, y0 + r * cell, cell, cell);
      cv::rectangle(img, box, bg, cv::FILLED);
      cv::rectangle(img, box, kGrid, 1);
      if (count > 0) {
        const std::string t = std::to_string(count);
        Text(img, t, {box.x + (cell - TextSize(t, 0.4).width) / 2, box.y + cell / 2 + 5}, 0.4,
             TextOn(bg));
      }
    }
  }
  return img;
}

cv::Mat DrawFloorPlan(const EvalResult& r, const Dataset& dataset, const WorldPlan* world) {
  const auto& poses = dataset.poses();
  PlanLayout layout;
  for (const auto& p : poses) {
    if (p) layout.Extend(p->x, p->y);
  }
  if (layout.empty()) return {};
  cv::Mat img = layout.Canvas(world, 760, 70, 110, 680);
  const double scale = layout.scale();
  const auto px = [&](double x, double y) { return layout.Px(x, y); };

  const std::string name = fs::path(r.dataset).filename().string();
  Text(img,
       world ? "floor plan of " + name + " (" + (world->kind.empty() ? "" : world->kind + " ") +
                   "world, " + std::to_string(world->rooms.size()) + " rooms)"
             : "trajectory of " + name,
       {20, 28}, 0.6);
  Text(img,
       "topological map over the trajectory: " + std::to_string(r.main.learned_places) +
           " learned places, " + std::to_string(r.main.map.edges().size()) + " edges",
       {20, 52}, 0.45);

  const cv::Scalar kTrajectory(225, 185, 140);
  // Map edges in purple over a world, so that they do not look like walls.
  const cv::Scalar kEdge = world ? kMapEdgeOverWorld : kAxis;
  if (world) DrawWorldPlan(img, *world, layout);

  // Trajectory.
  std::vector<cv::Point> path;
  for (const auto& p : poses) {
    if (p) path.push_back(px(p->x, p->y));
  }
  cv::polylines(img, path, false, kTrajectory, 2, cv::LINE_AA);

  // Places at the mean pose of their frames.
  std::map<PlaceId, cv::Point> where;
  for (const auto& [id, frames] : r.main.frames_of) {
    double sx = 0, sy = 0;
    int k = 0;
    for (int f : frames) {
      if (f < 0 || f >= static_cast<int>(poses.size()) || !poses[static_cast<size_t>(f)]) continue;
      sx += poses[static_cast<size_t>(f)]->x, sy += poses[static_cast<size_t>(f)]->y, ++k;
    }
    if (k > 0) where[id] = px(sx / k, sy / k);
  }
  for (const auto& [key, e] : r.main.map.edges()) {
    if (!where.count(e.a) || !where.count(e.b)) continue;
    cv::line(img, where[e.a], where[e.b], kEdge,
             static_cast<int>(std::min<int64_t>(1 + e.traversals, 4)), cv::LINE_AA);
  }
  const std::map<PlaceId, size_t> colour_of = PlaceColours(r.main);
  // Every marker first, then the names where they cover none of them.
  constexpr int kRadius = 12;
  LabelPlacer labels(img.size());
  for (const auto& [id, at] : where) {
    const cv::Scalar c = Palette(colour_of.at(id));
    cv::circle(img, at, kRadius, c, cv::FILLED, cv::LINE_AA);
    cv::circle(img, at, kRadius, kText, 1, cv::LINE_AA);
    labels.AddMarker(at, kRadius);
  }
  if (world) DrawRoomLabels(img, *world, layout, labels);
  for (const auto& [id, at] : where) {
    std::string label = id.ToString();
    const std::string truth = MajorityLabel(r.truth, r.main.frames_of.at(id));
    if (!truth.empty()) label += " " + truth;
    PlaceLabel(img, labels, label, at, kRadius);
  }

  const int bar_y = layout.legend_top() + 28;
  ScaleBar(img, scale, bar_y, world ? " m" : " (dataset units)");

  cv::Point legend(20, bar_y + 36);
  if (world) {
    Swatch(img, legend, kWall, "wall", 20);
    Swatch(img, legend, kDoor, "door", 20);
    Swatch(img, legend, kBox, "box", 20);
  }
  Swatch(img, legend, kTrajectory, "trajectory", 20);
  Swatch(img, legend, kEdge, "map edge (thicker: more traversals)", 20);
  Swatch(img, legend, Palette(0), "learned place at its mean pose (id, truth label)", 20);
  return img;
}

cv::Mat DrawTeamMap(const TeamMapPicture& team, const WorldPlan* world) {
  PlanLayout layout;
  for (const TeamMapPicture::Robot& r : team.robots) {
    for (const auto& [x, y] : r.trajectory) layout.Extend(x, y);
  }
  for (const TeamMapPicture::Place& p : team.places) {
    if (p.located) layout.Extend(p.x, p.y);
  }
  if (layout.empty()) return {};
  cv::Mat img = layout.Canvas(world, 900, 70, 130, 860);
  const double scale = layout.scale();
  const auto px = [&](double x, double y) { return layout.Px(x, y); };
  Text(img, team.title, {20, 28}, 0.6);
  Text(img, team.subtitle, {20, 52}, 0.45);
  if (world) DrawWorldPlan(img, *world, layout);

  // Trajectories, light, in each robot's colour.
  const auto robot_colour = [](uint32_t id) { return Palette(id > 0 ? id - 1 : 0); };
  for (const TeamMapPicture::Robot& r : team.robots) {
    std::vector<cv::Point> path;
    for (const auto& [x, y] : r.trajectory) path.push_back(px(x, y));
    const cv::Scalar c = robot_colour(r.id);
    const cv::Scalar light(0.35 * c[0] + 0.65 * 255, 0.35 * c[1] + 0.65 * 255,
                           0.35 * c[2] + 0.65 * 255);
    cv::polylines(img, path, false, light, 2, cv::LINE_AA);
  }
  // Edges between the places' positions.
  std::map<PlaceId, cv::Point> where;
  for (const TeamMapPicture::Place& p : team.places) {
    if (p.located) where[p.id] = px(p.x, p.y);
  }
  for (const auto& [key, e] : team.map.edges()) {
    if (!where.count(e.a) || !where.count(e.b)) continue;
    cv::line(img, where[e.a], where[e.b], kAxis,
             static_cast<int>(std::min<int64_t>(1 + e.traversals, 4)), cv::LINE_AA);
  }
  // Places: filled with the colour of the robot whose id they carry; a merged place ringed in
  // the colours of the robots whose places it absorbed.
  // Every marker first, then the names where they cover none of them.
  struct Name {
    std::string text;
    cv::Point at;
    int outer;  // the marker's outer radius
  };
  int merged = 0;
  LabelPlacer labels(img.size());
  std::vector<Name> names;
  for (const TeamMapPicture::Place& p : team.places) {
    if (!p.located) continue;
    const cv::Point at = where[p.id];
    std::set<uint32_t> others;
    for (const PlaceId& s : p.sources) {
      if (s.robot != p.id.robot) others.insert(s.robot);
    }
    constexpr int radius = 11;
    constexpr int kOwnJoinRing = 15;  // drawn 2 pixels wide
    int ring = radius + 5 * static_cast<int>(others.size());
    const int outer = p.sources.empty() ? radius + 1 : std::max(ring + 1, kOwnJoinRing + 1);
    labels.AddMarker(at, outer);
    std::string text = p.id.ToString();
    for (const PlaceId& s : p.sources) text += "+" + s.ToString();
    if (!p.label.empty()) text += " " + p.label;
    names.push_back({std::move(text), at, outer});
    if (!p.sources.empty()) {
      ++merged;
      cv::circle(img, at, ring + 1, kText, 1, cv::LINE_AA);
      for (uint32_t r : others) {
        cv::circle(img, at, ring, robot_colour(r), cv::FILLED, cv::LINE_AA);
        ring -= 5;
      }
      if (others.empty()) {  // joined with its own robot's places only
        cv::circle(img, at, kOwnJoinRing, kText, 2, cv::LINE_AA);
      }
    }
    cv::circle(img, at, radius, robot_colour(p.id.robot), cv::FILLED, cv::LINE_AA);
    cv::circle(img, at, radius, kText, 1, cv::LINE_AA);
  }
  if (world) DrawRoomLabels(img, *world, layout, labels);
  for (const Name& n : names) PlaceLabel(img, labels, n.text, n.at, n.outer);

  const int bar_y = layout.legend_top() + 28;
  ScaleBar(img, scale, bar_y, world ? " m" : " (units)");
  cv::Point legend(20, bar_y + 36);
  for (const TeamMapPicture::Robot& r : team.robots) {
    Swatch(img, legend, robot_colour(r.id), "robot " + std::to_string(r.id), 20);
  }
  Swatch(img, legend, kAxis, "map edge (thicker: more traversals)", 20);
  Text(img,
       "place: filled in the colour of the robot whose id it carries, at the mean position of "
       "its frames;",
       {20, legend.y + 24}, 0.42);
  Text(img,
       "merged place (" + std::to_string(merged) +
           "): ringed in the colours of the robots it absorbed, named id+sources; room label "
           "from the ground truth",
       {20, legend.y + 44}, 0.42);
  return img;
}

void WriteTeamMap(const TeamMapPicture& team, const WorldPlan* world, const fs::path& png) {
  const cv::Mat img = DrawTeamMap(team, world);
  if (img.empty()) throw std::runtime_error(png.string() + ": nothing to draw");
  Write(png, img);
}

std::vector<fs::path> WritePlots(const EvalResult& r, const Dataset& dataset, const fs::path& dir,
                                 std::ostream& warnings) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir.string() + ": cannot create folder: " + ec.message());
  std::vector<fs::path> written;
  const auto save = [&](const std::string& name, const cv::Mat& img) {
    if (img.empty()) return;
    Write(dir / name, img);
    written.push_back(dir / name);
  };
  save("timeline.png", DrawTimeline(r));
  save("pr_curve.png", DrawPrCurve(r));
  if (!dataset.poses().empty()) {
    const std::optional<WorldPlan> world = ReadWorldPlan(dataset.folder() / "world.json", warnings);
    save("floor_plan.png", DrawFloorPlan(r, dataset, world ? &*world : nullptr));
  }
  if (r.main.memory) {
    RenderPng(ToDot(*r.main.memory, r.main.map), dir / "memory_map.png");
    written.push_back(dir / "memory_map.png");
  }
  return written;
}

std::vector<fs::path> WritePlots(const EvalResult& r, const Dataset& dataset, const fs::path& dir) {
  return WritePlots(r, dataset, dir, std::cerr);
}

}  // namespace tsc
