#include "drivers/world/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsc::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double Frac(double x) { return x - std::floor(x); }

/// Cheap integer hash to [0, 1).
double Hash(int a, int b) {
  std::uint32_t h =
      static_cast<std::uint32_t>(a) * 374761393u + static_cast<std::uint32_t>(b) * 668265263u;
  h = (h ^ (h >> 13)) * 1274126177u;
  h ^= h >> 16;
  return static_cast<double>(h & 0xffffu) / 65536.0;
}

cv::Vec3b Mix(const cv::Vec3b& a, const cv::Vec3b& b, double t) {
  return {static_cast<uchar>(a[0] + (b[0] - a[0]) * t),
          static_cast<uchar>(a[1] + (b[1] - a[1]) * t),
          static_cast<uchar>(a[2] + (b[2] - a[2]) * t)};
}

/// Wall colour at (u along the wall, v height), both in metres.
cv::Vec3b Texel(const Appearance& a, double u, double v) {
  const double f = a.frequency_per_m;
  switch (a.texture) {
    case TextureKind::kVerticalStripes:
      return Frac(u * f) < 0.5 ? a.wall_a : a.wall_b;
    case TextureKind::kHorizontalStripes:
      return Frac(v * f) < 0.5 ? a.wall_a : a.wall_b;
    case TextureKind::kDiagonalStripes:
      return Frac((u + v) * f) < 0.5 ? a.wall_a : a.wall_b;
    case TextureKind::kChecker:
      return ((static_cast<int>(std::floor(u * f)) + static_cast<int>(std::floor(v * f))) & 1)
                 ? a.wall_b
                 : a.wall_a;
    case TextureKind::kNoise:
      return Mix(a.wall_a, a.wall_b,
                 Hash(static_cast<int>(std::floor(u * f * 3.0)),
                      static_cast<int>(std::floor(v * f * 3.0))));
    case TextureKind::kFacade: {
      // Buildings 6 m wide in varying tints; storeys of 3 m; windows in a grid; shops below.
      const int building = static_cast<int>(std::floor(u / 6.0));
      const cv::Vec3b tint = Mix(a.wall_a, cv::Vec3b(40, 60, 90), 0.6 * Hash(building, 7));
      if (v < 0.3) return Mix(tint, cv::Vec3b(0, 0, 0), 0.5);
      const bool window_col = Frac(u * f) > 0.25 && Frac(u * f) < 0.7;
      const bool window_row = Frac(v / 3.0) > 0.3 && Frac(v / 3.0) < 0.75;
      if (window_col && window_row) return v < 3.0 ? Mix(a.wall_b, tint, 0.3) : a.wall_b;
      return tint;
    }
  }
  return a.wall_a;
}

// Where a ray (origin o, direction d whose forward component is 1) meets the nearest wall:
// t is the optical depth, u the position along the wall.
struct Hit {
  double t = kInf;
  double u = 0.0;
  bool vertical_wall = false;
  double line = 0.0;
};

// The ray as it leaves the camera, not normalised: the ray parameter is the optical depth.
struct Ray {
  double ox, oy, dx, dy;
  double x(double t) const { return ox + t * dx; }
  double y(double t) const { return oy + t * dy; }
};

Hit NearestWall(const std::vector<Wall>& walls, const Ray& ray) {
  Hit hit;
  for (const Wall& wall : walls) {
    if (wall.x0 == wall.x1) {
      if (std::abs(ray.dx) < 1e-12) continue;
      const double t = (wall.x0 - ray.ox) / ray.dx;
      if (t <= 1e-6 || t >= hit.t) continue;
      const double y = ray.y(t);
      if (y < wall.y0 || y > wall.y1) continue;
      hit = Hit{t, y, true, wall.x0};
    } else {
      if (std::abs(ray.dy) < 1e-12) continue;
      const double t = (wall.y0 - ray.oy) / ray.dy;
      if (t <= 1e-6 || t >= hit.t) continue;
      const double x = ray.x(t);
      if (x < wall.x0 || x > wall.x1) continue;
      hit = Hit{t, x, false, wall.y0};
    }
  }
  return hit;
}

// The nearest face of a box in front of depth `limit`, in the rooms the ray passes through.
struct BoxHit {
  const Box* box = nullptr;
  double t = 0.0;
  bool x_face = false;
};

