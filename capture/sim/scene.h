#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/floor_marker.h"
#include "core/tsai_camera.h"

namespace occmap::sim {

// Simulated scenes: a room (textured floor, walls, bookshelves) watched by Tsai-model cameras, with
// objects that move on the floor. Everything is in metres except the cameras' Tsai parameters (mm).
// Scenes are deterministic functions of time, so any frame can be rendered, and its truth known,
// in any order.

// A solid standing on the floor: a vertical cylinder or an axis-aligned box, z from 0 to `height`.
struct Solid {
  enum class Shape : std::uint8_t { kCylinder, kBox };
  Shape shape = Shape::kCylinder;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d half_size = Eigen::Vector2d::Zero();  // box: half extents; cylinder: radius in x
  double height = 0;

  double radius() const { return half_size.x(); }
  // Whether the floor point lies inside the footprint (the boundary counts as inside).
  bool footprintContains(const Eigen::Vector2d& p) const;
  // Whether the footprint overlaps / contains the axis-aligned square [min, max].
  bool footprintOverlaps(const Eigen::Vector2d& min, const Eigen::Vector2d& max) const;
  bool footprintCovers(const Eigen::Vector2d& min, const Eigen::Vector2d& max) const;
  // How far the floor point lies outside the footprint (0 inside).
  double footprintDistance(const Eigen::Vector2d& p) const;
  // Where origin + t direction first enters the solid for t in (t_min, t_max), with the outward
  // normal.
  struct Hit {
    double t;
    Eigen::Vector3d normal;
  };
  std::optional<Hit> intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                               double t_min, double t_max) const;
};

// A patch of light on the floor: inside, every grey level times `gain`, blending to 1 over
// `soft_m` across its edge (0: sharp, as sun through a window). Round (radius half_size.x) or an
// axis-aligned rectangle. Where patches overlap their gains multiply.
struct LightPatch {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d half_size = Eigen::Vector2d::Zero();
  bool round = false;
  double soft_m = 0.0;
  double gain = 1.0;
  // The gain at floor point p.
  double at(const Eigen::Vector2d& p) const;
  // Half the side of the square around the centre outside which the gain is exactly 1.
  double reach() const {
    return std::max(half_size.x(), round ? half_size.x() : half_size.y()) +
           std::max(0.0, soft_m) / 2;
  }
};

enum class ObjectKind : std::uint8_t { kPerson, kChair, kRobot, kBox };
std::string_view objectKindName(ObjectKind kind);

// A moving object at one moment.
struct SceneObject {
  ObjectKind kind;
  Solid solid;
};

// How a solid looks: all objects but boxes are darker than every static surface by more than any
// threshold a test uses plus the sensor noise, so each pixel where an object hides the background
// is "changed". Boxes (room-day's) are only 26 to 60 below the floor's planks.
inline constexpr int kBrightestObject = 60;
inline constexpr int kDarkestBackground = 100;
inline constexpr int kSensorNoiseAmplitude = 6;  // grey levels, each way

// A camera of the scene: name, Tsai calibration (mm) and stream size.
struct SceneCamera {
  std::string name;
  TsaiParameters calibration;
};

// A camera knocked on its mount at a moment of the scene: from `at_s` on it looks along its old
// view turned by `turn` (axis times angle in radians, in camera coordinates: x right, y down, z
// along the optical axis), about its own centre. Its calibration still describes the old pose.
struct Knock {
  double at_s = 0;
  Eigen::Vector3d turn = Eigen::Vector3d::Zero();
};
// The calibration of a camera turned so.
TsaiParameters turnedOnItsMount(const TsaiParameters& calibration, const Eigen::Vector3d& turn);

// The scene's markers lie on white paper (core/floor_marker.h says where their corners are).
// The paper's margin round a marker, as a fraction of its side.
inline constexpr double kMarkerPaperMargin = 0.25;

class Scene {
 public:
  virtual ~Scene() = default;

