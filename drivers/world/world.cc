#include "drivers/world/world.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace tsc::sim {
namespace {

double Uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

/// HSV (all in [0, 1]) to BGR.
cv::Vec3b Hsv(double h, double s, double v) {
  h = h - std::floor(h);
  const double c = v * s;
  const double hp = h * 6.0;
  const double x = c * (1.0 - std::abs(std::fmod(hp, 2.0) - 1.0));
  double r = 0, g = 0, b = 0;
  if (hp < 1) {
    r = c, g = x;
  } else if (hp < 2) {
    r = x, g = c;
  } else if (hp < 3) {
    g = c, b = x;
  } else if (hp < 4) {
    g = x, b = c;
  } else if (hp < 5) {
    r = x, b = c;
  } else {
    r = c, b = x;
  }
  const double m = v - c;
  auto to8 = [](double t) { return cv::saturate_cast<uchar>(255.0 * t); };
  return {to8(b + m), to8(g + m), to8(r + m)};
}

/// Distinct looks for n rooms: hues spread around the circle, textures cycled from a shuffled
/// list, frequencies and floor colours varied.
std::vector<Appearance> Appearances(int n, std::mt19937& rng) {
  std::vector<TextureKind> kinds = {TextureKind::kVerticalStripes, TextureKind::kHorizontalStripes,
                                    TextureKind::kDiagonalStripes, TextureKind::kChecker,
                                    TextureKind::kNoise};
  std::shuffle(kinds.begin(), kinds.end(), rng);
  const double hue0 = Uniform(rng, 0.0, 1.0);
  std::vector<double> hues;
  for (int i = 0; i < n; ++i) hues.push_back(hue0 + static_cast<double>(i) / n);
  std::shuffle(hues.begin(), hues.end(), rng);
  std::vector<Appearance> out;
  for (int i = 0; i < n; ++i) {
    Appearance a;
    const double h = hues[static_cast<size_t>(i)];
    a.wall_a = Hsv(h, Uniform(rng, 0.35, 0.8), Uniform(rng, 0.7, 0.95));
    a.wall_b = Hsv(h + Uniform(rng, 0.05, 0.2), Uniform(rng, 0.3, 0.9), Uniform(rng, 0.3, 0.55));
    a.texture = kinds[static_cast<size_t>(i) % kinds.size()];
    a.frequency_per_m = Uniform(rng, 0.8, 4.0);
    a.floor = Hsv(h + 0.5, Uniform(rng, 0.1, 0.5), Uniform(rng, 0.25, 0.55));
    a.ceiling = Hsv(h, 0.05, Uniform(rng, 0.8, 0.95));
    out.push_back(a);
  }
  return out;
}

Appearance OutdoorAppearance(std::mt19937& rng, double ground_value) {
  Appearance a;
  a.outdoor = true;
  a.texture = TextureKind::kFacade;
  a.wall_height_m = Uniform(rng, 7.0, 10.0);
  a.frequency_per_m = Uniform(rng, 0.5, 0.8);  // windows per metre
  a.wall_a = Hsv(Uniform(rng, 0.0, 1.0), Uniform(rng, 0.2, 0.5), Uniform(rng, 0.6, 0.85));
  a.wall_b = Hsv(Uniform(rng, 0.5, 0.7), 0.3, 0.3);  // window glass
  a.floor = Hsv(Uniform(rng, 0.0, 1.0), 0.1, ground_value);
  a.ceiling = cv::Vec3b(235, 200, 150);  // sky
  return a;
}

/// 2–4 posters on random sides of the room, 1–2.5 m wide, between 0.8 and 2.2 m high.
void AddPosters(Room& room, std::mt19937& rng) {
  const int n = std::uniform_int_distribution<int>(2, 4)(rng);
  for (int i = 0; i < n; ++i) {
    Poster p;
    const int side = std::uniform_int_distribution<int>(0, 3)(rng);
    p.vertical_wall = side < 2;
    p.line = side == 0 ? room.x0 : side == 1 ? room.x1 : side == 2 ? room.y0 : room.y1;
    const double lo = p.vertical_wall ? room.y0 : room.x0;
    const double hi = p.vertical_wall ? room.y1 : room.x1;
    const double w = std::min(Uniform(rng, 1.0, 2.5), 0.8 * (hi - lo));
    p.u0 = Uniform(rng, lo + 0.1, hi - w - 0.1);
    p.u1 = p.u0 + w;
    const double top = std::min(room.appearance.wall_height_m - 0.2, 2.2);
    p.v0 = Uniform(rng, 0.8, 1.3);
    p.v1 = Uniform(rng, p.v0 + 0.4, top);
    p.colour = Hsv(Uniform(rng, 0, 1), Uniform(rng, 0.6, 1.0), Uniform(rng, 0.5, 1.0));
    room.posters.push_back(p);
  }
}

/// Furniture in 2–3 of the room's corners, 0.2 m from the walls, at most 0.7 m on a side:
/// routes (centre to doors in the middle third of a side) never cross them.
void AddBoxes(Room& room, std::mt19937& rng) {
  std::vector<int> corners = {0, 1, 2, 3};
  std::shuffle(corners.begin(), corners.end(), rng);
  const int n = std::uniform_int_distribution<int>(2, 3)(rng);
  for (int i = 0; i < n; ++i) {
    const int c = corners[static_cast<size_t>(i)];
    Box b;
    const double sx = Uniform(rng, 0.4, 0.7);
    const double sy = Uniform(rng, 0.4, 0.7);
    b.x0 = (c & 1) ? room.x1 - 0.2 - sx : room.x0 + 0.2;
    b.y0 = (c & 2) ? room.y1 - 0.2 - sy : room.y0 + 0.2;
    b.x1 = b.x0 + sx;
    b.y1 = b.y0 + sy;
    b.height_m = Uniform(rng, 0.5, 1.9);
    b.colour = Hsv(Uniform(rng, 0, 1), Uniform(rng, 0.3, 0.9), Uniform(rng, 0.15, 0.6));
    room.boxes.push_back(b);
  }
}

/// A door of width 0.9–1.1 m centred in the middle third of [lo, hi].
Door DoorIn(bool vertical_wall, double line, double lo, double hi, int a, int b,
            std::mt19937& rng) {
  const double third = (hi - lo) / 3.0;
  const double centre = Uniform(rng, lo + third, hi - third);
  const double half = 0.5 * Uniform(rng, 0.9, 1.1);
  return Door{vertical_wall, line, centre - half, centre + half, a, b};
}

Room MakeRoom(std::string label, double x0, double y0, double x1, double y1, bool transit) {
  Room r;
  r.label = std::move(label);
  r.x0 = x0, r.y0 = y0, r.x1 = x1, r.y1 = y1;
  r.transit = transit;
  return r;
}

/// Rooms off a corridor along x: a row north and a row south.
void Office(std::mt19937& rng, std::vector<Room>& rooms, std::vector<Door>& doors) {
  const double cw = Uniform(rng, 2.2, 2.6);
  rooms.push_back(MakeRoom("corridor", 0, 0, 0, cw, true));
  const int per_row = std::uniform_int_distribution<int>(3, 4)(rng);
  std::vector<double> widths_n, widths_s;
  double len_n = 0, len_s = 0;
  for (int i = 0; i < per_row; ++i) {
    widths_n.push_back(Uniform(rng, 4.0, 6.0));
    widths_s.push_back(Uniform(rng, 4.0, 6.0));
    len_n += widths_n.back();
    len_s += widths_s.back();
  }
  const double length = std::max(len_n, len_s);
  widths_n.back() += length - len_n;
  widths_s.back() += length - len_s;
  rooms[0].x1 = length;
  int label = 1;
  for (int row = 0; row < 2; ++row) {
    double x = 0;
    for (double w : row == 0 ? widths_n : widths_s) {
      const double depth = Uniform(rng, 4.0, 6.0);
      const int idx = static_cast<int>(rooms.size());
      if (row == 0) {
        rooms.push_back(
            MakeRoom("room" + std::to_string(label++), x, cw, x + w, cw + depth, false));
        doors.push_back(DoorIn(false, cw, x, x + w, 0, idx, rng));
      } else {
        rooms.push_back(MakeRoom("room" + std::to_string(label++), x, -depth, x + w, 0, false));
        doors.push_back(DoorIn(false, 0, x, x + w, 0, idx, rng));
      }
      x += w;
    }
  }
}

/// Three corridors in a U (south, east, north) and four rooms off them.
void Corridors(std::mt19937& rng, std::vector<Room>& rooms, std::vector<Door>& doors) {
  const double w = Uniform(rng, 2.2, 2.5);
  const double len = Uniform(rng, 16.0, 20.0);
  const double height = Uniform(rng, 12.0, 14.0);
  rooms.push_back(MakeRoom("corridor1", 0, 0, len, w, true));
  rooms.push_back(MakeRoom("corridor2", len, 0, len + w, height, true));
  rooms.push_back(MakeRoom("corridor3", 0, height - w, len, height, true));
  doors.push_back(Door{true, len, 0.15, w - 0.15, 0, 1});
  doors.push_back(Door{true, len, height - w + 0.15, height - 0.15, 2, 1});
  auto add = [&](double x0, double y0, double x1, double y1, bool vertical, double line,
                 int corridor) {
    const int idx = static_cast<int>(rooms.size());
    rooms.push_back(MakeRoom("room" + std::to_string(idx - 2), x0, y0, x1, y1, false));
    doors.push_back(vertical ? DoorIn(true, line, y0, y1, corridor, idx, rng)
                             : DoorIn(false, line, x0, x1, corridor, idx, rng));
  };
  const double rw1 = Uniform(rng, 4.0, 6.0), rd1 = Uniform(rng, 4.0, 5.0);
  add(1.5, w, 1.5 + rw1, w + rd1, false, w, 0);
  const double rw2 = Uniform(rng, 4.0, 6.0), rd2 = Uniform(rng, 4.0, 5.0);
  add(len - 1.5 - rw2, height - w - rd2, len - 1.5, height - w, false, height - w, 2);
  const double rw3 = Uniform(rng, 4.0, 6.0), rd3 = Uniform(rng, 4.0, 6.0);
  add(len + w, 0.5 * height - 0.5 * rd3, len + w + rw3, 0.5 * height + 0.5 * rd3, true, len + w, 1);
  const double rw4 = Uniform(rng, 4.0, 6.0), rd4 = Uniform(rng, 4.0, 5.0);
  add(len - 1.0 - rw4, -rd4, len - 1.0, 0, false, 0, 0);
}

/// A street (east–west) and a square north of it, lined with facades; two rooms off the street.
void Outdoor(std::mt19937& rng, std::vector<Room>& rooms, std::vector<Door>& doors) {
  const double len = Uniform(rng, 26.0, 30.0);
  const double sw = Uniform(rng, 7.0, 9.0);
  const double sq = Uniform(rng, 11.0, 13.0);
  const double sx0 = 0.5 * (len - sq);
  rooms.push_back(MakeRoom("street", 0, 0, len, sw, true));
  rooms.push_back(MakeRoom("square", sx0, sw, sx0 + sq, sw + sq, false));
  doors.push_back(Door{false, sw, sx0 + 1.5, sx0 + sq - 1.5, 0, 1});
  const double rw1 = Uniform(rng, 4.5, 6.0), rd1 = Uniform(rng, 4.0, 5.5);
  rooms.push_back(MakeRoom("room1", 2.0, -rd1, 2.0 + rw1, 0, false));
  doors.push_back(DoorIn(false, 0, 2.0, 2.0 + rw1, 0, 2, rng));
  const double rw2 = Uniform(rng, 4.5, 6.0), rd2 = Uniform(rng, 4.0, 5.5);
  rooms.push_back(MakeRoom("room2", len - 2.0 - rw2, -rd2, len - 2.0, 0, false));
  doors.push_back(DoorIn(false, 0, len - 2.0 - rw2, len - 2.0, 0, 3, rng));
}

void AppendJson(std::ostringstream& out, const cv::Vec3b& c) {
  out << "[" << int{c[0]} << "," << int{c[1]} << "," << int{c[2]} << "]";
}

std::string Quoted(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}

}  // namespace