// Slab test of one box: the depth where the ray enters it, before `limit`, and whether it
// enters through a face of constant x.
std::optional<std::pair<double, bool>> EnterBox(const Box& b, const Ray& ray, double limit) {
  double tmin = 1e-6, tmax = limit;
  bool xface = false;
  for (int axis = 0; axis < 2; ++axis) {
    const double o = axis == 0 ? ray.ox : ray.oy;
    const double d = axis == 0 ? ray.dx : ray.dy;
    const double lo = axis == 0 ? b.x0 : b.y0, hi = axis == 0 ? b.x1 : b.y1;
    if (std::abs(d) < 1e-12) {
      if (o < lo || o > hi) return std::nullopt;
      continue;
    }
    double t1 = (lo - o) / d, t2 = (hi - o) / d;
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > tmin) {
      tmin = t1;
      xface = axis == 0;
    }
    tmax = std::min(tmax, t2);
    if (tmin > tmax) return std::nullopt;
  }
  return std::make_pair(tmin, xface);
}

}  // namespace

void RenderOptions::Validate() const {
  if (width < 8 || height < 8 || width > 8192 || height > 8192) {
    throw std::invalid_argument("image size " + std::to_string(width) + "x" +
                                std::to_string(height) + " must be within 8..8192");
  }
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("hfov_deg " + std::to_string(hfov_deg) + " must be in (0, 180)");
  }
  if (!(camera_height_m > 0.0 && camera_height_m < 2.4)) {
    throw std::invalid_argument("camera_height_m " + std::to_string(camera_height_m) +
                                " must be in (0, 2.4)");
  }
}

Renderer::Renderer(const World& world, const RenderOptions& options, std::uint32_t noise_seed)
    : world_(world), options_(options) {
  options_.Validate();
  const int w = options_.width, h = options_.height;
  focal_ = 0.5 * w / std::tan(0.5 * options_.hfov_deg * std::numbers::pi / 180.0);
  const double cx = 0.5 * w, cy = 0.5 * h;
  column_slope_.resize(static_cast<size_t>(w));
  for (int c = 0; c < w; ++c) column_slope_[static_cast<size_t>(c)] = (cx - (c + 0.5)) / focal_;
  floor_depth_.assign(static_cast<size_t>(h), 0.0f);
  row_shade_.assign(static_cast<size_t>(h), 1.0f);
  for (int r = 0; r < h; ++r) {
    const double off = r + 0.5 - cy;  // > 0 below the horizon
    if (off > 0) {
      floor_depth_[static_cast<size_t>(r)] =
          static_cast<float>(options_.camera_height_m * focal_ / off);
    }
    row_shade_[static_cast<size_t>(r)] = static_cast<float>(0.75 + 0.25 * std::abs(off) / cy);
  }
  std::mt19937 rng(noise_seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  noise_pool_.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * 3 + 65536);
  for (auto& n : noise_pool_) {
    n = static_cast<std::int8_t>(std::clamp(std::lround(16.0 * normal(rng)), -127L, 127L));
  }
}

