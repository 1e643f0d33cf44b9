// occmap status: ask the running occmapd how it is doing, over LCM.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <random>
#include <tuple>
#include <vector>

#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/merge_status_t.hpp>
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
#include "transport/merge_status_message.h"
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
  bool all = false;
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
// before or after the status, so those with our id are kept (a few dozen: with --all every daemon
// answers, and strangers may forge), each checked as carefully as the status (status_message.h).
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
  static constexpr std::size_t kMaxKept = 64;
  std::string channel_;
  std::int64_t request_id_;
  Decode decode_;
  std::vector<Message> kept_;
};

// A message occmapd publishes beside its maps (zones_t, tracks_t: footprints_message.h), which
// answers no request: the newest from each of a few dozen hosts is kept (several daemons may share
// the bus), so that the one from the daemon that answered can be shown.
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

  static constexpr std::size_t kMaxHosts = 64;
  std::string channel_;
  Decode decode_;
  std::vector<Message> kept_;
};

// One daemon's answer: a camera PC's status_t or a merge node's merge_status_t.
struct Answer {
  std::optional<occmap::status_t> camera_pc;
  std::optional<occmap::merge_status_t> merge_node;

  const std::string& hostname() const {
    return camera_pc ? camera_pc->hostname : merge_node->hostname;
  }
  const std::string& configFile() const {
    return camera_pc ? camera_pc->config_file : merge_node->config_file;
  }
  bool sameDaemon(const Answer& other) const {
    return hostname() == other.hostname() &&
           merge_node.has_value() == other.merge_node.has_value() &&
           configFile() == other.configFile();
  }
};

// The answers to our request in the order they came, each daemon's once however often it
// answered; at most kMaxDaemons, since anyone who saw the request's id can answer too. Without
// --all the first is the one shown.
class Answers {
 public:
  void take(Answer&& answer) {
    for (const Answer& kept : answers_) {
      if (kept.sameDaemon(answer)) return;
    }
    if (answers_.size() < kMaxDaemons) answers_.push_back(std::move(answer));
  }
  bool empty() const { return answers_.empty(); }
  std::size_t size() const { return answers_.size(); }
  const Answer& first() const { return answers_.front(); }
  bool from(const std::string& hostname) const {
    return std::any_of(answers_.begin(), answers_.end(),
                       [&](const Answer& a) { return a.hostname() == hostname; });
  }
  std::vector<Answer> sorted() const {
    std::vector<Answer> sorted = answers_;
    std::stable_sort(sorted.begin(), sorted.end(), [](const Answer& a, const Answer& b) {
      // has_value() orders a camera PC (no merge_status_t) before a merge node.
      return std::forward_as_tuple(a.hostname(), a.merge_node.has_value(), a.configFile()) <
             std::forward_as_tuple(b.hostname(), b.merge_node.has_value(), b.configFile());
    });
    return sorted;
  }

  static constexpr std::size_t kMaxDaemons = 64;

 private:
  std::vector<Answer> answers_;
};

// The hosts whose periodic status (request_id -1) was heard, each once, at most kMaxDaemons.
class PeriodicHosts {
 public:
  void heard(const std::string& hostname) {
    if (std::find(hosts_.begin(), hosts_.end(), hostname) == hosts_.end() &&
        hosts_.size() < Answers::kMaxDaemons) {
      hosts_.push_back(hostname);
    }
  }
  const std::vector<std::string>& hosts() const { return hosts_; }