WorldKind ParseWorldKind(const std::string& name) {
  if (name == "office") return WorldKind::kOffice;
  if (name == "corridors") return WorldKind::kCorridors;
  if (name == "outdoor") return WorldKind::kOutdoor;
  throw std::invalid_argument("unknown world '" + name + "' (office, corridors or outdoor)");
}

const char* WorldKindName(WorldKind kind) {
  switch (kind) {
    case WorldKind::kOffice:
      return "office";
    case WorldKind::kCorridors:
      return "corridors";
    case WorldKind::kOutdoor:
      return "outdoor";
  }
  return "?";
}

World::World(WorldKind kind, std::vector<Room> rooms, std::vector<Door> doors)
    : kind_(kind), rooms_(std::move(rooms)), doors_(std::move(doors)) {
  if (rooms_.empty()) throw std::invalid_argument("World: no rooms");
  for (const Room& r : rooms_) {
    if (!(r.x1 > r.x0 && r.y1 > r.y0)) {
      throw std::invalid_argument("World: room '" + r.label + "' has no area");
    }
  }
  const int n = static_cast<int>(rooms_.size());
  for (const Door& d : doors_) {
    if (d.room_a < 0 || d.room_a >= n || d.room_b < 0 || d.room_b >= n || !(d.hi > d.lo)) {
      throw std::invalid_argument("World: bad door on line " + std::to_string(d.line));
    }
  }
  // Each room side minus the door gaps on it. Shared sides appear twice; harmless.
  for (const Room& r : rooms_) {
    const struct {
      bool vertical;
      double line, lo, hi;
    } sides[4] = {{true, r.x0, r.y0, r.y1},
                  {true, r.x1, r.y0, r.y1},
                  {false, r.y0, r.x0, r.x1},
                  {false, r.y1, r.x0, r.x1}};
    for (const auto& s : sides) {
      std::vector<std::pair<double, double>> gaps;
      for (const Door& d : doors_) {
        if (d.vertical_wall == s.vertical && std::abs(d.line - s.line) < 1e-9 && d.hi > s.lo &&
            d.lo < s.hi) {
          gaps.emplace_back(d.lo, d.hi);
        }
      }
      std::sort(gaps.begin(), gaps.end());
      double at = s.lo;
      auto emit = [&](double a, double b) {
        if (b - a < 1e-9) return;
        walls_.push_back(s.vertical ? Wall{s.line, a, s.line, b} : Wall{a, s.line, b, s.line});
      };
      for (const auto& [glo, ghi] : gaps) {
        emit(at, std::max(at, glo));
        at = std::max(at, ghi);
      }
      emit(at, s.hi);
    }
  }
}

