#include "web/bus_feed.h"

#include <algorithm>
#include <cstdio>
#include <random>
#include <utility>

#include <occmap/status_request_t.hpp>

#include "base/clock.h"
#include "transport/bus.h"
#include "transport/camera_preview_message.h"
#include "transport/control_message.h"
#include "transport/footprints_message.h"
#include "transport/merge_status_message.h"
#include "transport/status_message.h"
#include "transport/status_text.h"
#include "web/map_wire.h"

namespace occmap::web {
namespace {

// A status request may be sent at once when a map says a camera changed state, but no sooner than
// this after the last (the daemon answers at most 20 a second, for everyone).
constexpr std::int64_t kPromptRequestGapNs = 250'000'000;
// A camera PC sends its control, lighting and view statuses right after each status_t: a daemon
// first heard is shown once they have come too, or after this long without them (a daemon from
// before them; `occmap status` waits as long).
constexpr std::int64_t kCompanionGraceNs = 500'000'000;
// The most hosts whose companions, zones and tracks are kept.
constexpr std::size_t kMaxHosts = LiveState::kMaxDaemons;

// A random, non-negative request id (-1 marks a daemon's periodic status).
std::int64_t randomStatusRequestId() {
  std::random_device device;
  const std::uint64_t high = device(), low = device();
  return static_cast<std::int64_t>((high << 32 | low) & 0x7fffffffffffffffull);
}

}  // namespace

template <typename Message>
const Message* BusFeed::NewestByHost<Message>::of(const std::string& hostname) const {
  for (const Message& message : kept_) {
    if (message.hostname == hostname) return &message;
  }
  return nullptr;
}

template <typename Message>
void BusFeed::NewestByHost<Message>::keep(Message&& message) {
  for (Message& kept : kept_) {
    if (kept.hostname == message.hostname) {
      kept = std::move(message);
      return;
    }
  }
  if (kept_.size() < kMaxHosts) kept_.push_back(std::move(message));
}

BusFeed::BusFeed(BusFeedOptions options, LiveState& state)
    : options_(std::move(options)), state_(state) {}

BusFeed::~BusFeed() { stop(); }

std::string BusFeed::open() {
  bus_ = std::make_unique<LcmBus>(options_.lcm_url);
  if (!bus_->good()) {
    return "cannot open LCM at " + options_.lcm_url +
           " (is the URL right? for udpm://, does the host have a multicast route?)";
  }
  maps_ = std::make_unique<MapReceiver>(
      *bus_, options_.map_channel,
      [this](const DecodedMap& map, std::int64_t recv_utime) { onMap(map, recv_utime); },
      [this](const std::string& channel, std::size_t, const std::string& why) {
        refuse(channel, why);
      });
  if (!maps_->subscribed()) {
    return "cannot subscribe to " + maps_->mapChannel() + " and " + maps_->tileChannel();
  }
  // Every message here may come from anyone on the segment: each is checked before LCM's decoder
  // sees it (transport/status_message.h, footprints_message.h).
  const std::string& status = options_.status_channel;
  const auto subscribe = [this](const std::string& channel, auto take) {
    return bus_->subscribe(
        channel, [this, channel, take](const std::uint8_t* data, std::size_t size, std::int64_t) {
          take(this, channel, data, size);
        });
  };
  const auto decoded = [](auto decode, auto use) {
    return [decode, use](BusFeed* self, const std::string& channel, const std::uint8_t* data,
                         std::size_t size) {
      std::string error;
      auto message = decode(data, size, &error);
      if (!message) {
        self->refuse(channel, error);
      } else {
        use(self, std::move(*message));
      }
    };
  };
  const struct {
    std::string channel;
    std::function<void(BusFeed*, const std::string&, const std::uint8_t*, std::size_t)> take;
  } subscriptions[] = {
      {status, decoded(decodeStatus,
                       [](BusFeed* self, occmap::status_t&& s) { self->onStatus(std::move(s)); })},
      {mergeStatusChannel(status), decoded(decodeMergeStatus,
                                           [](BusFeed* self, occmap::merge_status_t&& s) {
                                             self->onMergeStatus(std::move(s));
                                           })},
      {controlStatusChannel(status), decoded(decodeControlStatus,
                                             [](BusFeed* self, occmap::control_status_t&& c) {
                                               const std::string host = c.hostname;
                                               self->controls_.keep(std::move(c));
                                               self->refreshHost(host);
                                             })},
      {lightingStatusChannel(status), decoded(decodeLightingStatus,
                                              [](BusFeed* self, occmap::lighting_status_t&& l) {
                                                const std::string host = l.hostname;
                                                self->lightings_.keep(std::move(l));
                                                self->refreshHost(host);
                                              })},
      {viewStatusChannel(status), decoded(decodeViewStatus,
                                          [](BusFeed* self, occmap::view_status_t&& v) {
                                            const std::string host = v.hostname;
                                            self->views_.keep(std::move(v));
                                            self->refreshHost(host);
                                          })},
      {zonesChannel(options_.map_channel),
       decoded(decodeZones,
               [](BusFeed* self, occmap::zones_t&& z) {
                 self->state_.putZones(std::make_shared<const std::string>(formatZonesJson(z)));
                 self->zones_.keep(std::move(z));
               })},
      {tracksChannel(options_.map_channel),
       decoded(decodeTracks,
               [](BusFeed* self, occmap::tracks_t&& t) {
                 self->state_.putTracks(std::make_shared<const std::string>(formatTracksJson(t)));
                 self->tracks_.keep(std::move(t));
               })},
      {cameraPreviewChannel(status),
       decoded(decodeCameraPreview,
               [](BusFeed* self, occmap::camera_preview_t&& p) { self->onPreview(p); })},
  };
  for (const auto& [channel, take] : subscriptions) {
    if (!subscribe(channel, take)) return "cannot subscribe to " + channel;
  }
  request_id_ = randomStatusRequestId();
  return "";
}

void BusFeed::start() {
  stopping_.store(false);
  started_ns_ = monotonicNanoseconds();
  next_request_ns_ = started_ns_;
  thread_ = std::thread([this] { run(); });
}

void BusFeed::stop() {
  stopping_.store(true);
  if (thread_.joinable()) thread_.join();
}

void BusFeed::run() {
  const auto interval_ns = static_cast<std::int64_t>(options_.status_request_interval_s * 1e9);
  while (!stopping_.load(std::memory_order_relaxed)) {
    const std::int64_t now = monotonicNanoseconds();
    if (now >= next_request_ns_ ||
        (prompt_request_ && now - last_request_ns_ >= kPromptRequestGapNs)) {
      requestStatus();
      last_request_ns_ = now;
      prompt_request_ = false;
      next_request_ns_ = now + interval_ns;
    }
    if (state_.viewers() == 0) {
      next_preview_request_ns_ = 0;
    } else if (now >= next_preview_request_ns_) {
      requestPreviews();
      next_preview_request_ns_ =
          now + static_cast<std::int64_t>(options_.preview_request_interval_s * 1e9);
    }
    std::int64_t wait_ns = std::min<std::int64_t>(next_request_ns_ - now, 100'000'000);
    if (prompt_request_) wait_ns = std::min(wait_ns, last_request_ns_ + kPromptRequestGapNs - now);
    const int wait_ms = 1 + static_cast<int>(std::max<std::int64_t>(wait_ns, 0) / 1'000'000);
    if (bus_->handleTimeout(wait_ms) < 0 && !stopping_.load(std::memory_order_relaxed)) {
      // LCM's socket failed (udpm rarely does): said once a while, tried again.
      refuse(options_.lcm_url, "LCM stopped receiving");
      sleepUntil(monotonicNanoseconds() + 100'000'000);
    }
  }
}

void BusFeed::onMap(const DecodedMap& decoded, std::int64_t recv_utime) {
  auto held = std::make_shared<HeldMap>(
      HeldMap{decoded.seq, decoded.utime, recv_utime, decoded.toOccupancyMap()});
  auto frame = std::make_shared<const std::vector<std::uint8_t>>(
      encodeMapFrame(held->map, held->seq, held->utime, recv_utime));
  state_.putMap(std::move(held), std::move(frame));
  // A camera that changed state in the map (down, back) is asked about at once, so that the page
  // shows it within a moment rather than at the next periodic status.
  bool changed = decoded.cameras.size() != map_cameras_.size();
  for (std::size_t k = 0; !changed && k < decoded.cameras.size(); ++k) {
    changed = decoded.cameras[k].name != map_cameras_[k].first ||
              decoded.cameras[k].state != map_cameras_[k].second;
  }
  if (changed) {
    map_cameras_.clear();
    for (const DecodedCamera& camera : decoded.cameras) {
      map_cameras_.emplace_back(camera.name, camera.state);
    }
    prompt_request_ = true;
  }
}

void BusFeed::onStatus(occmap::status_t&& status) {
  const auto same = std::find_if(daemons_.begin(), daemons_.end(), [&](const Daemon& d) {
    return d.camera_pc && d.camera_pc->hostname == status.hostname &&
           d.camera_pc->config_file == status.config_file;
  });
  std::size_t index = static_cast<std::size_t>(same - daemons_.begin());
  if (same == daemons_.end()) {
    if (daemons_.size() >= LiveState::kMaxDaemons) return;
    daemons_.emplace_back();
  } else if (status.utime < same->camera_pc->utime &&
             monotonicNanoseconds() - same->heard_ns < 5'000'000'000) {
    return;  // an older status (an answer that came late) does not replace a newer one
  }
  daemons_[index].camera_pc = std::move(status);
  daemons_[index].heard_ns = monotonicNanoseconds();
  if (daemons_[index].first_heard_ns == 0)
    daemons_[index].first_heard_ns = daemons_[index].heard_ns;
  publishDaemon(index);
}

void BusFeed::onMergeStatus(occmap::merge_status_t&& status) {
  const auto same = std::find_if(daemons_.begin(), daemons_.end(), [&](const Daemon& d) {
    return d.merge_node && d.merge_node->hostname == status.hostname &&
           d.merge_node->config_file == status.config_file;
  });
  std::size_t index = static_cast<std::size_t>(same - daemons_.begin());
  if (same == daemons_.end()) {
    if (daemons_.size() >= LiveState::kMaxDaemons) return;
    daemons_.emplace_back();
  } else if (status.utime < same->merge_node->utime &&
             monotonicNanoseconds() - same->heard_ns < 5'000'000'000) {
    return;
  }
  daemons_[index].merge_node = std::move(status);
  daemons_[index].heard_ns = monotonicNanoseconds();
  if (daemons_[index].first_heard_ns == 0)
    daemons_[index].first_heard_ns = daemons_[index].heard_ns;
  publishDaemon(index);
}

void BusFeed::refreshHost(const std::string& hostname) {
  for (std::size_t k = 0; k < daemons_.size(); ++k) {
    if (daemons_[k].camera_pc && daemons_[k].camera_pc->hostname == hostname) publishDaemon(k);
  }
}

void BusFeed::publishDaemon(std::size_t index) {
  const Daemon& d = daemons_[index];
  const std::string& host = d.camera_pc ? d.camera_pc->hostname : d.merge_node->hostname;
  if (d.camera_pc && d.heard_ns - d.first_heard_ns < kCompanionGraceNs &&
      (controls_.of(host) == nullptr || lightings_.of(host) == nullptr ||
       views_.of(host) == nullptr)) {
    return;  // shown when the last of them comes (refreshHost), or with the next status
  }
  const double listened_s = static_cast<double>(monotonicNanoseconds() - started_ns_) / 1e9;
  const ZonesAndTracks heard{zones_.of(host), tracks_.of(host), listened_s};
  DaemonHeard daemon;
  daemon.hostname = host;
  daemon.heard_ns = d.heard_ns;
  if (d.camera_pc) {
    daemon.config_file = d.camera_pc->config_file;
    daemon.status_json = std::make_shared<const std::string>(formatStatusJson(
        *d.camera_pc, controls_.of(host), lightings_.of(host), views_.of(host), &heard));
  } else {
    daemon.config_file = d.merge_node->config_file;
    daemon.merge_node = true;
    daemon.status_json =
        std::make_shared<const std::string>(formatMergeStatusJson(*d.merge_node, &heard));
  }
  state_.putDaemon(std::move(daemon));
}

void BusFeed::requestStatus() {
  occmap::status_request_t request{};
  request.utime = hostTimeMicroseconds();
  request.request_id = request_id_;
  request_bytes_.resize(static_cast<std::size_t>(request.getEncodedSize()));
  request.encode(request_bytes_.data(), 0, static_cast<int>(request_bytes_.size()));
  if (!bus_->publish(statusRequestChannel(options_.status_channel), request_bytes_)) {
    refuse(statusRequestChannel(options_.status_channel), "the status request could not be sent");
  }
}

void BusFeed::onPreview(const occmap::camera_preview_t& preview) {
  auto held = std::make_shared<HeldPreview>();
  std::string error;
  // The coverage unpacks to a byte a cell: only for maps of a size this server holds (the
  // message's few hundred bytes could otherwise cost 64 MiB and a second of this thread).
  std::optional<std::vector<std::uint8_t>> coverage;
  if (static_cast<std::size_t>(std::max(preview.map_width, 0)) *
          static_cast<std::size_t>(std::max(preview.map_height, 0)) <=
      LiveState::kMaxCoverageCells) {
    coverage = previewCoverage(preview, &error);
    if (!coverage) {
      refuse(cameraPreviewChannel(options_.status_channel), error);
      return;
    }
  }
  held->hostname = preview.hostname;
  held->camera = preview.camera;
  held->utime = preview.utime;
  held->sequence = preview.sequence;
  held->width = preview.width;
  held->height = preview.height;
  held->jpeg.assign(preview.jpeg.begin(), preview.jpeg.end());
  held->changed = previewChangedPixels(preview);
  held->map_width = preview.map_width;
  held->map_height = preview.map_height;
  if (coverage) held->coverage = std::move(*coverage);
  held->heard_ns = monotonicNanoseconds();
  state_.putPreview(std::move(held));
}

void BusFeed::requestPreviews() {
  const std::string channel = cameraPreviewRequestChannel(options_.status_channel);
  if (!bus_->publish(channel, encodeCameraPreviewRequest(hostTimeMicroseconds(), ""))) {
    refuse(channel, "the preview request could not be sent");
  }
}

void BusFeed::refuse(const std::string& channel, const std::string& why) {
  state_.countRefused(channel + ": " + why);
}

}  // namespace occmap::web