 private:
  std::vector<std::string> hosts_;
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
  Answers answers;
  PeriodicHosts periodic;
  std::int64_t others = 0, undecodable = 0;
  // Checked before LCM's generated decoders see them (status_message.h, merge_status_message.h):
  // anyone on the network segment can publish here.
  const auto heard = [&](auto decoded, auto into) {
    if (!decoded) {
      ++undecodable;
    } else if (decoded->request_id == request_id) {
      Answer answer;
      (answer.*into).emplace(std::move(*decoded));
      answers.take(std::move(answer));
    } else if (decoded->request_id == -1) {
      periodic.heard(decoded->hostname);
    } else {
      ++others;  // an answer to someone else's request
    }
  };
  const bool subscribed =
      bus.subscribe(o.channel, [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
        heard(decodeStatus(data, size), &Answer::camera_pc);
      });
  const std::string merge_channel = mergeStatusChannel(o.channel);
  const bool merge_subscribed =
      bus.subscribe(merge_channel, [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
        heard(decodeMergeStatus(data, size), &Answer::merge_node);
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
                                    : !merge_subscribed         ? &merge_channel
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
  // A camera PC sends control, lighting and view statuses with its answer; a merge node none.
  const auto companionsHeard = [&](const Answer& a) {
    return a.merge_node ||
           (controls.of(a.hostname()) != nullptr && lightings.of(a.hostname()) != nullptr &&
            views.of(a.hostname()) != nullptr);
  };
  // A merge node sends zones and tracks beside its merged maps as a camera PC does.
  const auto mapSideHeard = [&](const Answer& a) {
    return zones.of(a.hostname()) != nullptr && tracks.of(a.hostname()) != nullptr;
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
    // With --all every daemon that answers within --timeout is listed: there is no telling when
    // the last one has, so the whole timeout is waited.
    if (!o.all && !answers.empty()) {
      if (!answered_at) answered_at = now;
      const bool companions = companionsHeard(answers.first());
      if (companions && mapSideHeard(answers.first())) break;
      grace_end = std::min(deadline, *answered_at + (companions ? Clock::duration(kMapSideGrace)
                                                                : Clock::duration(kControlGrace)));
    }
    if (now >= (grace_end ? *grace_end : deadline)) break;
    // Alone: again every 0.5 s until answered, a datagram may be lost. With --all one request,
    // which every daemon answers once.
    const bool request_due = o.all ? requests == 0 : answers.empty() && now >= next_request;
    if (request_due) {
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
    const auto until = grace_end ? *grace_end : o.all ? deadline : std::min(next_request, deadline);
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
  if (answers.empty()) {
    std::fprintf(stderr,
                 "occmap status: no result: no occmapd answered within %g s (%d request%s on %s "
                 "at %s).",
                 o.timeout, requests, requests == 1 ? "" : "s", request_channel.c_str(),
                 o.lcm_url.c_str());
    if (!periodic.hosts().empty()) {
      std::fprintf(stderr,
                   " Its periodic status did arrive (from %s): it may be too busy to answer, or "
                   "an older version.\n",
                   terminalText(periodic.hosts().front()).c_str());
    } else {
      std::fprintf(stderr,
                   " Is occmapd running, with the same transport.lcm_url and status_channel? "
                   "(ttl=0 reaches this host only.)\n");
    }
    if (undecodable > 0) {
      std::fprintf(stderr, "occmap status: %lld undecodable message%s on %s or %s\n",
                   static_cast<long long>(undecodable), undecodable == 1 ? "" : "s",
                   o.channel.c_str(), merge_channel.c_str());
    }
    return kExitNoResult;
  }
  // Each daemon as it is shown alone. A camera PC without a control_status_t (a daemon from
  // before control requests, or one lost on the way) is shown with the status alone, as such a
  // daemon always gave it.
  const auto show = [&](const Answer& a) {
    const ZonesAndTracks heard_beside{zones.of(a.hostname()), tracks.of(a.hostname()), listened_s};
    if (a.merge_node) {
      return o.json ? formatMergeStatusJson(*a.merge_node, &heard_beside) + "\n"
                    : formatMergeStatusTable(*a.merge_node, &heard_beside);
    }
    const occmap::control_status_t* control = controls.of(a.hostname());
    const occmap::lighting_status_t* lighting = lightings.of(a.hostname());
    const occmap::view_status_t* view = views.of(a.hostname());
    return o.json ? formatStatusJson(*a.camera_pc, control, lighting, view, &heard_beside) + "\n"
                  : formatStatusTable(*a.camera_pc, control, lighting, view, &heard_beside);
  };
  if (!o.all) {
    std::printf("%s", show(answers.first()).c_str());
    if (answers.size() > 1) {
      const std::size_t more = answers.size() - 1;
      std::fprintf(stderr,
                   "occmap status: %zu more daemon%s answered on %s (the first is shown): "
                   "--all lists them all\n",
                   more, more == 1 ? "" : "s", request_channel.c_str());
    }
    return kExitOk;
  }
  const std::vector<Answer> sorted = answers.sorted();
  for (std::size_t k = 0; k < sorted.size(); ++k) {
    // Tables apart by a blank line; JSON one object a line.
    std::printf("%s%s", k > 0 && !o.json ? "\n" : "", show(sorted[k]).c_str());
  }
  // A daemon whose periodic status came but which did not answer is worth a word.
  for (const std::string& host : periodic.hosts()) {
    if (!answers.from(host)) {
      std::fprintf(stderr,
                   "occmap status: %s publishes its status but did not answer within %g s: it may "
                   "be too busy to answer, or an older version\n",
                   terminalText(host).c_str(), o.timeout);
    }
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
      "--timeout.\n"
      "A merge node (occmapd with `merge:` in its config, docs/merge.md) answers the same request "
      "on the status channel's name + \"_MERGE\" and is shown the same way: its state, uptime, "
      "merged maps published, publish errors, maps per second, the latency from the newest "
      "input's arrival to the merged map's publish (p50, p99, last) and the time to take an "
      "input map in, and a table of its inputs: channel, state (never heard, fresh, down), maps, "
      "maps per second, how far behind the newest input, lost maps and clock offset, with a "
      "warning for a clock more than 10 ms off and each input's refused messages and last error; "
      "then its zones and tracks. Without --all the first daemon to answer is shown (stderr says "
      "how many more answered).\n"
      "--all sends one request and lists every daemon that answers within --timeout, camera PCs "
      "and merge nodes, each as it is shown alone, sorted by host (tables a blank line apart; "
      "with --json one object a line). It waits the whole --timeout (there is no telling when "
      "the last daemon has answered): on a LAN --timeout 1 is plenty. A daemon whose periodic "
      "status came but which did not answer is named on stderr.\n\n"
      "Examples:\n"
      "  occmap status\n"
      "  occmap status --all --timeout 1\n"
      "  occmap status --lcm-url 'udpm://239.255.76.67:7667?ttl=1' --timeout 5 --json\n\n"
      "Exit codes: 0 answered (with --all: at least one daemon); 1 failed (LCM could not be "
      "opened or the request not sent); 2 bad arguments; 3 no occmapd answered within --timeout "
      "(the message says so on stderr).");
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
  command
      ->add_option("--timeout", options->timeout,
                   "Seconds to wait for an answer (with --all, waited in full)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_flag("--json", options->json,
                    "Print the answer as one JSON object on one line (every status_t field by its "
                    "LCM name, states also by name; then control_status_t's: control_*, camera_*; "
                    "then \"zones\", an array of zone_t, and \"tracks\", the tracks_t, each "
                    "null when none was heard). A merge node's: every merge_status_t field, "
                    "\"inputs\" (where a camera PC has \"cameras\"), \"zones\", \"tracks\"");
  command->add_flag("--all", options->all,
                    "List every daemon (camera PCs and merge nodes) that answers one request "
                    "within --timeout, sorted by host");
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
