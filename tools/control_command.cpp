// occmap control: authenticated state-changing requests to a running occmapd (docs/control.md), and
// the key they are signed with.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <occmap/control_reply_t.hpp>
#include <occmap/control_request_t.hpp>

#include "base/clock.h"
#include "config/config.h"
#include "config/control_key_file.h"
#include "config/exit_codes.h"
#include "tools/commands.h"
#include "transport/control_message.h"
#include "transport/lcm_bus.h"
#include "transport/status_text.h"

namespace occmap::tools {
namespace {

using Clock = std::chrono::steady_clock;

struct ControlOptions {
  std::string make_key;
  std::string key_file;
  std::string lcm_url = TransportSettings{}.lcm_url;
  std::string channel = TransportSettings{}.status_channel;
  double timeout = 10;
  std::string camera;
  int threshold = 0;
  int frames = 50;
  CLI::App* set_threshold = nullptr;
  CLI::App* recapture = nullptr;
};

int makeKey(const std::string& file) {
  writeNewControlKey(file);
  std::printf(
      "wrote a new key to %s (mode 0600). Next:\n"
      "  chown occmap %s      # only occmapd's user may read it\n"
      "  in the config:  control: {enabled: true, key_file: %s}\n"
      "  then reload occmapd, and give each operator a copy as private as this one (mode 0600,\n"
      "  over ssh or scp, never by e-mail or chat): whoever holds it can change the daemon.\n",
      file.c_str(), file.c_str(), file.c_str());
  return kExitOk;
}

int run(const ControlOptions& o) {
  if (!o.make_key.empty()) return makeKey(o.make_key);
  const bool set_threshold = o.set_threshold->parsed();
  if (o.key_file.empty() || (!set_threshold && !o.recapture->parsed())) {
    std::fprintf(stderr,
                 "occmap control: give --key-file and a command (set-threshold CAMERA N or "
                 "recapture-background CAMERA), or --make-key FILE; see occmap control --help\n");
    return kExitInvalidInput;
  }
  const ControlKey key = loadControlKey(o.key_file, {o.key_file, 0, "--key-file"});
  LcmBus bus(o.lcm_url);
  if (!bus.good()) {
    std::fprintf(stderr,
                 "occmap control: failed: cannot open LCM at %s (is the URL right? for udpm://, "
                 "does the host have a multicast route?)\n",
                 o.lcm_url.c_str());
    return kExitFailure;
  }
  occmap::control_request_t request{};
  request.request_id = randomControlNonce() & 0x7fffffffffffffffll;
  request.nonce = randomControlNonce();
  request.command = std::string(set_threshold ? kSetThreshold : kRecaptureBackground);
  request.camera = o.camera;
  request.value = set_threshold ? o.threshold : o.frames;

  std::optional<int> exit_code;
  std::int64_t ignored = 0;
  const std::string reply_channel = controlReplyChannel(o.channel);
  const bool subscribed =
      bus.subscribe(reply_channel, [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
        // Only the daemon holds the key besides us: a reply that does not verify is anyone's.
        const std::optional<occmap::control_reply_t> reply = decodeControlReply(key, data, size);
        if (!reply || reply->request_id != request.request_id) {
          ++ignored;
          return;
        }
        const std::string text = terminalText(reply->message);
        if (reply->outcome == occmap::control_reply_t::OUTCOME_STARTED) {
          std::printf("started: %s\n", text.c_str());
          std::fflush(stdout);
        } else if (reply->outcome == occmap::control_reply_t::OUTCOME_DONE) {
          std::printf("done: %s\n", text.c_str());
          exit_code = kExitOk;
        } else {
          std::fprintf(stderr, "occmap control: refused: %s\n", text.c_str());
          exit_code = kExitFailure;
        }
      });
  if (!subscribed) {
    std::fprintf(stderr, "occmap control: failed: cannot subscribe to %s at %s\n",
                 reply_channel.c_str(), o.lcm_url.c_str());
    return kExitFailure;
  }
  // Sent once: the daemon takes a request only once (its replay window), so sending the same bytes
  // again would be refused, and a new request could do the work twice.
  request.utime = hostTimeMicroseconds();
  const std::string request_channel = controlRequestChannel(o.channel);
  if (!bus.publish(request_channel, encodeControlRequest(key, request))) {
    std::fprintf(stderr, "occmap control: failed: cannot publish on %s at %s\n",
                 request_channel.c_str(), o.lcm_url.c_str());
    return kExitFailure;
  }
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(o.timeout));
  while (!exit_code && Clock::now() < deadline) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (bus.handleTimeout(static_cast<int>(std::clamp<std::int64_t>(left.count(), 1, 100))) < 0) {
      std::fprintf(stderr, "occmap control: failed: LCM stopped receiving (%s)\n",
                   o.lcm_url.c_str());
      return kExitFailure;
    }
  }
  if (exit_code) return *exit_code;
  std::fprintf(stderr,
               "occmap control: no result: no reply from occmapd within %g s on %s at %s. A daemon "
               "answers only requests it can authenticate: is control enabled in its config, "
               "with the same key? Are the two clocks within its replay window (control."
               "replay_window_s, 30 s by default)? `occmap status` counts what it ignored.%s\n",
               o.timeout, reply_channel.c_str(), o.lcm_url.c_str(),
               ignored > 0 ? " (Replies that did not verify under this key arrived.)" : "");
  return kExitNoResult;
}

}  // namespace

