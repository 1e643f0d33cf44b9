#include "transport/footprints_publisher.h"

#include <algorithm>
#include <cassert>
#include <cstdint>

#include "transport/footprints_message.h"

namespace occmap {

FootprintsPublisher::FootprintsPublisher(const std::string& map_channel, std::string hostname,
                                         std::span<const ZoneSpec> zones)
    : tracks_channel_(tracksChannel(map_channel)), zones_channel_(zonesChannel(map_channel)) {
  tracks_.hostname = hostname;
  zones_.hostname = std::move(hostname);
  zones_.num_zones = static_cast<std::int16_t>(zones.size());
  zones_.zones.resize(zones.size());
  for (std::size_t k = 0; k < zones.size(); ++k) {
    occmap::zone_t& zone = zones_.zones[k];
    zone.name = zones[k].name;
    zone.num_corners = static_cast<std::int16_t>(zones[k].polygon_m.size());
    for (const Eigen::Vector2d& corner : zones[k].polygon_m) {
      zone.corner_x_m.push_back(corner.x());
      zone.corner_y_m.push_back(corner.y());
    }
  }
  // Room for a crowd before the first publish, so that the usual one allocates nothing: the
  // messages' vectors, and the buffer for a tracks_t of that crowd (it grew the first time a map
  // had one track or footprint more than any before: occmapd allocated while running steadily,
  // pipeline_test under TSan, 535 bytes).
  constexpr std::int16_t kCrowd = 64;
  tracks_.footprints.resize(kCrowd);
  tracks_.tracks.resize(kCrowd);
  tracks_.num_footprints = kCrowd;
  tracks_.num_tracks = kCrowd;
  buffer_.reserve(
      static_cast<std::size_t>(std::max(tracks_.getEncodedSize(), zones_.getEncodedSize())));
  tracks_.footprints.clear();
  tracks_.tracks.clear();
  tracks_.num_footprints = 0;
  tracks_.num_tracks = 0;
}

bool FootprintsPublisher::send(Bus& bus, const std::string& channel, const auto& message) {
  buffer_.resize(static_cast<std::size_t>(message.getEncodedSize()));
  if (message.encode(buffer_.data(), 0, static_cast<int>(buffer_.size())) < 0 ||
      !bus.publish(channel, buffer_)) {
    ++errors_;
    return false;
  }
  return true;
}

bool FootprintsPublisher::publishZones(Bus& bus, std::int64_t seq, std::int64_t utime,
                                       std::span<const ZoneStatus> zones, double time_s) {
  if (zones_.zones.empty()) return true;
  assert(zones.size() == zones_.zones.size());
  zones_.utime = utime;
  zones_.seq = seq;
  for (std::size_t k = 0; k < zones.size(); ++k) {
    occmap::zone_t& zone = zones_.zones[k];
    zone.state = static_cast<std::int8_t>(zones[k].state);
    zone.state_s = time_s - zones[k].changed_s;
    zone.cells = static_cast<std::int32_t>(zones[k].cells);
    zone.occupied_cells = static_cast<std::int32_t>(zones[k].occupied_cells);
    zone.unseen_cells = static_cast<std::int32_t>(zones[k].unseen_cells);
  }
  return send(bus, zones_channel_, zones_);
}

bool FootprintsPublisher::publishTracks(Bus& bus, std::int64_t seq, std::int64_t utime,
                                        std::span<const Detection> footprints,
                                        std::span<const Track> tracks) {
  tracks_.utime = utime;
  tracks_.seq = seq;
  // A count is an int16 on the wire: more than 32767 people on one map is not a map of people.
  const std::size_t shown_footprints = std::min<std::size_t>(footprints.size(), INT16_MAX);
  const std::size_t shown_tracks = std::min<std::size_t>(tracks.size(), INT16_MAX);
  tracks_.num_footprints = static_cast<std::int16_t>(shown_footprints);
  tracks_.footprints.resize(shown_footprints);
  for (std::size_t k = 0; k < shown_footprints; ++k) {
    const Detection& in = footprints[k];
    occmap::footprint_t& out = tracks_.footprints[k];
    out.x_m = in.x_m;
    out.y_m = in.y_m;
    out.area_m2 = in.area_m2;
    out.score = in.score;
    out.height_m = in.height_m;
  }
  tracks_.num_tracks = static_cast<std::int16_t>(shown_tracks);
  tracks_.tracks.resize(shown_tracks);
  for (std::size_t k = 0; k < shown_tracks; ++k) {
    const Track& in = tracks[k];
    occmap::track_t& out = tracks_.tracks[k];
    out.id = static_cast<std::int32_t>(in.id);
    out.x_m = in.x_m;
    out.y_m = in.y_m;
    out.vx_m_s = in.vx_m_s;
    out.vy_m_s = in.vy_m_s;
    out.area_m2 = in.area_m2;
    out.age_s = in.age_s;
    out.unseen_s = in.unseen_s;
  }
  return send(bus, tracks_channel_, tracks_);
}

}  // namespace occmap
