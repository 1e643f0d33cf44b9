#include "core/hidden_floor.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>

namespace occmap {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr HiddenFloor::Rectangle kNotInView{kInfinity, kInfinity, -kInfinity, -kInfinity};

}  // namespace

HiddenFloor::HiddenFloor(const MapGeometry& map, std::span<const std::uint32_t> cells,
                         std::span<const Camera> cameras, const FootprintSettings& settings,
                         double column_height_m)
    : map_(map),
      cells_(cells.begin(), cells.end()),
      column_height_m_(column_height_m),
      camera_list_(cameras.begin(), cameras.end()),
      cameras_(cameras.size()),
      box_(settings) {
  for (const Camera& camera : cameras) below_.push_back(camera.centreMetres().head<2>());
  // Room for a crowd found, so that the usual map allocates nothing.
  constexpr std::size_t kRoom = 64;
  found_at_.reserve(kRoom);
  shadows_.reserve(kRoom * cameras_);
  centres_.reserve(cells.size());
  sights_.reserve(cells.size() * cameras_);
  for (std::size_t i = 0; i < cells_.size(); ++i) {
    centres_.push_back(map.cellCentre(std::size_t{cells_[i]}).cast<float>());
    for (const Camera& camera : camera_list_) sights_.push_back(sightOf(camera, i));
  }
}

HiddenFloor::Rectangle HiddenFloor::sightOf(const Camera& camera, std::size_t i) const {
  const Eigen::Vector2d p = map_.cellCentre(std::size_t{cells_[i]});
  // The cell is in view when its centre's floor point is in the image (as the map's tables have
  // it); its column's pixels then run from there to the top of the column.
  const std::optional<Eigen::Vector2d> foot = camera.worldToStream({p.x(), p.y(), 0.0});
  const std::optional<Eigen::Vector2d> top = camera.worldToStream({p.x(), p.y(), column_height_m_});
  if (!foot || !top || !camera.pixelIndexAt(*foot)) return kNotInView;
  return {static_cast<float>(std::min(foot->x(), top->x())),
          static_cast<float>(std::min(foot->y(), top->y())),
          static_cast<float>(std::max(foot->x(), top->x())),
          static_cast<float>(std::max(foot->y(), top->y()))};
}

std::vector<HiddenFloor::Rectangle> HiddenFloor::sightsOf(const Camera& camera) const {
  std::vector<Rectangle> sights;
  sights.reserve(cells_.size());
  for (std::size_t i = 0; i < cells_.size(); ++i) sights.push_back(sightOf(camera, i));
  return sights;
}

void HiddenFloor::replaceCamera(std::size_t k, Camera&& camera, std::span<const Rectangle> sights) {
  if (k >= cameras_ || sights.size() != cells_.size()) {
    throw std::invalid_argument("HiddenFloor: no such camera, or sights of other cells");
  }
  below_[k] = camera.centreMetres().head<2>();
  camera_list_[k] = std::move(camera);
  for (std::size_t i = 0; i < cells_.size(); ++i) sights_[i * cameras_ + k] = sights[i];
}

void HiddenFloor::setFound(std::span<const Detection> found) {
  found_at_.resize(found.size());
  shadows_.resize(found.size() * cameras_);
  for (std::size_t p = 0; p < found.size(); ++p) {
    const Detection& person = found[p];
    const Eigen::Vector2d at(person.x_m, person.y_m);
    found_at_[p] = at.cast<float>();
    // The detector's box, as high as what was found (0: a person's).
    const double height = person.height_m > 0 ? person.height_m : box_.box_height_m;
    for (std::size_t k = 0; k < cameras_; ++k) {
      const std::optional<PixelRectangle> board =
          boardInImage(camera_list_[k], below_[k], at, box_.box_width_m, height);
      shadows_[p * cameras_ + k] =
          board ? Rectangle{static_cast<float>(board->u0), static_cast<float>(board->v0),
                            static_cast<float>(board->u1), static_cast<float>(board->v1)}
                : kNotInView;
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
