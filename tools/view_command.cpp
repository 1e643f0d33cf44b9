// occmap view: watch the maps occmapd broadcasts over LCM (whole or in tiles): rate, latency,
// losses, and the maps themselves as a picture or a video, with the zones and tracks found on them.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "tools/commands.h"
#include "tools/footprints_heard.h"
#include "tools/pictures.h"
#include "transport/footprints_message.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"
#include "transport/map_receiver.h"

namespace occmap::tools {
namespace {

// A count plus an amount from the network, held at INT64_MAX instead of overflowing.
std::int64_t saturatingAdd(std::int64_t count, std::uint64_t amount) {
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  const auto room = static_cast<std::uint64_t>(kMax - count);  // count is never negative
  return amount >= room ? kMax : count + static_cast<std::int64_t>(amount);
}

using Clock = std::chrono::steady_clock;

struct ViewOptions {
  std::string lcm_url = TransportSettings{}.lcm_url;
  std::string channel = TransportSettings{}.map_channel;
  std::int64_t count = 0;  // 0: no limit
  double seconds = 0;      // 0: no limit
  double timeout = 10;     // 0: wait for ever
  std::string png;
  std::string video;
  double video_fps = 30;
};

volatile std::sig_atomic_t g_stop = 0;
extern "C" void onStopSignal(int) { g_stop = 1; }

// Ctrl-C and SIGTERM end the run as --count would, so that the summary, the picture and the
// video are still written. The previous handlers come back at the end.
class StopSignals {
 public:
  StopSignals() {
    g_stop = 0;
    struct sigaction action {};
    action.sa_handler = onStopSignal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

struct Latency {
  std::int64_t maps = 0;
  double sum_ms = 0;
  double max_ms = 0;
  void add(double ms) {
    ++maps;
    sum_ms += ms;
    max_ms = maps == 1 ? ms : std::max(max_ms, ms);
  }
  double mean() const { return maps > 0 ? sum_ms / static_cast<double>(maps) : 0.0; }
};

// A map kept to be drawn: it is drawn when the next map arrives, or at the end.
struct HeldMap {
  OccupancyMap map;
  std::int64_t seq = 0;
  std::int64_t utime = 0;
};

class Viewer {
 public:
  explicit Viewer(const ViewOptions& options)
      : o_(options),
        zones_channel_(zonesChannel(options.channel)),
        tracks_channel_(tracksChannel(options.channel)) {}

  const std::string& zonesChannelName() const { return zones_channel_; }
  const std::string& tracksChannelName() const { return tracks_channel_; }

  // A map from the MapReceiver, whole or put together from `tiles`.
  void onMap(const DecodedMap& map, std::int64_t recv_utime, const MapTiles& tiles) {
    if (closing_) return;
    ++received_;
    if (tiles.missing > 0) {
      ++incomplete_;
      tiles_lost_ = saturatingAdd(tiles_lost_, static_cast<std::uint64_t>(tiles.missing));
      interval_tiles_lost_ += tiles.missing;
    }
    last_map_time_ = Clock::now();
    if (last_seq_) {
      // seq and utime come from the network and may be anything: the step is taken in unsigned
      // arithmetic (INT64_MIN to INT64_MAX does not overflow) and the latency in double.
      if (map.seq > *last_seq_ &&
          static_cast<std::uint64_t>(map.seq) - static_cast<std::uint64_t>(*last_seq_) > 1) {
        const std::uint64_t missing =
            static_cast<std::uint64_t>(map.seq) - static_cast<std::uint64_t>(*last_seq_) - 1;
        ++gaps_;
        lost_ = saturatingAdd(lost_, missing);
        interval_lost_ = saturatingAdd(interval_lost_, missing);
      } else if (map.seq <= *last_seq_) {
        std::printf("seq went back from %lld to %lld: the publisher restarted\n",
                    static_cast<long long>(*last_seq_), static_cast<long long>(map.seq));
      }
    }
    last_seq_ = map.seq;
    const double latency_ms =
        (static_cast<double>(recv_utime) - static_cast<double>(map.utime)) / 1000.0;
    interval_latency_.add(latency_ms);
    total_latency_.add(latency_ms);
    const auto occupied = std::count(map.cells.begin(), map.cells.end(),
                                     static_cast<std::uint8_t>(CellState::kOccupied));
    interval_occupied_ = static_cast<double>(occupied) / static_cast<double>(map.cells.size());
    if (drawsPictures()) {
      // A map is drawn when the next one arrives, or at the end (finish): its zones_t is sent right
      // after it, so by then it has come. (Its tracks come later still: a map is drawn with the
      // newest tracks found on it or on an earlier map.)
      if (held_ && !o_.video.empty() && !video_failed_) writeVideoFrame(picture(*held_));
      held_ = HeldMap{map.toOccupancyMap(), map.seq, map.utime};
    }
  }

  // A map or tile message the MapReceiver refused.
  void onRefusedMap(const std::string& channel, std::size_t size, const std::string& why) {
    if (closing_) return;
    refuse(++undecodable_, channel, size, why);
  }

  void onZones(const std::uint8_t* data, std::size_t size) {
    std::string error;
    if (!heard_.takeZones(data, size, error)) {
      refuse(heard_.zonesCount().undecodable, zones_channel_, size, error);
    }
  }

  void onTracks(const std::uint8_t* data, std::size_t size) {
    std::string error;
    if (!heard_.takeTracks(data, size, error)) {
      refuse(heard_.tracksCount().undecodable, tracks_channel_, size, error);
    }
  }

  // The run has ended: no more maps are taken, but the last one's zones_t may still come.
  void stopTakingMaps() { closing_ = true; }
  bool drawsPictures() const { return !o_.png.empty() || !o_.video.empty(); }
  // Whether the last map is to be drawn and its zones_t has not come yet, though the daemon sends
  // zones (some zones_t was heard; after a single map that cannot be told yet).
  bool awaitsLastZones() const {
    if (!held_ || heard_.zonesOf(held_->seq) != nullptr) return false;
    return heard_.zonesCount().any() || received_ == 1;
  }

  // One line on the second that just ended.
  void report(double elapsed_s) {
    if (interval_latency_.maps == 0) {
      std::printf("%5.0f s  %4d maps/s%s\n", elapsed_s, 0,
                  interval_undecodable_ > 0 ? "  (only undecodable messages)" : "");
    } else {
      std::printf(
          "%5.0f s  %4lld maps/s  latency mean %6.1f ms, max %6.1f ms  occupied %5.2f %%  lost %lld"
          "%s%s%s\n",
          elapsed_s, static_cast<long long>(interval_latency_.maps), interval_latency_.mean(),
          interval_latency_.max_ms, 100.0 * interval_occupied_,
          static_cast<long long>(interval_lost_),
          interval_tiles_lost_ > 0
              ? ("  tiles lost " + std::to_string(interval_tiles_lost_)).c_str()
              : "",
          heard_.newestText().c_str(),
          interval_undecodable_ > 0 ? "  (and undecodable messages)" : "");
    }
    std::fflush(stdout);
    interval_latency_ = {};
    interval_lost_ = 0;
    interval_tiles_lost_ = 0;
    interval_undecodable_ = 0;
  }

  // Writes the picture, closes the video and prints the summary; returns the exit code.
  int finish(double elapsed_s, bool timed_out) {
    if (held_ && !o_.video.empty() && !video_failed_) writeVideoFrame(picture(*held_));
    if (writer_.isOpened()) writer_.release();
    std::printf(
        "summary: received %lld maps in %.2f s (%.1f maps/s), lost %lld (%lld seq gaps), "
        "undecodable %lld, tiles lost %lld (%lld maps incomplete)",
        static_cast<long long>(received_), elapsed_s,
        elapsed_s > 0 ? static_cast<double>(received_) / elapsed_s : 0.0,
        static_cast<long long>(lost_), static_cast<long long>(gaps_),
        static_cast<long long>(undecodable_), static_cast<long long>(tiles_lost_),
        static_cast<long long>(incomplete_));
    if (total_latency_.maps > 0) {
      std::printf("; latency mean %.2f ms, max %.2f ms", total_latency_.mean(),
                  total_latency_.max_ms);
    }
    std::printf("%s\n", heard_.countsText().c_str());
    if (received_ == 0) {
      if (timed_out) {
        std::fprintf(stderr,
                     "occmap view: no result: no map on %s at %s within %g s (--timeout). Is "
                     "occmapd running and publishing there? (ttl=0 reaches this host only)\n",
                     o_.channel.c_str(), o_.lcm_url.c_str(), o_.timeout);
      } else {
        std::fprintf(stderr, "occmap view: no result: no map on %s at %s before the run ended\n",
                     o_.channel.c_str(), o_.lcm_url.c_str());
      }
      return kExitNoResult;
    }
    int code = kExitOk;
    if (!o_.png.empty()) {
      if (cv::imwrite(o_.png, picture(*held_))) {
        std::printf("wrote %s (the last map, seq %lld, as a floor plan: +y up%s)\n", o_.png.c_str(),
                    static_cast<long long>(held_->seq),
                    heard_.drawnText(held_->seq, held_->utime).c_str());
      } else {
        std::fprintf(stderr, "occmap view: cannot write %s\n", o_.png.c_str());
        code = kExitFailure;
      }
    }
    if (!o_.video.empty()) {
      if (video_failed_) {
        code = kExitFailure;
      } else {
        std::printf("wrote %s (%lld frames, Motion JPEG at %g frames/s, by %s's encoder)\n",
                    o_.video.c_str(), static_cast<long long>(video_frames_), o_.video_fps,
                    video_encoder_);
      }
    }
    return code;
  }

  std::int64_t received() const { return received_; }
  Clock::time_point lastMapTime() const { return last_map_time_; }
  void setStart(Clock::time_point start) { last_map_time_ = start; }

 private:
  // Pixels per cell of the pictures: about 600 pixels across, at least one per cell.
  static int scaleFor(const MapGeometry& g) {
    return std::max(1, 600 / std::max(g.width, g.height));
  }

  // The map as a floor plan, with its zones and the tracks found on it or just before.
  cv::Mat picture(const HeldMap& held) const {
    const int scale = scaleFor(held.map.geometry);
    cv::Mat plan = floorPlan(held.map, scale);
    heard_.draw(plan, held.map.geometry, scale, held.seq, held.utime);
    return plan;
  }

  // A message that could not be decoded, the `undecodable`th on its channel: the first few are
  // shown.
  void refuse(std::int64_t undecodable, const std::string& channel, std::size_t size,
              const std::string& why) {
    ++interval_undecodable_;
    if (undecodable <= 5) {
      std::fprintf(stderr, "occmap view: an undecodable message on %s (%zu bytes): %s%s\n",
                   channel.c_str(), size, why.c_str(),
                   undecodable == 5 ? " (no more of these are shown)" : "");
    }
  }

  void writeVideoFrame(cv::Mat plan) {
    if (!writer_.isOpened()) {
      video_size_ = plan.size();
      // Motion JPEG in AVI plays everywhere. FFmpeg's encoder first: OpenCV's own (for builds
      // without FFmpeg) cuts the last bits of some frames short, which decoders warn about.
      for (const auto& [api, name] :
           {std::pair{cv::CAP_FFMPEG, "FFmpeg"}, std::pair{cv::CAP_OPENCV_MJPEG, "OpenCV"}}) {
        if (writer_.open(o_.video, api, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), o_.video_fps,
                         video_size_, true)) {
          video_encoder_ = name;
          break;
        }
      }
      if (!writer_.isOpened()) {
        std::fprintf(stderr, "occmap view: cannot write the video %s\n", o_.video.c_str());
        video_failed_ = true;
        return;
      }
    }
    if (plan.size() != video_size_) {  // the map's size changed (the daemon's config was reloaded)
      cv::resize(plan, plan, video_size_, 0, 0, cv::INTER_NEAREST);
    }
    writer_.write(plan);
    ++video_frames_;
  }

  const ViewOptions& o_;
  const std::string zones_channel_, tracks_channel_;
  std::int64_t received_ = 0, lost_ = 0, gaps_ = 0, undecodable_ = 0;
  std::int64_t tiles_lost_ = 0, incomplete_ = 0;  // tiled maps: tiles that never came, and maps
  std::int64_t interval_tiles_lost_ = 0;
  std::optional<std::int64_t> last_seq_;
  Clock::time_point last_map_time_;
  Latency interval_latency_, total_latency_;
  std::int64_t interval_lost_ = 0, interval_undecodable_ = 0;
  double interval_occupied_ = 0;
  std::optional<HeldMap> held_;  // the last map, when it is to be drawn
  FootprintsHeard heard_;
  bool closing_ = false;
  cv::VideoWriter writer_;
  cv::Size video_size_;
  bool video_failed_ = false;
  std::int64_t video_frames_ = 0;
  const char* video_encoder_ = "";
};

int run(const ViewOptions& o) {
  if (!o.video.empty()) {
    std::string extension = std::filesystem::path(o.video).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension != ".avi") {
      throw InputError(o.video, 0, "--video",
                       "the video is Motion JPEG in an AVI file: give a name ending in .avi");
    }
  }
  LcmBus bus(o.lcm_url);
  if (!bus.good()) {
    std::fprintf(stderr,
                 "occmap view: failed: cannot open LCM at %s (is the URL right? for udpm://, "
                 "does the host have a multicast route?)\n",
                 o.lcm_url.c_str());
    return kExitFailure;
  }
  Viewer viewer(o);
  // Maps whole on the map channel or in tiles on its name + _TILES, whichever the daemon sends.
  MapReceiver maps(
      bus, o.channel,
      [&viewer, &maps](const DecodedMap& map, std::int64_t recv_utime) {
        viewer.onMap(map, recv_utime, maps.tilesOfMap());
      },
      [&viewer](const std::string& channel, std::size_t size, const std::string& why) {
        viewer.onRefusedMap(channel, size, why);
      });
  if (!maps.subscribed()) {
    std::fprintf(stderr, "occmap view: failed: cannot subscribe to %s and %s at %s\n",
                 maps.mapChannel().c_str(), maps.tileChannel().c_str(), o.lcm_url.c_str());
    return kExitFailure;
  }
  const std::pair<const std::string&, Bus::Handler> channels[] = {
      {viewer.zonesChannelName(), [&viewer](const std::uint8_t* data, std::size_t size,
                                            std::int64_t) { viewer.onZones(data, size); }},
      {viewer.tracksChannelName(), [&viewer](const std::uint8_t* data, std::size_t size,
                                             std::int64_t) { viewer.onTracks(data, size); }},
  };
  for (const auto& [channel, handler] : channels) {
    if (!bus.subscribe(channel, handler)) {
      std::fprintf(stderr, "occmap view: failed: cannot subscribe to %s at %s\n", channel.c_str(),
                   o.lcm_url.c_str());
      return kExitFailure;
    }
  }
  std::printf("listening for maps on %s (tiled on %s), zones on %s and tracks on %s at %s\n",
              o.channel.c_str(), maps.tileChannel().c_str(), viewer.zonesChannelName().c_str(),
              viewer.tracksChannelName().c_str(), o.lcm_url.c_str());
  std::fflush(stdout);

