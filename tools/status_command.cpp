// occmap status: ask the running occmapd how it is doing, over LCM.
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/status_request_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>
#include <occmap/view_status_t.hpp>
#include <occmap/zones_t.hpp>

#include "base/clock.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "tools/commands.h"
#include "transport/control_message.h"
#include "transport/footprints_message.h"
#include "transport/lcm_bus.h"
#include "transport/status_message.h"
#include "transport/status_text.h"

namespace occmap::tools {
namespace {

using Clock = std::chrono::steady_clock;

struct StatusOptions {
  std::string lcm_url = TransportSettings{}.lcm_url;
  std::string channel = TransportSettings{}.status_channel;
  std::string map_channel = TransportSettings{}.map_channel;
  double timeout = 3;
  bool json = false;
};

// A random, non-negative id (-1 marks the daemon's periodic status).
std::int64_t randomRequestId() {
  std::random_device device;
  const std::uint64_t high = device(), low = device();
  return static_cast<std::int64_t>((high << 32 | low) & 0x7fffffffffffffffull);
}

// A message occmapd publishes with each status_t (control_status_t, lighting_status_t,
// view_status_t): the one
// that goes with our answer has our request id and the answering daemon's hostname. It may come
// before or after the status, so those with our id are kept (a few: several daemons may answer,
// strangers may forge), each checked as carefully as the status (status_message.h).
template <typename Message>
class Companions {
 public:
  using Decode = std::optional<Message> (*)(const std::uint8_t*, std::size_t, std::string*);
  Companions(std::string channel, std::int64_t request_id, Decode decode)
      : channel_(std::move(channel)), request_id_(request_id), decode_(decode) {}

  bool subscribe(LcmBus& bus) {
    return bus.subscribe(
        channel_, [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
          std::optional<Message> message = decode_(data, size, nullptr);
          if (message && message->request_id == request_id_ && kept_.size() < kMaxKept) {
            kept_.push_back(std::move(*message));
          }
        });
  }
  const std::string& channel() const { return channel_; }
  // The one from `hostname`, or nullptr (none yet, or a daemon from before this message).
  const Message* of(const std::string& hostname) const {
    for (const Message& message : kept_) {
      if (message.hostname == hostname) return &message;
    }
    return nullptr;
  }

 private:
  static constexpr std::size_t kMaxKept = 8;
  std::string channel_;
  std::int64_t request_id_;
  Decode decode_;
  std::vector<Message> kept_;
};

// A message occmapd publishes beside its maps (zones_t, tracks_t: footprints_message.h), which
// answers no request: the newest from each of a few hosts is kept (several daemons may share the
// bus), so that the one from the daemon that answered can be shown.
template <typename Message>
class NewestByHost {
 public:
  using Decode = std::optional<Message> (*)(const std::uint8_t*, std::size_t, std::string*);
  NewestByHost(std::string channel, Decode decode)
      : channel_(std::move(channel)), decode_(decode) {}

  bool subscribe(LcmBus& bus) {
    return bus.subscribe(channel_,
                         [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
                           std::optional<Message> message = decode_(data, size, nullptr);
                           if (message) keep(std::move(*message));
                         });
  }
  const std::string& channel() const { return channel_; }
  // The newest from `hostname`, or nullptr.
  const Message* of(const std::string& hostname) const {
    for (const Message& message : kept_) {
      if (message.hostname == hostname) return &message;
    }
    return nullptr;
  }

 private:
  void keep(Message&& message) {
    for (Message& kept : kept_) {
      if (kept.hostname == message.hostname) {
        kept = std::move(message);
        return;
      }
    }
    if (kept_.size() < kMaxHosts) kept_.push_back(std::move(message));
  }

