#pragma once
// The simulated world (DESIGN §7): a generated 2D floor plan of axis-aligned rectangular areas
// ("rooms": offices, corridors, outdoor areas) separated by walls with doors (gaps), each with
// its own appearance (wall colours and texture, posters, furniture-like boxes, floor and
// ceiling colours). Units: metres; the plan's x axis points east, y north; headings are
// radians counter-clockwise from +x.

#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

namespace tsc::sim {

enum class WorldKind {
  kOffice,     ///< rooms off a single corridor
  kCorridors,  ///< three corridors in a U with a few rooms
  kOutdoor,    ///< a street and a square lined with building facades, plus two rooms
};

/// "office" | "corridors" | "outdoor"; throws std::invalid_argument naming the bad value.
WorldKind ParseWorldKind(const std::string& name);
const char* WorldKindName(WorldKind kind);

/// How a wall surface is patterned. Frequencies are in cycles per metre.
enum class TextureKind {
  kVerticalStripes,
  kHorizontalStripes,
  kDiagonalStripes,
  kChecker,
  kNoise,
  kFacade
};

/// The look of one room; colours are BGR.
struct Appearance {
  cv::Vec3b wall_a{200, 200, 200};
  cv::Vec3b wall_b{150, 150, 150};
  TextureKind texture = TextureKind::kVerticalStripes;
  double frequency_per_m = 2.0;
  cv::Vec3b floor{90, 90, 90};
  cv::Vec3b ceiling{230, 230, 230};  ///< the sky colour outdoors
  double wall_height_m = 2.5;
  bool outdoor = false;  ///< no ceiling: a sky gradient and no ceiling depth
};

/// A coloured rectangle on one wall side of a room. The wall is the line x = line (vertical
/// wall) or y = line; [u0, u1] is along the wall (the other coordinate), [v0, v1] height in m.
struct Poster {
  bool vertical_wall = true;
  double line = 0.0;
  double u0 = 0.0, u1 = 0.0, v0 = 0.0, v1 = 0.0;
  cv::Vec3b colour{0, 0, 255};
};

/// An axis-aligned furniture-like block standing on the floor.
struct Box {
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
  double height_m = 0.8;
  cv::Vec3b colour{60, 60, 60};
};

struct Room {
  std::string label;  ///< ground-truth place label, e.g. "room1", "corridor", "street"
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
  bool transit = false;  ///< corridors and streets: routes pass through without dwelling
  Appearance appearance;
  std::vector<Poster> posters;
  std::vector<Box> boxes;

  bool Contains(double x, double y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
  double cx() const { return 0.5 * (x0 + x1); }
  double cy() const { return 0.5 * (y0 + y1); }
};

/// A gap in the wall between rooms a and b, on the line x = line (vertical_wall) or y = line,
/// spanning [lo, hi] along it.
struct Door {
  bool vertical_wall = true;
  double line = 0.0;
  double lo = 0.0, hi = 0.0;
  int room_a = 0, room_b = 0;

  double cx() const { return vertical_wall ? line : 0.5 * (lo + hi); }
  double cy() const { return vertical_wall ? 0.5 * (lo + hi) : line; }
};

/// An axis-aligned wall segment from (x0, y0) to (x1, y1) (x0 == x1 or y0 == y1).
struct Wall {
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
};

/// The floor plan. Invariants (checked by the constructor): at least one room, rooms with
/// positive size, doors referring to existing rooms.
class World {
 public:
  /// Half depth of the doorway zone on each side of a door's wall line, in metres: the ground
  /// truth label is "" within it.
  static constexpr double kDoorwayHalfDepthM = 0.5;

  /// Builds the walls: every room side minus the door gaps on it.
  World(WorldKind kind, std::vector<Room> rooms, std::vector<Door> doors);

  /// A random plan of the given kind; the same seed gives the same plan.
  static World Generate(WorldKind kind, std::mt19937& rng);

  WorldKind kind() const { return kind_; }
  const std::vector<Room>& rooms() const { return rooms_; }
  const std::vector<Door>& doors() const { return doors_; }
  const std::vector<Wall>& walls() const { return walls_; }

  /// Index of the room containing (x, y) (the first one on shared borders), or -1.
  int RoomAt(double x, double y) const;
  /// True within kDoorwayHalfDepthM of a door's wall line, along the door's span.
  bool InDoorway(double x, double y) const;
  /// Ground-truth place label at (x, y): "" in doorways and outside every room.
  std::string LabelAt(double x, double y) const;
  /// Doorway zone of door i as a rectangle {x0, y0, x1, y1}.
  cv::Vec4d DoorwayZone(int i) const;

  /// The plan as JSON:
  ///   {"kind":"office","wall_height_m":2.5,
  ///    "rooms":[{"label":"room1","x0":..,"y0":..,"x1":..,"y1":..,"transit":false,
  ///              "outdoor":false,"wall_bgr":[b,g,r],"floor_bgr":[b,g,r],
  ///              "boxes":[{"x0":..,"y0":..,"x1":..,"y1":..,"height_m":..}]}, ...],
  ///    "walls":[{"x0":..,"y0":..,"x1":..,"y1":..}, ...],
  ///    "doors":[{"x0":..,"y0":..,"x1":..,"y1":..,"rooms":[a,b],
  ///              "zone":[x0,y0,x1,y1]}, ...]}
  /// Coordinates in metres (x east, y north); doors are the gap segments, "zone" the doorway
  /// rectangle where the label is ""; "rooms" of a door index the rooms array.
  std::string ToJson() const;

 private:
  WorldKind kind_;
  std::vector<Room> rooms_;
  std::vector<Door> doors_;
  std::vector<Wall> walls_;
};

}  // namespace tsc::sim
