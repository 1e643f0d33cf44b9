#include "capture/sim/scene.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Geometry>

namespace occmap::sim {

bool Solid::footprintContains(const Eigen::Vector2d& p) const {
  if (shape == Shape::kCylinder) return (p - centre).squaredNorm() <= radius() * radius();
  const Eigen::Vector2d d = (p - centre).cwiseAbs();
  return d.x() <= half_size.x() && d.y() <= half_size.y();
}

double Solid::footprintDistance(const Eigen::Vector2d& p) const {
  if (shape == Shape::kCylinder) return std::max(0.0, (p - centre).norm() - radius());
  return ((p - centre).cwiseAbs() - half_size).cwiseMax(0.0).norm();
}

bool Solid::footprintOverlaps(const Eigen::Vector2d& min, const Eigen::Vector2d& max) const {
  if (shape == Shape::kCylinder) {
    const Eigen::Vector2d nearest = centre.cwiseMax(min).cwiseMin(max);
    return (nearest - centre).squaredNorm() < radius() * radius();
  }
  return min.x() < centre.x() + half_size.x() && max.x() > centre.x() - half_size.x() &&
         min.y() < centre.y() + half_size.y() && max.y() > centre.y() - half_size.y();
}

bool Solid::footprintCovers(const Eigen::Vector2d& min, const Eigen::Vector2d& max) const {
  // Both shapes are convex: the square is inside when its four corners are.
  return footprintContains(min) && footprintContains(max) &&
         footprintContains({min.x(), max.y()}) && footprintContains({max.x(), min.y()});
}

std::optional<Solid::Hit> Solid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                           double t_min, double t_max) const {
  if (shape == Shape::kBox) {
    // Slabs: the entry is the largest of the three entering parameters.
    const Eigen::Vector3d low(centre.x() - half_size.x(), centre.y() - half_size.y(), 0.0);
    const Eigen::Vector3d high(centre.x() + half_size.x(), centre.y() + half_size.y(), height);
    double enter = -std::numeric_limits<double>::infinity();
    double leave = std::numeric_limits<double>::infinity();
    int axis = -1;
    for (int i = 0; i < 3; ++i) {
      if (d[i] == 0.0) {
        if (o[i] < low[i] || o[i] > high[i]) return std::nullopt;
        continue;
      }
      double a = (low[i] - o[i]) / d[i];
      double b = (high[i] - o[i]) / d[i];
      if (a > b) std::swap(a, b);
      if (a > enter) {
        enter = a;
        axis = i;
      }
      leave = std::min(leave, b);
    }
    if (axis < 0 || enter > leave || !(enter > t_min && enter < t_max)) return std::nullopt;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal[axis] = d[axis] > 0 ? -1.0 : 1.0;
    return Hit{enter, normal};
  }
  std::optional<Hit> best;
  const double r = radius();
  // The side: |(o + t d - c)_xy| = r, the entering root, with the hit between floor and top.
  const double ox = o.x() - centre.x();
  const double oy = o.y() - centre.y();
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 0.0) {
    const double b = 2.0 * (ox * d.x() + oy * d.y());
    const double c = ox * ox + oy * oy - r * r;
    const double discriminant = b * b - 4.0 * a * c;
    if (discriminant >= 0.0) {
      const double t = (-b - std::sqrt(discriminant)) / (2.0 * a);
      const double z = o.z() + t * d.z();
      if (t > t_min && t < t_max && z >= 0.0 && z <= height) {
        best = Hit{t, Eigen::Vector3d(ox + t * d.x(), oy + t * d.y(), 0.0) / r};
      }
    }
  }
  // The top, seen from above.
  if (d.z() < 0.0 && o.z() > height) {
    const double t = (height - o.z()) / d.z();
    const double x = ox + t * d.x();
    const double y = oy + t * d.y();
    if (t > t_min && t < t_max && x * x + y * y <= r * r && (!best || t < best->t)) {
      best = Hit{t, Eigen::Vector3d::UnitZ()};
    }
  }
  return best;
}

std::string_view objectKindName(ObjectKind kind) {
  switch (kind) {
    case ObjectKind::kPerson:
      return "person";
    case ObjectKind::kChair:
      return "chair";
    case ObjectKind::kRobot:
      return "robot";
    case ObjectKind::kBox:
      return "box";
  }
  return "object";
}

double LightPatch::at(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d d = (p - centre).cwiseAbs();
  // How far inside the edge (negative outside).
  const double inside =
      round ? half_size.x() - d.norm() : std::min(half_size.x() - d.x(), half_size.y() - d.y());
  const double weight =
      soft_m <= 0.0 ? (inside >= 0.0 ? 1.0 : 0.0) : std::clamp(0.5 + inside / soft_m, 0.0, 1.0);
  return 1.0 + (gain - 1.0) * weight;
}

TsaiParameters turnedOnItsMount(const TsaiParameters& calibration, const Eigen::Vector3d& turn) {
  TsaiParameters turned = calibration;
  turned.setPose(occmap::turnedOnItsMount(TsaiCamera(calibration).pose(), turn));
  return turned;
}

const std::vector<FloorMarker>& Scene::floorMarkers() const {
  static const std::vector<FloorMarker> none;
  return none;
}

std::string markersYamlText(const Scene& scene) {
  // The shortest text that reads back as the same double: full precision, and 0.3 stays "0.3".
  const auto number = [](double value) {
    char digits[32];
    const std::to_chars_result end = std::to_chars(digits, digits + sizeof digits, value);
    return std::string(digits, end.ptr);
  };
  std::string text = "dictionary: " + std::string(scene.markerDictionary()) + "\nmarkers:\n";
  for (const FloorMarker& m : scene.floorMarkers()) {
    text += "  - {id: " + std::to_string(m.id) + ", centre_m: [" + number(m.centre_m.x()) + ", " +
            number(m.centre_m.y()) + "], side_m: " + number(m.side_m) +
            ", yaw_deg: " + number(m.yaw_deg) + "}\n";
  }
  return text;
}

bool Scene::roomContains(const Eigen::Vector3d& p) const {
  const Eigen::Vector2d size = roomSize();
  return p.x() > 0 && p.y() > 0 && p.z() > 0 && p.x() < size.x() && p.y() < size.y() &&
         p.z() < wallHeight();
}

Scene::Hit Scene::castStatic(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  Hit hit = castRoom(o, d);
  for (const Solid& solid : furniture()) {
    const std::optional<Solid::Hit> h = solid.intersect(o, d, 1e-9, hit.t);
    if (h) hit = Hit{h->t, h->normal, false};
  }
  return hit;
}

Scene::Hit Scene::castRoom(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  // The room is a closed box: from inside, the ray leaves it through the nearest face it heads to.
  const Eigen::Vector2d size = roomSize();
  const Eigen::Vector3d high(size.x(), size.y(), wallHeight());
  Hit hit{std::numeric_limits<double>::infinity(), Eigen::Vector3d::Zero(), false};
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) continue;
    const double bound = d[i] > 0 ? high[i] : 0.0;
    const double t = (bound - o[i]) / d[i];
    if (t > 1e-9 && t < hit.t) {
      hit.t = t;
      hit.normal = Eigen::Vector3d::Zero();
      hit.normal[i] = d[i] > 0 ? -1.0 : 1.0;
      hit.floor = (i == 2 && d[i] < 0);
    }
  }
  return hit;
}

}  // namespace occmap::sim
