#include "daemon/merge_node.h"

#include <algorithm>
#include <cstring>
#include <utility>

#include "base/clock.h"
#include "transport/footprints_message.h"

namespace occmap {
namespace {

std::vector<std::string> namesOf(const std::vector<MergeInputSpec>& inputs) {
  std::vector<std::string> names;
  for (const MergeInputSpec& input : inputs) names.push_back(input.name);
  return names;
}

}  // namespace

MergeNode::MergeNode(Bus& bus, const MapGeometry& merged, std::vector<MergeInputSpec> inputs,
                     double max_age_s, std::string output_channel, MapEncoding encoding,
                     std::span<const ZoneSpec> zones, std::string hostname, MapMessages messages)
    : bus_(bus),
      merged_geometry_(merged),
      freshness_(inputs.size(), max_age_s),
      output_channel_(std::move(output_channel)),
      // Inputs not heard from yet stand in as one cell each, down: no memory for maps unknown.
      merger_(merged, std::vector<MapGeometry>(inputs.size(),
                                               MapGeometry{merged.origin_x_m, merged.origin_y_m,
                                                           merged.cell_size_m, 1, 1})),
      frame_(merged, inputs.size()),
      publisher_(merged, namesOf(inputs), encoding, output_channel_, "the merged map's bus",
                 messages),
      zones_(merged, zones),
      footprints_publisher_(output_channel_, std::move(hostname), zones),
      found_(inputs.size()),
      max_age_s_(max_age_s) {
  for (MergeInputSpec& spec : inputs) {
    Input input;
    input.spec = std::move(spec);
    inputs_.push_back(std::move(input));
  }
  for (std::size_t k = 0; k < inputs_.size(); ++k) {
    receivers_.push_back(std::make_unique<MapReceiver>(
        bus_, inputs_[k].spec.channel,
        [this, k](const DecodedMap& map, std::int64_t recv_utime) {
          const std::int64_t start_ns = monotonicNanoseconds();
          heard(k, map, recv_utime);
          merge_times_.record(monotonicNanoseconds() - start_ns);
        },
        [this, k](const std::string&, std::size_t, const std::string& why) { refused(k, why); }));
    bus_.subscribe(tracksChannel(inputs_[k].spec.channel),
                   [this, k](const std::uint8_t* data, std::size_t size, std::int64_t) {
                     heardFootprints(k, data, size);
                   });
  }
}

int MergeNode::spinOnce(int timeout_ms) { return bus_.handleTimeout(timeout_ms); }

void MergeNode::refused(std::size_t k, const std::string& why) {
  ++inputs_[k].refused;
  inputs_[k].last_error = why;
}

void MergeNode::heard(std::size_t k, const DecodedMap& decoded, std::int64_t recv_utime) {
  Input& input = inputs_[k];
  input.tiles_lost += static_cast<std::uint64_t>(receivers_[k]->tilesOfMap().missing);
  // Old or repeated: nothing new. A seq that starts again with a newer capture is the PC's occmapd
  // restarted (its seq counts from 0), not an old map: taken, or the PC would stay down until its
  // new seq passed the old one.
  const bool restarted =
      input.seq >= 0 && decoded.seq <= input.seq && decoded.utime > input.capture_utime;
  if (input.seq >= 0 && decoded.seq <= input.seq && !restarted) return;
  if (input.seq >= 0 && decoded.seq > input.seq + 1) {
    input.lost += static_cast<std::uint64_t>(decoded.seq - input.seq - 1);
  }
  const bool new_geometry = !input.map || input.map->geometry != decoded.geometry;
  if (new_geometry) input.map.emplace(decoded.geometry);
  // The decoder refused any cell value but 0, 1 and 2, CellState's own values: the bytes as they
  // are.
  static_assert(sizeof(CellState) == 1 && static_cast<int>(CellState::kFree) == 0 &&
                static_cast<int>(CellState::kOccupied) == 1 &&
                static_cast<int>(CellState::kUnseen) == 2);
  std::memcpy(input.map->cells.data(), decoded.cells.data(), decoded.cells.size());
  if (input.seq >= 0 && !restarted && decoded.utime > input.capture_utime) {
    input.period_s = static_cast<double>(decoded.utime - input.capture_utime) * 1e-6;
  }
  input.seq = decoded.seq;
  input.capture_utime = decoded.utime;
  input.new_map = true;
  ++input.maps;
  freshness_.heard(k, static_cast<double>(decoded.utime) * 1e-6,
                   static_cast<double>(recv_utime) * 1e-6);
  if (new_geometry) {
    merger_.reshape(k, input.map->geometry);  // counts as down until updated below
    input.merged = false;
  }
  // This input's new map where it is fresh, and any input whose freshness this map changed.
  for (std::size_t j = 0; j < inputs_.size(); ++j) {
    Input& other = inputs_[j];
    const bool fresh = freshness_.fresh(j);
    if (fresh && (j == k || !other.merged)) {
      merger_.update(j, &*other.map);
    } else if (!fresh && other.merged) {
      merger_.update(j, nullptr);
    }
    other.merged = fresh;
  }
  if (timeToPublish()) publish(recv_utime);
}

void MergeNode::heardFootprints(std::size_t k, const std::uint8_t* data, std::size_t size) {
  Input& input = inputs_[k];
  std::string error;
  const std::optional<occmap::tracks_t> tracks = decodeTracks(data, size, &error);
  if (!tracks) {
    ++input.refused;
    input.last_error = "tracks: " + error;
    return;
  }
  // Older than what it gave before (reordered on the way; a restarted PC's maps are newer): none.
  if (tracks->utime < input.footprints_utime) return;
  input.footprints.clear();
  for (const occmap::footprint_t& f : tracks->footprints) {
    input.footprints.push_back({f.x_m, f.y_m, f.area_m2, f.score, f.height_m});
  }
  input.footprints_utime = tracks->utime;
  input.new_footprints = true;
}

bool MergeNode::timeToPublish() const {
  const std::optional<double> newest = freshness_.newestCaptureS();
  if (!newest || static_cast<std::int64_t>(*newest * 1e6 + 0.5) <= last_published_utime_) {
    return false;  // nothing newer than what went out
  }
  bool all_new = true;
  double period = 1.0;
  for (const Input& input : inputs_) {
    if (input.merged) {
      all_new = all_new && input.new_map;
      period = std::min(period, input.period_s);
    }
  }
  return all_new || *newest - static_cast<double>(last_published_utime_) * 1e-6 >= period;
}

void MergeNode::publish(std::int64_t newest_arrival_utime) {
  for (std::size_t k = 0; k < inputs_.size(); ++k) {
    Input& input = inputs_[k];
    CameraContribution& part = frame_.cameras[k];
    part.state = !freshness_.heardFrom(k) ? CameraState::kStarting
                 : input.merged           ? CameraState::kStreaming
                                          : CameraState::kDown;
    part.used = input.merged;
    part.sequence = input.merged ? input.seq : -1;
    part.capture_time_us = input.merged ? input.capture_utime : 0;
    input.new_map = false;
  }
  frame_.map.cells = merger_.merged().cells;  // same size: no allocation
  const std::int64_t newest = static_cast<std::int64_t>(*freshness_.newestCaptureS() * 1e6 + 0.5);
  frame_.utime = std::max(newest, last_published_utime_ + 1);
  // Numbered by the publisher: a map that could not be sent is a gap its subscribers see.
  if (!publisher_.publish(bus_, frame_)) return;
  last_published_utime_ = frame_.utime;
  // The zones' states on this very map, right after it (nothing is sent without zones).
  const double time_s = static_cast<double>(frame_.utime) * 1e-6;
  footprints_publisher_.publishZones(bus_, frame_.seq, frame_.utime,
                                     zones_.update(frame_.map.cells, time_s), time_s);
  last_latency_s_ = static_cast<double>(hostTimeMicroseconds() - newest_arrival_utime) * 1e-6;
  publishTracks(frame_.seq, frame_.utime);
}

void MergeNode::publishTracks(std::int64_t seq, std::int64_t utime) {
  bool news = false;
  for (std::size_t k = 0; k < inputs_.size(); ++k) {
    Input& input = inputs_[k];
    // A fresh input's people found on a map of about the merged map's time: people move.
    const bool current = input.merged && input.new_footprints &&
                         static_cast<double>(utime - input.footprints_utime) * 1e-6 <= max_age_s_;
    found_[k] =
        current ? std::span<const Detection>(input.footprints) : std::span<const Detection>();
    news = news || current;
    if (current) input.new_footprints = false;
  }
  if (!news) return;
  const std::vector<Detection>& found = footprint_merger_.merge(found_);
  const std::vector<Track>& tracks = tracker_.update(found, static_cast<double>(utime) * 1e-6);
  tracks_.assign(tracks.begin(), tracks.end());
  if (footprints_publisher_.publishTracks(bus_, seq, utime, found, tracks)) ++tracks_published_;
}

std::vector<MergeNode::InputStatus> MergeNode::inputs() const {
  std::vector<InputStatus> status;
  const std::optional<double> newest = freshness_.newestCaptureS();
  for (std::size_t k = 0; k < inputs_.size(); ++k) {
    const Input& input = inputs_[k];
    InputStatus s;
    s.name = input.spec.name;
    s.channel = input.spec.channel;
    s.fresh = freshness_.fresh(k);
    s.maps = input.maps;
    s.lost = input.lost;
    s.tiles_lost = input.tiles_lost;
    s.refused = input.refused;
    s.last_error = input.last_error;
    if (const std::optional<double> capture = freshness_.captureS(k); capture && newest) {
      s.age_s = *newest - *capture;
    }
    s.clock_offset_s = freshness_.clockOffsetS(k);
    status.push_back(std::move(s));
  }
  return status;
}

}  // namespace occmap