namespace {

// What drawing a column needs of the camera: the image height, the horizon row, the camera
// height, the focal length and the per-row tables.
struct Lens {
  int height;
  double cy, cam_h, focal;
  const std::vector<float>& row_shade;
  const std::vector<float>& floor_depth;
};

// A stretch of a ray inside one room: up to depth t_end (−1: outside every room).
struct Span {
  double t_end;
  int room;
};

// One image column: its pixels and, when asked for, its depths.
struct Column {
  uchar* bgr;
  size_t step;
  float* depth;  // null: no depth map
  size_t depth_step;
  uchar* at(int r) const { return bgr + static_cast<size_t>(r) * step; }
  void set_depth(int r, float t) const {
    if (depth != nullptr) depth[static_cast<size_t>(r) * depth_step] = t;
  }
};

void SplitIntoRooms(const World& world, const Ray& ray, int home, double t_wall,
                    std::vector<double>& crossings, std::vector<Span>& spans) {
  crossings.clear();
  for (const Door& d : world.doors()) {
    const double den = d.vertical_wall ? ray.dx : ray.dy;
    if (std::abs(den) < 1e-12) continue;
    const double t = (d.line - (d.vertical_wall ? ray.ox : ray.oy)) / den;
    if (t <= 1e-6 || t >= t_wall) continue;
    const double along = d.vertical_wall ? ray.y(t) : ray.x(t);
    if (along >= d.lo && along <= d.hi) crossings.push_back(t);
  }
  std::sort(crossings.begin(), crossings.end());
  spans.clear();
  int room = home;
  for (double t : crossings) {
    spans.push_back({t, room});
    const double tm = t + 1e-3;
    room = world.RoomAt(ray.x(tm), ray.y(tm));
  }
  spans.push_back({kInf, room});
}

void DrawWall(const Column& px, const Lens& lens, const Hit& hit, const Room& room, int* r_top,
              int* r_bot) {
  const int h = lens.height;
  const double cy = lens.cy, cam_h = lens.cam_h, focal = lens.focal;
  const Appearance& look = room.appearance;
  const double k = focal / hit.t;
  *r_top =
      std::clamp(static_cast<int>(std::ceil(cy - 0.5 - (look.wall_height_m - cam_h) * k)), 0, h);
  *r_bot = std::clamp(static_cast<int>(std::floor(cy - 0.5 + cam_h * k)) + 1, 0, h);
  // Wall slice: v (height) falls linearly with the row; the texture is looked up per pixel.
  const double shade = (hit.vertical_wall ? 0.85 : 1.0) / (1.0 + 0.02 * hit.t);
  const double dv = hit.t / focal;
  double v = cam_h + (cy - (*r_top + 0.5)) * dv;
  const Poster* poster = nullptr;
  for (const Poster& p : room.posters) {
    if (p.vertical_wall == hit.vertical_wall && std::abs(p.line - hit.line) < 1e-9 &&
        hit.u >= p.u0 && hit.u <= p.u1) {
      poster = &p;
      break;
    }
  }
  const float tf = static_cast<float>(hit.t);
  for (int r = *r_top; r < *r_bot; ++r, v -= dv) {
    const cv::Vec3b texel = (poster != nullptr && v >= poster->v0 && v <= poster->v1)
                                ? poster->colour
                                : Texel(look, hit.u, v);
    uchar* p = px.at(r);
    p[0] = static_cast<uchar>(texel[0] * shade);
    p[1] = static_cast<uchar>(texel[1] * shade);
    p[2] = static_cast<uchar>(texel[2] * shade);
    px.set_depth(r, tf);
  }
}

// Ceiling (or sky) above the wall: the colour of the room the ray is in at that depth.
void DrawCeiling(const Column& px, const Lens& lens, const std::vector<Room>& rooms,
                 const std::vector<Span>& spans, const Appearance* look, int r_top) {
  const double cy = lens.cy, cam_h = lens.cam_h, focal = lens.focal;
  for (int r = 0; r < r_top; ++r) {
    const double up = cy - (r + 0.5);  // > 0
    const int room_i = spans.back().room;
    const Appearance* a = room_i >= 0 ? &rooms[static_cast<size_t>(room_i)].appearance : look;
    double t = kInf;
    if (a != nullptr && !a->outdoor) t = (a->wall_height_m - cam_h) * focal / up;
    int ri = room_i;
    for (const Span& span : spans) {
      if (t < span.t_end) {
        ri = span.room;
        break;
      }
    }
    const Appearance* ar = ri >= 0 ? &rooms[static_cast<size_t>(ri)].appearance : a;
    uchar* p = px.at(r);
    if (ar == nullptr) {
      p[0] = p[1] = p[2] = 0;
      px.set_depth(r, 0.0f);
      continue;
    }
    const float shade = lens.row_shade[static_cast<size_t>(r)];
    if (ar->outdoor) {
      // Sky: whiter towards the horizon.
      const float k = 1.0f - shade;  // 0.25 at the horizon, 0 at the top
      for (int ch = 0; ch < 3; ++ch) {
        p[ch] = static_cast<uchar>(ar->ceiling[ch] + (255 - ar->ceiling[ch]) * 3.0f * k);
      }
      px.set_depth(r, 0.0f);
    } else {
      for (int ch = 0; ch < 3; ++ch) p[ch] = static_cast<uchar>(ar->ceiling[ch] * shade);
      px.set_depth(r, static_cast<float>((ar->wall_height_m - cam_h) * focal / up));
    }
  }
}

// Floor below the wall: the colour of the room the ray is in at that depth.
void DrawFloor(const Column& px, const Lens& lens, const std::vector<Room>& rooms,
               const std::vector<Span>& spans, int r_bot) {
  size_t span_i = spans.size() - 1;
  for (int r = r_bot; r < lens.height; ++r) {
    const float t = lens.floor_depth[static_cast<size_t>(r)];
    while (span_i > 0 && t < spans[span_i - 1].t_end) --span_i;
    const int ri = spans[span_i].room;
    uchar* p = px.at(r);
    if (ri < 0) {
      p[0] = p[1] = p[2] = 0;
    } else {
      const cv::Vec3b& fc = rooms[static_cast<size_t>(ri)].appearance.floor;
      const float shade = lens.row_shade[static_cast<size_t>(r)];
      p[0] = static_cast<uchar>(fc[0] * shade);
      p[1] = static_cast<uchar>(fc[1] * shade);
      p[2] = static_cast<uchar>(fc[2] * shade);
    }
    px.set_depth(r, t);
  }
}

// The nearest box in front of the wall (at `t_wall`), over whatever was drawn.
void DrawBox(const Column& px, const Lens& lens, const std::vector<Room>& rooms,
             const std::vector<Span>& spans, const Ray& ray, double t_wall) {
  BoxHit near{nullptr, t_wall, false};
  for (const Span& span : spans) {
    if (span.room < 0) continue;
    for (const Box& b : rooms[static_cast<size_t>(span.room)].boxes) {
      const auto enter = EnterBox(b, ray, near.t);
      if (enter && enter->first < near.t && enter->first > 1e-6) {
        near = BoxHit{&b, enter->first, enter->second};
      }
    }
  }
  if (near.box == nullptr) return;
  const int h = lens.height;
  const double cy = lens.cy, cam_h = lens.cam_h;
  const double k = lens.focal / near.t;
  const int b_top =
      std::clamp(static_cast<int>(std::ceil(cy - 0.5 - (near.box->height_m - cam_h) * k)), 0, h);
  const int b_bot = std::clamp(static_cast<int>(std::floor(cy - 0.5 + cam_h * k)) + 1, 0, h);
  const double shade = near.x_face ? 0.8 : 1.0;
  const float tf = static_cast<float>(near.t);
  for (int r = b_top; r < b_bot; ++r) {
    uchar* p = px.at(r);
    const double g = shade * (r == b_top ? 1.3 : 1.0);  // a lit top edge
    for (int ch = 0; ch < 3; ++ch) p[ch] = cv::saturate_cast<uchar>(near.box->colour[ch] * g);
    px.set_depth(r, tf);
  }
}

}  // namespace