  const StopSignals signals;
  const auto start = Clock::now();
  viewer.setStart(start);
  const auto seconds = [](double s) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  auto next_report = start + std::chrono::seconds(1);
  bool timed_out = false;
  while (g_stop == 0) {
    if (o.count > 0 && viewer.received() >= o.count) break;
    const auto now = Clock::now();
    if (o.seconds > 0 && now >= start + seconds(o.seconds)) break;
    if (o.timeout > 0 && now >= viewer.lastMapTime() + seconds(o.timeout)) {
      timed_out = true;
      break;
    }
    if (now >= next_report) {
      viewer.report(std::chrono::duration<double>(next_report - start).count());
      next_report += std::chrono::seconds(1);
      continue;
    }
    const auto wait = std::min(next_report - now, Clock::duration(std::chrono::milliseconds(100)));
    const int wait_ms =
        1 + static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(wait).count());
    // Ctrl-C (or SIGTERM) interrupts LCM's wait: that is a stop, with the summary, not a failure.
    // The wait can end with EINTR before the handler has set g_stop (ThreadSanitizer defers
    // handlers to its next interception point): then the loop looks at g_stop again.
    errno = 0;
    if (bus.handleTimeout(wait_ms) < 0 && g_stop == 0 && errno != EINTR) {
      std::fprintf(stderr, "occmap view: failed: LCM stopped receiving (%s)\n", o.lcm_url.c_str());
      return kExitFailure;
    }
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  // A tiled map still waiting for tiles when the run ended otherwise than by --count: taken with
  // them unseen (and counted).
  if (!(o.count > 0 && viewer.received() >= o.count)) maps.flush();
  if (viewer.drawsPictures()) {
    // The last map's zones_t follows it on the wire and may not have been read when the run ends:
    // wait a moment for it (maps that come meanwhile are not taken), then take what else has come
    // already (the tracks sent after it).
    viewer.stopTakingMaps();
    const auto give_up = Clock::now() + std::chrono::milliseconds(250);
    while (viewer.awaitsLastZones() && Clock::now() < give_up) {
      if (bus.handleTimeout(10) < 0) break;
    }
    for (int k = 0; k < 100; ++k) {
      if (bus.handleTimeout(0) <= 0) break;
    }
  }
  return viewer.finish(elapsed_s, timed_out);
}

}  // namespace

Command addViewCommand(CLI::App& app) {
  auto options = std::make_shared<ViewOptions>();
  CLI::App* command = app.add_subcommand(
      "view",
      "Watch the maps occmapd broadcasts over LCM.\n"
      "Subscribes to the map channel (maps sent whole, and maps sent in tiles on its name + "
      "_TILES: transport.tiles) and to the zones and tracks found on the maps, and prints "
      "one line per second: maps received, the latency from each map's time (the capture time of "
      "its newest camera frame) to its receipt here (mean and max; across machines this needs "
      "their clocks in step), the occupied share of the last map, and maps lost (gaps in the "
      "maps' seq numbers; and, for tiled maps, tiles lost). At the end it prints a "
      "summary (maps received, lost, undecodable, tiles lost and the tiled maps they were missing "
      "from, whose cells there show as unseen) and writes the last map as a picture "
      "(--png) and every map as a video (--video), drawn as floor plans: +y up, with a scale "
      "bar; white free, black occupied, blue-grey unseen.\n"
      "Over them it draws what occmapd finds on the maps, heard on the map channel's name + "
      "_ZONES and + _TRACKS: each zone's outline in its state's colour (green free, red "
      "occupied, amber unseen) with its name and state, as the zones_t of that very map says; "
      "each footprint (a detection) as a hollow circle, and each confirmed track as a blue dot "
      "with its id and an arrow of one second's motion, from the newest tracks_t found on that map "
      "or an earlier one (the detector lags the maps a little; tracks more than a second older "
      "than the map are not drawn). The line each second then ends with the number of tracks and "
      "the zones' states (tracks 2  zones: robot-cell occupied, door free), and the summary counts "
      "the zones_t and tracks_t received and undecodable. A map is drawn once the next one has "
      "come, or at the end, when view waits up to 0.25 s for the last map's zones.\n"
      "It runs until --count maps, --seconds, Ctrl-C, or --timeout seconds without a map.\n"
      "Raw (unencoded) maps of 512 x 512 cells arrive in LCM fragments: give the receiver a "
      "large socket buffer with ?recv_buf_size=4194304 in the URL (Linux caps it at "
      "net.core.rmem_max).\n\n"
      "Examples:\n"
      "  occmap view                                   # the default URL and channel\n"
      "  occmap view --count 300 --png last.png --video maps.avi\n"
      "  occmap view --lcm-url 'udpm://239.255.76.67:7667?ttl=1' --seconds 60\n\n"
      "Exit codes: 0 at least one map received; 1 failed (LCM could not be opened, a picture or "
      "video could not be written); 2 bad arguments; 3 no map arrived (within --timeout, or before "
      "--seconds ended).");
  command
      ->add_option("--lcm-url", options->lcm_url,
                   "LCM URL to listen on: the daemon's transport.lcm_url")
      ->capture_default_str();
  command
      ->add_option("--channel", options->channel,
                   "Map channel (transport.map_channel); tiled maps, zones and tracks are heard on "
                   "its name + _TILES, + _ZONES and + _TRACKS")
      ->capture_default_str();
  command->add_option("--count", options->count, "Stop after this many maps")
      ->check(CLI::PositiveNumber);
  command->add_option("--seconds", options->seconds, "Stop after this many seconds")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--timeout", options->timeout,
                   "Stop when no map arrived for this many seconds (the first or the next); 0 "
                   "waits for ever")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->add_option("--png", options->png,
                      "Write the last map received to this PNG file, as a floor plan");
  command->add_option("--video", options->video,
                      "Write every map received to this video (.avi, Motion JPEG), as floor plans");
  command->add_option("--video-fps", options->video_fps, "Frame rate the video plays at")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
