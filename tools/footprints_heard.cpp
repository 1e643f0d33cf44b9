#include "tools/footprints_heard.h"

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tools/footprint_pictures.h"
#include "transport/footprints_message.h"

namespace occmap::tools {
namespace {

// Decodes one message with `decode` into the last few `kept`, counting it.
template <typename Message, typename Decode>
bool take(const std::uint8_t* data, std::size_t size, std::string& error, Decode decode,
          std::deque<Message>& kept, std::size_t most, MessageCount& count) {
  std::optional<Message> message = decode(data, size, &error);
  if (!message) {
    ++count.undecodable;
    return false;
  }
  ++count.received;
  if (kept.size() == most) kept.pop_front();
  kept.push_back(std::move(*message));
  return true;
}

// The newest of `heard` (kept oldest first) that `fits`, or null.
template <typename Message, typename Fits>
const Message* newestThat(const std::deque<Message>& heard, Fits fits) {
  for (auto it = heard.rbegin(); it != heard.rend(); ++it) {
    if (fits(*it)) return &*it;
  }
  return nullptr;
}

}  // namespace

bool FootprintsHeard::takeZones(const std::uint8_t* data, std::size_t size, std::string& error) {
  return take(data, size, error, decodeZones, zones_, kKept, zones_count_);
}

bool FootprintsHeard::takeTracks(const std::uint8_t* data, std::size_t size, std::string& error) {
  return take(data, size, error, decodeTracks, tracks_, kKept, tracks_count_);
}

const occmap::zones_t* FootprintsHeard::zonesOf(std::int64_t seq) const {
  return newestThat(zones_, [seq](const occmap::zones_t& zones) { return zones.seq == seq; });
}

const occmap::tracks_t* FootprintsHeard::tracksFor(std::int64_t seq, std::int64_t utime) const {
  const occmap::tracks_t* tracks = newestThat(tracks_, [seq, utime](const occmap::tracks_t& heard) {
    return heard.seq >= 0 ? heard.seq <= seq : heard.utime <= utime;
  });
  // utime comes from the network: the difference is taken in double, which cannot overflow.
  constexpr double kLongestLagS = 1.0;
  if (tracks == nullptr ||
      (static_cast<double>(utime) - static_cast<double>(tracks->utime)) / 1e6 > kLongestLagS) {
    return nullptr;
  }
  return tracks;
}

void FootprintsHeard::draw(cv::Mat& plan, const MapGeometry& map, int pixels_per_cell,
                           std::int64_t seq, std::int64_t utime) const {
  if (const occmap::zones_t* zones = zonesOf(seq)) drawZones(plan, map, pixels_per_cell, *zones);
  if (const occmap::tracks_t* tracks = tracksFor(seq, utime)) {
    drawTracks(plan, map, pixels_per_cell, *tracks);
  }
}

std::string FootprintsHeard::newestText() const {
  std::string text;
  if (!tracks_.empty()) text += "  tracks " + std::to_string(tracks_.back().tracks.size());
  if (zones_.empty() || zones_.back().zones.empty()) return text;
  const std::vector<occmap::zone_t>& zones = zones_.back().zones;
  constexpr std::size_t kShown = 8;  // a line, not a table
  text += "  zones: ";
  for (std::size_t k = 0; k < zones.size() && k < kShown; ++k) {
    if (k > 0) text += ", ";
    text += terminalText(zones[k].name) + " " + zoneStateText(zones[k].state);
  }
  if (zones.size() > kShown) text += " and " + std::to_string(zones.size() - kShown) + " more";
  return text;
}

std::string FootprintsHeard::drawnText(std::int64_t seq, std::int64_t utime) const {
  std::string text;
  if (zonesOf(seq) != nullptr) text += "; with its zones";
  if (const occmap::tracks_t* tracks = tracksFor(seq, utime)) {
    text += tracks->seq >= 0 ? "; with the tracks found on map " + std::to_string(tracks->seq)
                             : std::string("; with the tracks found on a map not sent");
  }
  return text;
}

std::string FootprintsHeard::countsText() const {
  if (!zones_count_.any() && !tracks_count_.any()) return "";
  return "; zones_t: received " + std::to_string(zones_count_.received) + ", undecodable " +
         std::to_string(zones_count_.undecodable) + "; tracks_t: received " +
         std::to_string(tracks_count_.received) + ", undecodable " +
         std::to_string(tracks_count_.undecodable);
}

}  // namespace occmap::tools