void Renderer::Render(const Pose2& pose, cv::Mat* bgr, cv::Mat* depth) const {
  const int w = options_.width;
  bgr->create(options_.height, w, CV_8UC3);
  if (depth != nullptr) depth->create(options_.height, w, CV_32F);
  const double fx = std::cos(pose.heading), fy = std::sin(pose.heading);
  const auto& rooms = world_.rooms();
  const int home = world_.RoomAt(pose.x, pose.y);
  const Lens lens{options_.height, 0.5 * options_.height, options_.camera_height_m, focal_,
                  row_shade_,      floor_depth_};
  std::vector<Span> spans;
  std::vector<double> crossings;
  for (int c = 0; c < w; ++c) {
    const double s = column_slope_[static_cast<size_t>(c)];
    const Ray ray{pose.x, pose.y, fx - s * fy, fy + s * fx};
    const Hit hit = NearestWall(world_.walls(), ray);
    SplitIntoRooms(world_, ray, home, hit.t, crossings, spans);
    const int hit_room = spans.back().room;
    const Appearance* look =
        hit_room >= 0 ? &rooms[static_cast<size_t>(hit_room)].appearance : nullptr;
    const Column px{bgr->data + 3 * c, bgr->step,
                    depth != nullptr ? reinterpret_cast<float*>(depth->data) + c : nullptr,
                    depth != nullptr ? depth->step / sizeof(float) : 0};
    int r_top = static_cast<int>(std::floor(lens.cy)), r_bot = r_top;
    if (std::isfinite(hit.t) && look != nullptr) {
      DrawWall(px, lens, hit, rooms[static_cast<size_t>(hit_room)], &r_top, &r_bot);
    }
    DrawCeiling(px, lens, rooms, spans, look, r_top);
    DrawFloor(px, lens, rooms, spans, r_bot);
    DrawBox(px, lens, rooms, spans, ray, hit.t);
  }
}

void Renderer::ApplyLighting(const Lighting& light, std::mt19937& rng, cv::Mat* bgr) const {
  CV_Assert(bgr->type() == CV_8UC3 && bgr->isContinuous());
  cv::Mat lut(1, 256, CV_8U);
  for (int i = 0; i < 256; ++i) {
    lut.at<uchar>(i) =
        cv::saturate_cast<uchar>(light.gain * ((i - 128.0) * light.contrast + 128.0));
  }
  cv::LUT(*bgr, lut, *bgr);
  const size_t n = bgr->total() * 3;
  CV_Assert(n <= noise_pool_.size());
  const size_t offset = std::uniform_int_distribution<size_t>(0, noise_pool_.size() - n)(rng);
  if (light.noise_sigma <= 0.0) return;
  const int k = static_cast<int>(std::lround(light.noise_sigma * 16.0));  // (pool·k) >> 8
  const std::int8_t* noise = noise_pool_.data() + offset;
  uchar* p = bgr->data;
  for (size_t i = 0; i < n; ++i) {
    const int v = p[i] + ((noise[i] * k) >> 8);
    p[i] = static_cast<uchar>(v < 0 ? 0 : v > 255 ? 255 : v);
  }
}

}  // namespace tsc::sim