Command addControlCommand(CLI::App& app) {
  auto options = std::make_shared<ControlOptions>();
  CLI::App* command = app.add_subcommand(
      "control",
      "Change what a running occmapd does, over LCM: a camera's threshold, or its background "
      "(recaptured as the per-pixel median of its next frames). Off unless occmapd's config "
      "enables it (`control: {enabled: true, key_file: FILE}`); each request is signed with the "
      "shared key (HMAC-SHA256) and taken once, within the replay window of the daemon's clock. "
      "A reload of the daemon (SIGHUP) goes back to the config's thresholds and backgrounds. "
      "docs/control.md explains what this protects and what it does not.\n\n"
      "Prints the daemon's signed reply. Requests the daemon cannot authenticate get no reply "
      "(`occmap status` counts them).\n\n"
      "Examples:\n"
      "  occmap control --make-key /etc/occmap/control.key\n"
      "  occmap control --key-file ~/.config/occmap/control.key set-threshold c0 35\n"
      "  occmap control --key-file KEY --lcm-url 'udpm://239.255.76.67:7667?ttl=1' "
      "recapture-background c2 --frames 100\n\n"
      "Exit codes: 0 done; 1 refused (the reason is printed) or LCM failed; 2 bad arguments or "
      "key file; 3 no reply within --timeout.");
  command
      ->add_option("--make-key", options->make_key,
                   "Write a new random key (64 hex digits) to this file, mode 0600, and exit; "
                   "never replaces a file")
      ->excludes(command->add_option("--key-file", options->key_file,
                                     "The shared key (the file the daemon's control.key_file "
                                     "names, or a copy as private: mode 0600)"));
  command
      ->add_option("--lcm-url", options->lcm_url, "LCM URL of the daemon (its transport.lcm_url)")
      ->capture_default_str();
  command
      ->add_option("--channel", options->channel,
                   "The daemon's status channel (transport.status_channel); requests go to its "
                   "name + \"_CONTROL\", replies come on + \"_CONTROL_REPLY\"")
      ->capture_default_str();
  command
      ->add_option("--timeout", options->timeout,
                   "Seconds to wait for the reply (for a recapture: until it has ended)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->require_subcommand(0, 1);
  options->set_threshold = command->add_subcommand(
      "set-threshold",
      "Set CAMERA's threshold to N (1..255 grey levels) from its next frame on: a pixel is "
      "unchanged when |live - background| < N");
  options->set_threshold->fallthrough();  // --key-file and the like may come after it too
  options->set_threshold->add_option("CAMERA", options->camera, "The camera's name in the config")
      ->required();
  options->set_threshold->add_option("N", options->threshold, "The new threshold")
      ->check(CLI::Range(1, 255))
      ->required();
  options->recapture = command->add_subcommand(
      "recapture-background",
      "Make CAMERA's background the per-pixel median of its next frames, without a restart (the "
      "scene should be empty, or people moving through it); saved in the daemon's state "
      "directory when it has one");
  options->recapture->fallthrough();
  options->recapture->add_option("CAMERA", options->camera, "The camera's name in the config")
      ->required();
  options->recapture->add_option("--frames", options->frames, "How many frames (1..255)")
      ->check(CLI::Range(1, 255))
      ->capture_default_str();
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