World World::Generate(WorldKind kind, std::mt19937& rng) {
  std::vector<Room> rooms;
  std::vector<Door> doors;
  switch (kind) {
    case WorldKind::kOffice:
      Office(rng, rooms, doors);
      break;
    case WorldKind::kCorridors:
      Corridors(rng, rooms, doors);
      break;
    case WorldKind::kOutdoor:
      Outdoor(rng, rooms, doors);
      break;
  }
  const std::vector<Appearance> looks = Appearances(static_cast<int>(rooms.size()), rng);
  double ground = 0.35;
  for (size_t i = 0; i < rooms.size(); ++i) {
    Room& r = rooms[i];
    const bool outdoor =
        kind == WorldKind::kOutdoor && (r.label == "street" || r.label == "square");
    if (outdoor) {
      r.appearance = OutdoorAppearance(rng, ground);
      ground += 0.2;  // street and square differ in paving
    } else {
      r.appearance = looks[i];
    }
    AddPosters(r, rng);
    if (!r.transit && !outdoor) AddBoxes(r, rng);
  }
  return World(kind, std::move(rooms), std::move(doors));
}

int World::RoomAt(double x, double y) const {
  for (size_t i = 0; i < rooms_.size(); ++i) {
    if (rooms_[i].Contains(x, y)) return static_cast<int>(i);
  }
  return -1;
}