  virtual std::string_view name() const = 0;
  virtual const std::vector<SceneCamera>& cameras() const = 0;
  // Scripted motion lasts this long; off-line sources end there, live ones loop.
  virtual double durationS() const = 0;
  // The objects at time t, written into `out` (its capacity is reused: no allocation per frame).
  virtual void objectsAt(double t, std::vector<SceneObject>& out) const = 0;
  std::vector<SceneObject> objectsAt(double t) const {
    std::vector<SceneObject> out;
    objectsAt(t, out);
    return out;
  }

  // Static geometry: the room's floor rectangle [0, size.x] x [0, size.y], its wall height, and the
  // furniture that never moves (part of the background).
  virtual Eigen::Vector2d roomSize() const = 0;
  virtual double wallHeight() const = 0;
  virtual const std::vector<Solid>& furniture() const = 0;
  // Whether a point lies inside the room (where a camera must stand to see it from within).
  bool roomContains(const Eigen::Vector3d& point) const;

  // Grey level of a static surface point; `normal` tells floor (z), walls and furniture sides
  // apart.
  virtual double staticShade(const Eigen::Vector3d& point, const Eigen::Vector3d& normal) const = 0;
  virtual double objectShade(const SceneObject& object, const Eigen::Vector3d& point) const = 0;
  // The light at time t as a gain on every grey level a camera records (daylight, a dimmer, the
  // camera's own exposure): 1 while it is as it was when the backgrounds were taken.
  virtual double lightGain(double /*t*/) const { return 1.0; }
  // Light on part of the floor at time t (a lamp's pool, sun through a window, shade), on top of
  // lightGain; objects are not lit by it.
  virtual void lightPatches(double /*t*/, std::vector<LightPatch>& out) const { out.clear(); }
  // Whether the camera of this name is knocked during the scene, and how.
  virtual std::optional<Knock> knock(std::string_view /*camera*/) const { return std::nullopt; }
  // The moments something changes at once (a step of the light, a lamp switched, an object put
  // down or a person stopping, a knock), for measures taken some time after each.
  virtual std::vector<double> eventTimes() const { return {}; }

  // ArUco markers lying on the floor (part of the static background), from the dictionary named
  // as OpenCV names it.
  virtual const std::vector<FloorMarker>& floorMarkers() const;
  virtual std::string_view markerDictionary() const { return "DICT_4X4_50"; }
  // Rays per pixel along each axis for the static background (n x n, their shades averaged), as a
  // camera integrates light over its pixel: 1 is one ray through the pixel's centre. Sub-pixel
  // corner detection needs edges without staircases.
  virtual int backgroundSamples() const { return 1; }

  // The nearest static surface along a ray (t > 1e-9), with its normal; rays from inside the room
  // always hit something (walls and ceiling close it).
  struct Hit {
    double t;
    Eigen::Vector3d normal;
    bool floor;  // the visible floor, not furniture, walls or ceiling
  };
  Hit castStatic(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;
  // The room's faces alone (floor, walls, ceiling): castStatic before the furniture.
  Hit castRoom(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;
};

// Built-in scenes by name ("room": the paper's set-up; "room-light": the same room and people while
// its light steps and ramps; "room-gains": the light stepped and ramped between half and double;
// "room-lamps": light in parts of it; "room-knock": camera c1 turned by
// 1 degree at 1 s; "room-day": ten minutes of light, lamps, sun, shadows, a box left, a person
// standing still and a knock; docs/lighting.md; "room-crowd": twelve people walking, and
// "room-crowd-N" (N from 1) another twelve for each N;
// "room-markers": the room empty, with ArUco markers on its floor, for calibration). Empty for an
// unknown name.
std::unique_ptr<Scene> makeScene(std::string_view name);
std::vector<std::string> sceneNames();

// The scene's floor markers as the calibration tool reads them (markers.yaml): the dictionary, then
// one line per marker, `  - {id: 3, centre_m: [x, y], side_m: 0.3, yaw_deg: 0}`.
std::string markersYamlText(const Scene& scene);

}  // namespace occmap::sim
