#include "core/hidden_floor.h"

#include <algorithm>
#include <limits>
#include <optional>

namespace occmap {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr HiddenFloor::Rectangle kNotInView{kInfinity, kInfinity, -kInfinity, -kInfinity};

// The rectangle holding the points' pixels, or kNotInView when one has none.
template <std::size_t N>
HiddenFloor::Rectangle rectangleOf(const Camera& camera, const Eigen::Vector3d (&points)[N]) {
  HiddenFloor::Rectangle r = {kInfinity, kInfinity, -kInfinity, -kInfinity};
  for (const Eigen::Vector3d& point : points) {
    const std::optional<Eigen::Vector2d> pixel = camera.worldToStream(point);
    if (!pixel) return kNotInView;
    r.u0 = std::min(r.u0, static_cast<float>(pixel->x()));
    r.u1 = std::max(r.u1, static_cast<float>(pixel->x()));
    r.v0 = std::min(r.v0, static_cast<float>(pixel->y()));
    r.v1 = std::max(r.v1, static_cast<float>(pixel->y()));
  }
  return r;
}

}  // namespace

HiddenFloor::HiddenFloor(const MapGeometry& map, std::span<const std::uint32_t> cells,
                         std::span<const Camera> cameras, const FootprintSettings& settings,
                         double column_height_m)
    : camera_list_(cameras.begin(), cameras.end()), cameras_(cameras.size()), box_(settings) {
  for (const Camera& camera : cameras) {
    const Eigen::Vector3d centre = camera.centreMetres();
    below_.emplace_back(centre.x(), centre.y());
  }
  // Room for a crowd found, so that the usual map allocates nothing.
  constexpr std::size_t kRoom = 64;
  found_at_.reserve(kRoom);
  shadows_.reserve(kRoom * cameras_);
  centres_.reserve(cells.size());
  sights_.reserve(cells.size() * cameras_);
  for (const std::uint32_t cell : cells) {
    const Eigen::Vector2d p = map.cellCentre(std::size_t{cell});
    centres_.push_back(p.cast<float>());
    for (const Camera& camera : camera_list_) {
      // The cell is in view when its centre's floor point is in the image (as the map's tables
      // have it); its column's pixels then run from there to the top of the column.
      const Eigen::Vector3d column[2] = {{p.x(), p.y(), 0.0}, {p.x(), p.y(), column_height_m}};
      const Rectangle sight = rectangleOf(camera, column);
      const std::optional<Eigen::Vector2d> foot = camera.worldToStream(column[0]);
      const bool foot_in = foot && foot->x() >= -0.5 && foot->y() >= -0.5 &&
                           foot->x() < camera.streamWidth() - 0.5 &&
                           foot->y() < camera.streamHeight() - 0.5;
      sights_.push_back(foot_in ? sight : kNotInView);
    }
  }
}

void HiddenFloor::setFound(std::span<const Detection> found) {
  found_at_.resize(found.size());
  shadows_.resize(found.size() * cameras_);
  const double half = box_.box_width_m / 2;
  for (std::size_t p = 0; p < found.size(); ++p) {
    const Detection& person = found[p];
    const double height = person.height_m > 0 ? person.height_m : box_.box_height_m;
    const Eigen::Vector2d at(person.x_m, person.y_m);
    found_at_[p] = at.cast<float>();
    for (std::size_t k = 0; k < cameras_; ++k) {
      // The detector's box (core/footprints.cpp): the upright board, box_width_m wide and as high
      // as what was found, facing the camera.
      Rectangle& shadow = shadows_[p * cameras_ + k];
      shadow = kNotInView;
      const Eigen::Vector2d to = at - below_[k];
      const double distance = to.norm();
      if (distance < 1e-9) continue;
      const Eigen::Vector2d across = Eigen::Vector2d(-to.y(), to.x()) * (half / distance);
      const Eigen::Vector3d corners[4] = {{at.x() - across.x(), at.y() - across.y(), 0.0},
                                          {at.x() + across.x(), at.y() + across.y(), 0.0},
                                          {at.x() - across.x(), at.y() - across.y(), height},
                                          {at.x() + across.x(), at.y() + across.y(), height}};
      shadow = rectangleOf(camera_list_[k], corners);
    }
  }
}

bool HiddenFloor::hidden(std::size_t i) const {
  // A person's own footprint is theirs: a cell within half the box's width of someone found is
  // not hidden, however others' boxes cover it. Up to a whole box's width it is the edge of their
  // blob on the map: something stands there, but it is them.
  const float reach = static_cast<float>(box_.box_width_m / 2);
  const Eigen::Vector2f& at = centres_[i];
  float nearest = std::numeric_limits<float>::infinity();
  for (const Eigen::Vector2f& p : found_at_) nearest = std::min(nearest, (at - p).squaredNorm());
  if (nearest <= reach * reach) return false;
  if (nearest <= 4 * reach * reach) return true;
  // Farther from everyone: hidden when every camera that sees it has someone found in the way.
  bool seen_at_all = false;
  for (std::size_t k = 0; k < cameras_; ++k) {
    const Rectangle& sight = sights_[i * cameras_ + k];
    if (!sight.seen()) continue;
    seen_at_all = true;
    bool behind = false;
    for (std::size_t p = 0; p < found_at_.size() && !behind; ++p) {
      const Rectangle& s = shadows_[p * cameras_ + k];
      behind = sight.u0 <= s.u1 && s.u0 <= sight.u1 && sight.v0 <= s.v1 && s.v0 <= sight.v1;
    }
    if (!behind) return false;
  }
  return seen_at_all;
}

}  // namespace occmap