cv::Vec4d World::DoorwayZone(int i) const {
  const Door& d = doors_.at(static_cast<size_t>(i));
  const double h = kDoorwayHalfDepthM;
  return d.vertical_wall ? cv::Vec4d(d.line - h, d.lo, d.line + h, d.hi)
                         : cv::Vec4d(d.lo, d.line - h, d.hi, d.line + h);
}

bool World::InDoorway(double x, double y) const {
  for (int i = 0; i < static_cast<int>(doors_.size()); ++i) {
    const cv::Vec4d z = DoorwayZone(i);
    if (x >= z[0] && x <= z[2] && y >= z[1] && y <= z[3]) return true;
  }
  return false;
}

std::string World::LabelAt(double x, double y) const {
  if (InDoorway(x, y)) return "";
  const int r = RoomAt(x, y);
  return r < 0 ? std::string() : rooms_[static_cast<size_t>(r)].label;
}

std::string World::ToJson() const {
  std::ostringstream out;
  out.precision(6);
  double wall_height = 0;
  for (const Room& r : rooms_) wall_height = std::max(wall_height, r.appearance.wall_height_m);
  out << "{\"kind\":\"" << WorldKindName(kind_) << "\",\"wall_height_m\":" << wall_height
      << ",\n\"rooms\":[";
  for (size_t i = 0; i < rooms_.size(); ++i) {
    const Room& r = rooms_[i];
    out << (i ? ",\n" : "\n") << "{\"label\":" << Quoted(r.label) << ",\"x0\":" << r.x0
        << ",\"y0\":" << r.y0 << ",\"x1\":" << r.x1 << ",\"y1\":" << r.y1
        << ",\"transit\":" << (r.transit ? "true" : "false")
        << ",\"outdoor\":" << (r.appearance.outdoor ? "true" : "false") << ",\"wall_bgr\":";
    AppendJson(out, r.appearance.wall_a);
    out << ",\"floor_bgr\":";
    AppendJson(out, r.appearance.floor);
    out << ",\"boxes\":[";
    for (size_t j = 0; j < r.boxes.size(); ++j) {
      const Box& b = r.boxes[j];
      out << (j ? "," : "") << "{\"x0\":" << b.x0 << ",\"y0\":" << b.y0 << ",\"x1\":" << b.x1
          << ",\"y1\":" << b.y1 << ",\"height_m\":" << b.height_m << "}";
    }
    out << "]}";
  }
  out << "],\n\"walls\":[";
  for (size_t i = 0; i < walls_.size(); ++i) {
    const Wall& w = walls_[i];
    out << (i ? ",\n" : "\n") << "{\"x0\":" << w.x0 << ",\"y0\":" << w.y0 << ",\"x1\":" << w.x1
        << ",\"y1\":" << w.y1 << "}";
  }
  out << "],\n\"doors\":[";
  for (size_t i = 0; i < doors_.size(); ++i) {
    const Door& d = doors_[i];
    const double x0 = d.vertical_wall ? d.line : d.lo, x1 = d.vertical_wall ? d.line : d.hi;
    const double y0 = d.vertical_wall ? d.lo : d.line, y1 = d.vertical_wall ? d.hi : d.line;
    const cv::Vec4d z = DoorwayZone(static_cast<int>(i));
    out << (i ? ",\n" : "\n") << "{\"x0\":" << x0 << ",\"y0\":" << y0 << ",\"x1\":" << x1
        << ",\"y1\":" << y1 << ",\"rooms\":[" << d.room_a << "," << d.room_b << "],\"zone\":["
        << z[0] << "," << z[1] << "," << z[2] << "," << z[3] << "]}";
  }
  out << "]}\n";
  return out.str();
}

}  // namespace tsc::sim