  static constexpr std::size_t kMaxHosts = 8;
  std::string channel_;
  Decode decode_;
  std::vector<Message> kept_;
};

int run(const StatusOptions& o) {
  LcmBus bus(o.lcm_url);
  if (!bus.good()) {
    std::fprintf(stderr,
                 "occmap status: failed: cannot open LCM at %s (is the URL right? for udpm://, "
                 "does the host have a multicast route?)\n",
                 o.lcm_url.c_str());
    return kExitFailure;
  }
  const std::int64_t request_id = randomRequestId();
  std::optional<occmap::status_t> answer;
  std::int64_t periodic = 0, others = 0, undecodable = 0;
  std::string periodic_host;
  const bool subscribed =
      bus.subscribe(o.channel, [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
        // Checked before LCM's generated decoder sees it (status_message.h): anyone on the
        // network segment can publish here.
        std::optional<occmap::status_t> status = decodeStatus(data, size);
        if (!status) {
          ++undecodable;
        } else if (status->request_id == request_id) {
          // The first answer is the one printed (another daemon on the channel may answer too).
          if (!answer) answer = std::move(status);
        } else if (status->request_id == -1) {
          ++periodic;
          periodic_host = terminalText(status->hostname);
        } else {
          ++others;  // an answer to someone else's request
        }
      });
  Companions<occmap::control_status_t> controls(controlStatusChannel(o.channel), request_id,
                                                decodeControlStatus);
  Companions<occmap::lighting_status_t> lightings(lightingStatusChannel(o.channel), request_id,
                                                  decodeLightingStatus);
  Companions<occmap::view_status_t> views(viewStatusChannel(o.channel), request_id,
                                          decodeViewStatus);
  NewestByHost<occmap::zones_t> zones(zonesChannel(o.map_channel), decodeZones);
  NewestByHost<occmap::tracks_t> tracks(tracksChannel(o.map_channel), decodeTracks);
  const std::string* unsubscribed = !subscribed                 ? &o.channel
                                    : !controls.subscribe(bus)  ? &controls.channel()
                                    : !lightings.subscribe(bus) ? &lightings.channel()
                                    : !views.subscribe(bus)     ? &views.channel()
                                    : !zones.subscribe(bus)     ? &zones.channel()
                                    : !tracks.subscribe(bus)    ? &tracks.channel()
                                                                : nullptr;
  if (unsubscribed != nullptr) {
    std::fprintf(stderr, "occmap status: failed: cannot subscribe to %s at %s\n",
                 unsubscribed->c_str(), o.lcm_url.c_str());
    return kExitFailure;
  }
  const auto controlOfAnswer = [&] { return controls.of(answer->hostname); };
  const auto lightingOfAnswer = [&] { return lightings.of(answer->hostname); };
  const auto viewOfAnswer = [&] { return views.of(answer->hostname); };
  const auto companionsHeard = [&] {
    return controlOfAnswer() != nullptr && lightingOfAnswer() != nullptr &&
           viewOfAnswer() != nullptr;
  };
  const auto mapSideHeard = [&] {
    return zones.of(answer->hostname) != nullptr && tracks.of(answer->hostname) != nullptr;
  };

  const std::string request_channel = statusRequestChannel(o.channel);
  std::vector<std::uint8_t> buffer;
  int requests = 0;
  const auto start = Clock::now();
  const auto deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.timeout));
  auto next_request = start;
  // Once the status has come, its control_status_t, lighting_status_t and view_status_t get this
  // long more (within the deadline): the daemon sends them right after the status, and a daemon
  // from before them never does, which must not cost its user the whole timeout.
  constexpr auto kControlGrace = std::chrono::milliseconds(500);
  // The zones and tracks of the daemon that answered are listened to from the start; if they are
  // not all there with the answer, they get this long more (and no longer than the companions or
  // the deadline): zones come with every map, 30 a second, and tracks as often when the detector
  // keeps up (1.8 ms a map on the paper's rig), so a daemon that sends them is heard, and one that
  // does not (footprints off, no zones) costs its user no more than this.
  constexpr auto kMapSideGrace = std::chrono::milliseconds(200);
  std::optional<Clock::time_point> answered_at;
  std::optional<Clock::time_point> grace_end;
  while (true) {
    const auto now = Clock::now();
    if (answer && !answered_at) answered_at = now;
    if (answer) {
      const bool companions = companionsHeard();
      if (companions && mapSideHeard()) break;
      grace_end = std::min(deadline, *answered_at + (companions ? Clock::duration(kMapSideGrace)
                                                                : Clock::duration(kControlGrace)));
    }
    if (now >= (grace_end ? *grace_end : deadline)) break;
    if (!answer && now >= next_request) {  // again every 0.5 s: a datagram may be lost
      occmap::status_request_t request{};
      request.utime = hostTimeMicroseconds();
      request.request_id = request_id;
      buffer.resize(static_cast<std::size_t>(request.getEncodedSize()));
      request.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
      if (!bus.publish(request_channel, buffer)) {
        std::fprintf(stderr, "occmap status: failed: cannot publish on %s at %s\n",
                     request_channel.c_str(), o.lcm_url.c_str());
        return kExitFailure;
      }
      ++requests;
      next_request += std::chrono::milliseconds(500);
    }
    const auto until = grace_end ? *grace_end : std::min(next_request, deadline);
    const auto wait = std::min(until - now, Clock::duration(std::chrono::milliseconds(50)));
    const int wait_ms =
        1 + static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(wait).count());
    if (bus.handleTimeout(wait_ms) < 0) {
      std::fprintf(stderr, "occmap status: failed: LCM stopped receiving (%s)\n",
                   o.lcm_url.c_str());
      return kExitFailure;
    }
  }
  const double listened_s = std::chrono::duration<double>(Clock::now() - start).count();
  if (!answer) {
    std::fprintf(stderr,
                 "occmap status: no result: no occmapd answered within %g s (%d request%s on %s "
                 "at %s).",
                 o.timeout, requests, requests == 1 ? "" : "s", request_channel.c_str(),
                 o.lcm_url.c_str());
    if (periodic > 0) {
      std::fprintf(stderr,
                   " Its periodic status did arrive (from %s): it may be too busy to answer, or "
                   "an older version.\n",
                   periodic_host.c_str());
    } else {
      std::fprintf(stderr,
                   " Is occmapd running, with the same transport.lcm_url and status_channel? "
                   "(ttl=0 reaches this host only.)\n");
    }
    if (undecodable > 0) {
      std::fprintf(stderr, "occmap status: %lld undecodable message%s on %s\n",
                   static_cast<long long>(undecodable), undecodable == 1 ? "" : "s",
                   o.channel.c_str());
    }
    return kExitNoResult;
  }
  // Without a control_status_t (a daemon from before control requests, or one lost on the way),
  // the status alone, as such a daemon always gave it.
  const occmap::control_status_t* control = controlOfAnswer();
  const occmap::lighting_status_t* lighting = lightingOfAnswer();
  const occmap::view_status_t* view = viewOfAnswer();
  const ZonesAndTracks heard{zones.of(answer->hostname), tracks.of(answer->hostname), listened_s};
  if (o.json) {
    std::printf("%s\n", formatStatusJson(*answer, control, lighting, view, &heard).c_str());
  } else {
    std::printf("%s", formatStatusTable(*answer, control, lighting, view, &heard).c_str());
  }
  return kExitOk;
}

}  // namespace

