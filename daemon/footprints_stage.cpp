#include "daemon/footprints_stage.h"

#include <algorithm>
#include <cstring>

#include <poll.h>

namespace occmap {

FootprintsStage::Offer FootprintsStage::emptyOffer(std::span<const std::size_t> mask_bytes,
                                                   std::size_t cells) {
  Offer offer;
  for (const std::size_t bytes : mask_bytes) offer.changed.emplace_back(bytes);
  offer.used.assign(mask_bytes.size(), 0);
  offer.generations.assign(mask_bytes.size(), 0);
  offer.cells.assign(cells, CellState::kUnseen);
  return offer;
}

FootprintsFound FootprintsStage::emptyResult() {
  // Room for a crowd, so that the usual map allocates nothing.
  FootprintsFound found;
  found.footprints.reserve(64);
  found.tracks.reserve(64);
  return found;
}

FootprintsStage::FoundForZones FootprintsStage::emptyFound() {
  FoundForZones found;
  found.footprints.reserve(64);
  return found;
}

FootprintsStage::FootprintsStage(const MapGeometry& map, std::span<const Camera> cameras,
                                 const FootprintSettings& settings,
                                 std::span<const std::size_t> mask_bytes)
    : detector_(map, cameras, settings),
      offers_(emptyOffer(mask_bytes, map.cellCount()), emptyOffer(mask_bytes, map.cellCount()),
              emptyOffer(mask_bytes, map.cellCount())),
      results_(emptyResult(), emptyResult(), emptyResult()),
      for_zones_(emptyFound(), emptyFound(), emptyFound()),
      masks_(mask_bytes.size(), nullptr),
      boxes_generation_(mask_bytes.size(), 0),
      reposed_(mask_bytes.size()),
      expected_within_s_(settings.expected_within_s) {
  expected_.reserve(64);
}

void FootprintsStage::offer(std::uint64_t fused, std::int64_t utime, double time_s,
                            std::span<const std::uint8_t* const> changed,
                            std::span<const CellState> cells,
                            std::span<const std::uint32_t> generations) {
  Offer& offer = offers_.writeBuffer();
  offer.fused = fused;
  offer.utime = utime;
  offer.time_s = time_s;
  for (std::size_t k = 0; k < offer.changed.size(); ++k) {
    offer.used[k] = changed[k] != nullptr ? 1 : 0;
    offer.generations[k] = k < generations.size() ? generations[k] : 0;
    if (changed[k] != nullptr) {
      std::memcpy(offer.changed[k].data(), changed[k], offer.changed[k].size());
    }
  }
  std::copy(cells.begin(), cells.end(), offer.cells.begin());
  offers_.publish();
  wakeup_.signal();
}

void FootprintsStage::reposed(std::size_t k, std::uint32_t generation, const Camera& camera) {
  reposed_.give(k, generation, camera);
}

void FootprintsStage::stop() {
  stopping_.store(true, std::memory_order_relaxed);
  wakeup_.signal();
}

void FootprintsStage::run(const EventFd& found) {
  pollfd wakeup{wakeup_.fd(), POLLIN, 0};
  for (;;) {
    // A bounded wait: stop() signals too, so this is only a guard against a lost wake-up.
    ::poll(&wakeup, 1, 100);
    wakeup_.drain();
    const bool last_round = stopping_.load(std::memory_order_relaxed);
    if (findNewest()) found.signal();
    if (last_round) return;
  }
}

bool FootprintsStage::findNewest() {
  if (!offers_.takeLatest()) return false;
  const Offer& offer = offers_.readBuffer();
  for (std::size_t k = 0; k < masks_.size(); ++k) {
    masks_[k] = offer.used[k] != 0 ? offer.changed[k].data() : nullptr;
    if (masks_[k] == nullptr || offer.generations[k] == boxes_generation_[k]) continue;
    // Marked under another pose than the boxes': the boxes for it, if it has been handed over
    // (made here, outside the hand-over's lock: a capture thread never waits for them).
    if (const std::optional<Camera> pose = reposed_.take(k, offer.generations[k])) {
      detector_.replaceCamera(k, *pose);
      boxes_generation_[k] = offer.generations[k];
      ++reposes_applied_;
    }
    if (offer.generations[k] != boxes_generation_[k]) masks_[k] = nullptr;
  }
  expected_.clear();
  tracker_.expectedAt(offer.time_s, expected_within_s_, expected_);
  const std::vector<Detection>& footprints = detector_.detect(masks_, offer.cells, expected_);
  const std::vector<Track>& tracks = tracker_.update(footprints, offer.time_s);
  FootprintsFound& out = results_.writeBuffer();
  out.fused = offer.fused;
  out.utime = offer.utime;
  out.footprints.assign(footprints.begin(), footprints.end());
  out.tracks.assign(tracks.begin(), tracks.end());
  results_.publish();
  FoundForZones& for_zones = for_zones_.writeBuffer();
  for_zones.time_s = offer.time_s;
  for_zones.footprints.assign(footprints.begin(), footprints.end());
  for_zones_.publish();
  return true;
}

}  // namespace occmap
