#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/time_histogram.h"
#include "core/footprint_merge.h"
#include "core/map_frame.h"
#include "core/map_merge.h"
#include "core/merge_inputs.h"
#include "core/tracker.h"
#include "core/zones.h"
#include "transport/bus.h"
#include "transport/footprints_publisher.h"
#include "transport/map_codec.h"
#include "transport/map_publisher.h"
#include "transport/map_receiver.h"

namespace occmap {

// A merge node (issue 16, docs/merge.md): it hears the maps of several camera PCs' occmapd, each on
// its own channel, and publishes one map of the whole floor, merged by the paper's rule
// (core/map_merge.h) from the inputs that are fresh (core/merge_inputs.h); a stale or silent input
// counts as down and its cells turn unseen.
//
// A merged map goes out once every fresh input has brought a new map since the last one went out
// (camera PCs at 30 Hz: 30 merged maps a second, whatever their number), or once the newest capture
// is a frame period (the fastest input's) past the last one published, so that an input that
// falls behind holds nothing up. Its utime is the newest capture merged; its "cameras" are the
// inputs (name, streaming or down, used when fresh, the input's map seq and capture time), so
// `occmap view` and any subscriber see which parts of the floor come from where.
//
// The people: each camera PC's occmapd finds them with its own cameras (tracks_t on its map channel
// + "_TRACKS"); the node merges what the fresh inputs found since the last merged map
// (core/footprint_merge.h: one person seen by two PCs is one) and tracks them on the merged map
// (core/tracker.h), sent as tracks_t on the merged channel + "_TRACKS" naming the merged map. An
// input whose detector is slower than its maps adds its people when it has news; meanwhile its
// tracks coast. Everything runs on the thread that calls spinOnce().
struct MergeInputSpec {
  std::string name;
  std::string channel;
};

class MergeNode {
 public:
  // Inputs' maps are heard whole or in tiles (transport/map_receiver.h), whichever each PC sends;
  // the merged map goes out as `messages` says (tiles for a large floor: docs/daemon.md). `zones`
  // (the config's) get a state on every merged map, sent right after it as occmapd sends them
  // (zones_t on the map channel + "_ZONES"), from the merged map's cells alone.
  MergeNode(Bus& bus, const MapGeometry& merged, std::vector<MergeInputSpec> inputs,
            double max_age_s, std::string output_channel, MapEncoding encoding,
            std::span<const ZoneSpec> zones = {}, std::string hostname = "merge",
            MapMessages messages = MapMessages::kWhole);

  // Handles what arrives within `timeout_ms`: > 0 handled, 0 timed out, < 0 a bus error.
  int spinOnce(int timeout_ms);

  struct InputStatus {
    std::string name;
    std::string channel;
    bool fresh = false;
    std::uint64_t maps = 0;        // maps heard
    std::uint64_t lost = 0;        // gaps in the input's seq
    std::uint64_t tiles_lost = 0;  // tiles of its tiled maps that never came
    std::uint64_t refused = 0;     // messages that did not decode, or of a map too large
    std::string last_error;
    std::optional<double> age_s;           // behind the newest input's newest capture
    std::optional<double> clock_offset_s;  // against the other inputs (MergeInputs)
  };
  std::vector<InputStatus> inputs() const;
  // The tracks after the last merged map that carried people (tracks_t sent with it).
  const std::vector<Track>& tracks() const { return tracks_; }
  std::uint64_t tracksPublished() const { return tracks_published_; }
  std::uint64_t published() const { return publisher_.published(); }
  // Messages that could not be sent: merged maps, or their tiles (each one an error).
  std::uint64_t publishErrors() const { return publisher_.errors(); }
  // From an input map (decoded) to its merge done, the merged map and its zones and tracks sent
  // when it made one: the node's work per input map.
  const TimeHistogram& mergeTimes() const { return merge_times_; }
  // From the newest input map's arrival to the merged map's publish, the last one (seconds).
  double lastLatencyS() const { return last_latency_s_; }
  // The map last published.
  const MapFrame& lastMap() const { return frame_; }

 private:
  struct Input {
    MergeInputSpec spec;
    std::optional<OccupancyMap> map;  // the newest map, of its own geometry
    std::int64_t seq = -1;
    std::int64_t capture_utime = 0;
    std::uint64_t maps = 0, lost = 0, tiles_lost = 0, refused = 0;
    std::string last_error;
    bool merged = false;         // its map is in the merged map (it is fresh)
    bool new_map = false;        // a map came since the last merged map went out
    double period_s = 1.0 / 30;  // between its last two captures
    // The people its occmapd found on its newest map that has them, and that map's capture time.
    std::vector<Detection> footprints;
    std::int64_t footprints_utime = 0;
    bool new_footprints = false;  // not yet given to the tracker
  };

  void heard(std::size_t k, const DecodedMap& decoded, std::int64_t recv_utime);
  void refused(std::size_t k, const std::string& why);
  void heardFootprints(std::size_t k, const std::uint8_t* data, std::size_t size);
  bool timeToPublish() const;
  // The people the fresh inputs found since the last time, merged and tracked, sent for the map
  // just sent (seq, utime); nothing when no input brought news.
  void publishTracks(std::int64_t seq, std::int64_t utime);
  void publish(std::int64_t newest_arrival_utime);

  Bus& bus_;
  MapGeometry merged_geometry_;
  std::vector<Input> inputs_;
  MergeInputs freshness_;
  std::string output_channel_;
  std::vector<std::unique_ptr<MapReceiver>> receivers_;  // one per input
  MapMerger merger_;  // an input's part reshaped when its geometry is first known or changes
  MapFrame frame_;
  MapPublisher publisher_;
  Zones zones_;
  FootprintsPublisher footprints_publisher_;  // zones_t and tracks_t
  FootprintMerger footprint_merger_;
  Tracker tracker_;
  std::vector<std::span<const Detection>> found_;  // per input, for footprint_merger_
  std::vector<Track> tracks_;
  std::uint64_t tracks_published_ = 0;
  double max_age_s_;
  std::int64_t last_published_utime_ = 0;
  TimeHistogram merge_times_;
  double last_latency_s_ = 0;
};

}  // namespace occmap