Command addStatusCommand(CLI::App& app) {
  auto options = std::make_shared<StatusOptions>();
  CLI::App* command = app.add_subcommand(
      "status",
      "Ask the running occmapd how it is doing, over LCM.\n"
      "Publishes a status request with a random id on the status channel's name + \"_REQUEST\" "
      "(OCCMAP_STATUS_REQUEST by default), again every 0.5 s, until occmapd answers on the "
      "status channel with that id; then prints the daemon's state, uptime, maps published, "
      "publish errors, maps per second and fusion time (p50, p99), and a table of its cameras: "
      "state, frames in, frames dropped, frames per second and the age of the last capture; then, "
      "from the control status the daemon sends with it (on the status channel's name + "
      "\"_CONTROL_STATUS\"; a daemon from before control requests sends none), what became of "
      "control requests (`occmap control`, docs/control.md) and, when they are enabled, each "
      "camera's threshold and background. While it waits it also listens to the map's zones "
      "(zones_t on the map channel's name + \"_ZONES\") and tracks (tracks_t on its name + "
      "\"_TRACKS\") and prints the answering daemon's newest: each zone's state and for how "
      "long, and what is tracked (people and objects), where and how fast (or that none were "
      "heard: no zones in the "
      "config, footprints off); it waits for them at most 0.2 s after the answer, never past "
      "--timeout.\n\n"
      "Examples:\n"
      "  occmap status\n"
      "  occmap status --lcm-url 'udpm://239.255.76.67:7667?ttl=1' --timeout 5 --json\n\n"
      "Exit codes: 0 answered; 1 failed (LCM could not be opened or the request not sent); "
      "2 bad arguments; 3 no occmapd answered within --timeout (the message says so on stderr).");
  command
      ->add_option("--lcm-url", options->lcm_url, "LCM URL of the daemon (its transport.lcm_url)")
      ->capture_default_str();
  command
      ->add_option("--channel", options->channel,
                   "Status channel (transport.status_channel); requests go to its name + "
                   "\"_REQUEST\"")
      ->capture_default_str();
  command
      ->add_option("--map-channel", options->map_channel,
                   "Map channel (transport.map_channel); zones are heard on its name + "
                   "\"_ZONES\", tracks on its name + \"_TRACKS\"")
      ->capture_default_str();
  command->add_option("--timeout", options->timeout, "Seconds to wait for an answer")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_flag("--json", options->json,
                    "Print the answer as one JSON object on one line (every status_t field by its "
                    "LCM name, states also by name; then control_status_t's: control_*, camera_*; "
                    "then \"zones\", an array of zone_t, and \"tracks\", the tracks_t, each "
                    "null when none was heard)");
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
