#include "daemon/remote_control.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <new>
#include <system_error>

#include <poll.h>
#include <unistd.h>

#include "base/clock.h"
#include "base/log.h"
#include "capture/frame_source.h"
#include "capture/image_file.h"
#include "config/control_key_file.h"
#include "core/background_median.h"
#include "transport/bus.h"

namespace occmap {
namespace {

// A recapture keeps its frames in memory until their median is taken: at most this much.
constexpr std::size_t kMaxRecaptureBytes = std::size_t{256} << 20;
constexpr int kMaxRecaptureFrames = 255;

ControlKey keyOf(const Config& config) {
  if (!config.control.enabled) return {};
  return loadControlKey(config.control.key_file,
                        {config.file.string(), config.control.key_file_line, "control.key_file"});
}

}  // namespace

RemoteControl::RemoteControl(const Config& config, std::vector<CameraControl*> cameras,
                             Options options)
    : enabled_(config.control.enabled),
      key_(keyOf(config)),
      cameras_(std::move(cameras)),
      options_(std::move(options)),
      reply_channel_(controlReplyChannel(config.transport.status_channel)),
      replay_(static_cast<std::int64_t>(config.control.replay_window_s) * 1'000'000,
              options_.replay_memory),
      tokens_(options_.max_requests_per_s) {
  // Room for the longest reply, made now: the LCM thread then allocates nothing to answer.
  reply_.message.reserve(sizeof finished_message_);
  reply_bytes_.reserve(kMaxControlRequestBytes + sizeof finished_message_);
}

RemoteControl::~RemoteControl() { stop(); }

void RemoteControl::start() {
  if (enabled_ && !thread_.joinable()) thread_ = std::thread([this] { recaptureLoop(); });
}

void RemoteControl::stop() {
  stopping_.store(true, std::memory_order_relaxed);
  wakeup_.signal();
  if (thread_.joinable()) thread_.join();
}

ControlCounts RemoteControl::counts() const {
  constexpr auto relaxed = std::memory_order_relaxed;
  return {disabled_.load(relaxed), malformed_.load(relaxed), bad_mac_.load(relaxed),
          stale_.load(relaxed),    refused_.load(relaxed),   accepted_.load(relaxed)};
}

void RemoteControl::reply(Bus& bus, std::int64_t request_id, std::int8_t outcome,
                          const char* format, ...) {
  char text[sizeof finished_message_];
  va_list arguments;
  va_start(arguments, format);
  const int length = std::vsnprintf(text, sizeof text, format, arguments);
  va_end(arguments);
  reply_.utime = hostTimeMicroseconds();
  reply_.request_id = request_id;
  reply_.outcome = outcome;
  // Within the capacity reserved at construction: no allocation.
  reply_.message.assign(text,
                        static_cast<std::size_t>(std::clamp<int>(length, 0, sizeof text - 1)));
  encodeControlReply(key_, reply_, reply_bytes_);
  bus.publish(reply_channel_, reply_bytes_);
}

void RemoteControl::handle(const std::uint8_t* data, std::size_t size, std::int64_t now_us,
                           Bus& bus) {
  constexpr auto relaxed = std::memory_order_relaxed;
  if (!enabled_) {
    disabled_.fetch_add(1, relaxed);
    return;
  }
  // Cheapest first, and nothing trusted before the mac: an unauthenticated message gets no reply
  // (the daemon is no oracle and no amplifier for whoever can publish).
  const std::optional<ControlRequestFields> request = parseControlRequest(data, size);
  if (!request) {
    malformed_.fetch_add(1, relaxed);
    return;
  }
  if (!controlMacMatches(key_, data, size)) {
    bad_mac_.fetch_add(1, relaxed);
    return;
  }
  if (replay_.admit(request->utime, request->nonce, now_us) != ReplayWindow::Verdict::kFresh) {
    stale_.fetch_add(1, relaxed);
    return;
  }
  // Even a key holder gets a bounded rate: a token bucket, refilled by the daemon's clock.
  const std::int64_t elapsed_us = std::max<std::int64_t>(0, now_us - last_token_us_);
  last_token_us_ = now_us;
  tokens_ = std::min(options_.max_requests_per_s,
                     tokens_ + static_cast<double>(elapsed_us) / 1e6 * options_.max_requests_per_s);
  if (tokens_ < 1.0) {
    refused_.fetch_add(1, relaxed);
    return;
  }
  tokens_ -= 1.0;

  const std::int64_t id = request->request_id;
  const auto camera_name = static_cast<int>(request->camera.size());
  const char* camera_text = request->camera.data();
  std::size_t k = 0;
  while (k < cameras_.size() && cameras_[k]->name != request->camera) ++k;
  const bool set_threshold = request->command == kSetThreshold;
  const bool recapture = request->command == kRecaptureBackground;
  auto refuse = [&](const char* why) {
    refused_.fetch_add(1, relaxed);
    reply(bus, id, occmap::control_reply_t::OUTCOME_REFUSED, "%s", why);
  };
  if (!set_threshold && !recapture) {
    refused_.fetch_add(1, relaxed);
    reply(bus, id, occmap::control_reply_t::OUTCOME_REFUSED,
          "unknown command \"%.*s\"; the commands are set_threshold and recapture_background",
          static_cast<int>(request->command.size()), request->command.data());
    return;
  }
  if (k == cameras_.size()) {
    char names[256] = {};
    std::size_t used = 0;
    for (const CameraControl* camera : cameras_) {
      const int n = std::snprintf(names + used, sizeof names - used, "%s%s", used ? ", " : "",
                                  camera->name.c_str());
      if (n < 0 || static_cast<std::size_t>(n) >= sizeof names - used) break;
      used += static_cast<std::size_t>(n);
    }
    refused_.fetch_add(1, relaxed);
    reply(bus, id, occmap::control_reply_t::OUTCOME_REFUSED,
          "no camera named \"%.*s\"; the cameras are: %s", camera_name, camera_text, names);
    return;
  }
  CameraControl& camera = *cameras_[k];
  if (set_threshold) {
    if (request->value < 1 || request->value > 255) {
      refused_.fetch_add(1, relaxed);
      reply(bus, id, occmap::control_reply_t::OUTCOME_REFUSED,
            "threshold %d is out of range; a threshold is 1 to 255 grey levels", request->value);
      return;
    }
    // The capture thread reads it for its next frame: one relaxed atomic, no lock on its path.
    const int was = camera.threshold.exchange(request->value, relaxed);
    accepted_.fetch_add(1, relaxed);
    logLine(LogLevel::kNotice, "control: camera %s threshold %d (was %d)", camera.name.c_str(),
            request->value, was);
    reply(bus, id, occmap::control_reply_t::OUTCOME_DONE,
          "camera %s: threshold %d (was %d), from its next frame on; a reload (SIGHUP) goes back "
          "to the config's",
          camera.name.c_str(), request->value, was);
    return;
  }
  const std::size_t frame_bytes =
      static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  const int most = static_cast<int>(std::clamp<std::size_t>(
      kMaxRecaptureBytes / std::max<std::size_t>(frame_bytes, 1), 1, kMaxRecaptureFrames));
  if (request->value < 1 || request->value > most) {
    refused_.fetch_add(1, relaxed);
    reply(bus, id, occmap::control_reply_t::OUTCOME_REFUSED,
          "%d frames is out of range; camera %s takes 1 to %d frames for a background",
          request->value, camera.name.c_str(), most);
    return;
  }
  if (stopping_.load(relaxed)) return refuse("the daemon is stopping");
  if (camera.view_moved.load(relaxed)) {
    refused_.fetch_add(1, relaxed);
    reply(bus, id, occmap::control_reply_t::OUTCOME_REFUSED,
          "camera %s: its view has moved from its calibration (occmap status says by how much): a "
          "background taken now would not fit it. occmapd re-poses it by itself once its view is "
          "still; or put the camera back",
          camera.name.c_str());
    return;
  }
  if (recapture_busy_.load(std::memory_order_acquire)) {
    return refuse("a recapture is under way; try again when it has ended");
  }
  job_camera_ = k;
  job_frames_ = request->value;
  job_request_id_ = id;
  recapture_busy_.store(true, std::memory_order_release);
  wakeup_.signal();
  accepted_.fetch_add(1, relaxed);
  logLine(LogLevel::kNotice, "control: recapturing the background of camera %s from %d frames",
          camera.name.c_str(), request->value);
  reply(bus, id, occmap::control_reply_t::OUTCOME_STARTED,
        "camera %s: recapturing its background from its next %d frames (about %.1f s at %g fps)",
        camera.name.c_str(), request->value, request->value / camera.fps, camera.fps);
}

void RemoteControl::publishReplies(Bus& bus) {
  if (!finished_.load(std::memory_order_acquire)) return;
  reply(bus, finished_request_id_, finished_outcome_, "%s", finished_message_);
  finished_.store(false, std::memory_order_release);
}

void RemoteControl::finishRecapture(std::int64_t request_id, std::int8_t outcome,
                                    const char* format, ...) {
  // The LCM thread takes a reply within a round (0.1 s); wait for the one before to go.
  while (finished_.load(std::memory_order_acquire) && !stopping_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  va_list arguments;
  va_start(arguments, format);
  std::vsnprintf(finished_message_, sizeof finished_message_, format, arguments);
  va_end(arguments);
  logLine(outcome == occmap::control_reply_t::OUTCOME_DONE ? LogLevel::kNotice : LogLevel::kWarning,
          "control: %s", finished_message_);
  finished_request_id_ = request_id;
  finished_outcome_ = outcome;
  finished_.store(true, std::memory_order_release);
  if (options_.wake_lcm) options_.wake_lcm();
}

void RemoteControl::recaptureLoop() {
  pollfd wakeup{wakeup_.fd(), POLLIN, 0};
  while (!stopping_.load(std::memory_order_relaxed)) {
    ::poll(&wakeup, 1, 1000);
    wakeup_.drain();
    if (stopping_.load(std::memory_order_relaxed)) break;
    if (!recapture_busy_.load(std::memory_order_acquire)) continue;
    // No exception leaves this thread: a recapture that fails in a way not foreseen below is
    // refused like the others, and the daemon runs on with the background it had.
    try {
      recapture(job_camera_, job_frames_, job_request_id_);
    } catch (const std::exception& error) {
      cameras_[job_camera_]->recorder.finish();
      finishRecapture(job_request_id_, occmap::control_reply_t::OUTCOME_REFUSED,
                      "camera %s: the recapture failed (%s); the background stays as it was",
                      cameras_[job_camera_]->name.c_str(), error.what());
    }
    recapture_busy_.store(false, std::memory_order_release);
  }
}

void RemoteControl::recapture(std::size_t k, int frames, std::int64_t request_id) {
  constexpr std::int8_t kRefused = occmap::control_reply_t::OUTCOME_REFUSED;
  CameraControl& camera = *cameras_[k];
  const char* name = camera.name.c_str();
  try {
    if (!camera.recorder.arm(frames, camera.width, camera.height)) {
      finishRecapture(request_id, kRefused,
                      "camera %s: an earlier recapture has not let go of its frames (the camera "
                      "delivers none?); the background stays as it was",
                      name);
      return;
    }
  } catch (const std::bad_alloc&) {
    finishRecapture(request_id, kRefused, "camera %s: not enough memory for %d frames of %dx%d",
                    name, frames, camera.width, camera.height);
    return;
  }
  // The camera's own pace, with room for a slow start; a camera that is down fails here.
  const double timeout_s = 2.0 * frames / camera.fps + 5.0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!camera.recorder.filled()) {
    if (stopping_.load(std::memory_order_relaxed) || std::chrono::steady_clock::now() > deadline) {
      camera.recorder.finish();  // given up; the capture thread lets go at its next frame
      finishRecapture(request_id, kRefused,
                      "camera %s did not deliver %d frames within %.0f s; its background stays "
                      "as it was",
                      name, frames, timeout_s);
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::unique_ptr<Image> median;
  try {
    median = std::make_unique<Image>(
        backgroundMedian(camera.recorder.frames(), frames, camera.width, camera.height));
  } catch (const std::bad_alloc&) {
    camera.recorder.finish();
    finishRecapture(request_id, kRefused, "camera %s: not enough memory for the median", name);
    return;
  }
  camera.recorder.finish();  // frees the frames
  // Saved first (written aside, then renamed: never a half-written file under the name), so the
  // reply can say where; the config's image is left alone.
  char saved[256] = "not saved (no state directory)";
  if (options_.state_directory) {
    const std::filesystem::path file =
        *options_.state_directory / ("background-" + camera.name + ".png");
    const std::filesystem::path part =
        *options_.state_directory / (".background-" + camera.name + ".part.png");
    std::string error;
    std::error_code renamed;
    if (writeGreyPng(part, *median, error)) {
      std::filesystem::rename(part, file, renamed);
      if (renamed) error = renamed.message();
    }
    std::snprintf(saved, sizeof saved, error.empty() ? "saved to %s" : "not saved: %s",
                  error.empty() ? file.c_str() : error.c_str());
  }
  camera.background.offer(std::move(median));
  // The capture thread switches at its next frame; wait for that (a camera that went down meanwhile
  // switches when it is back).
  const auto taken_by = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  bool taken = camera.background.collect();
  while (!taken && std::chrono::steady_clock::now() < taken_by &&
         !stopping_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    taken = camera.background.collect();
  }
  camera.background_utime.store(hostTimeMicroseconds(), std::memory_order_relaxed);
  finishRecapture(request_id, occmap::control_reply_t::OUTCOME_DONE,
                  "camera %s: its background is now the per-pixel median of %d frames%s; %s; a "
                  "reload (SIGHUP) goes back to the config's image",
                  name, frames, taken ? "" : " (in use from its next frame)", saved);
}

}  // namespace occmap
