#include "daemon/pipeline.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <future>
#include <stdexcept>

#include <occmap/control_status_t.hpp>
#include <occmap/status_t.hpp>
#include <poll.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include "base/clock.h"
#include "transport/control_message.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"
#include "transport/status_message.h"

namespace occmap {
namespace {

std::int64_t toNs(std::chrono::nanoseconds d) { return d.count(); }

void drainEventfd(int fd) {
  std::uint64_t count = 0;
  [[maybe_unused]] const ssize_t got = ::read(fd, &count, sizeof count);
}

std::string hostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "?";
  return name;
}

}  // namespace

void TimeHistogram::record(std::int64_t ns) {
  const std::int64_t bin = std::clamp<std::int64_t>(ns / 10'000, 0, kBins - 1);
  bins_[bin].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  if (ns > max_ns_.load(std::memory_order_relaxed)) max_ns_.store(ns, std::memory_order_relaxed);
}

double TimeHistogram::percentileMs(double fraction) const {
  std::uint64_t total = 0;
  for (const auto& bin : bins_) total += bin.load(std::memory_order_relaxed);
  if (total == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(fraction * static_cast<double>(total - 1));
  std::uint64_t seen = 0;
  for (int i = 0; i < kBins; ++i) {
    seen += bins_[i].load(std::memory_order_relaxed);
    if (seen > rank) return (i + 0.5) * 0.01;  // the bin's middle, in ms
  }
  return kBins * 0.01;
}

Pipeline::Pipeline(Rig rig, std::vector<CarveTable> tables, PipelineOptions options)
    : rig_(std::move(rig)),
      tables_(std::move(tables)),
      options_(std::move(options)),
      kernel_(tables_),
      maps_(MapFrame(rig_.config().map, rig_.cameras().size()),
            MapFrame(rig_.config().map, rig_.cameras().size()),
            MapFrame(rig_.config().map, rig_.cameras().size())) {
  const std::size_t cameras = rig_.cameras().size();
  if (tables_.size() != cameras) throw std::invalid_argument("one carve table per camera");
  for (std::size_t k = 0; k < cameras; ++k) {
    const FrameSource& source = *rig_.cameras()[k].source;
    const int width = source.width();
    const int height = source.height();
    // Four slots: fusion holds the newest, and three leave the camera room while fusion works.
    rings_.push_back(std::make_unique<SpscRing<CapturedFrame>>(4, [&] {
      CapturedFrame frame;
      frame.image = Image(width, height);
      frame.changed.assign(changedMaskBytes(width, height), 0);
      return frame;
    }));
    counters_.push_back(std::make_unique<CameraCounters>());
    drop_warnings_.push_back(std::make_unique<RateLimit>(std::chrono::seconds(10)));
  }
  held_.resize(cameras);
  changed_.resize(cameras, nullptr);
  fusion_wakeup_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  publish_wakeup_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (fusion_wakeup_ < 0 || publish_wakeup_ < 0) {
    throw std::runtime_error(std::string("eventfd: ") + std::strerror(errno));
  }
  std::vector<CameraControl*> controls;
  for (std::size_t k = 0; k < cameras; ++k) {
    const RigCamera& camera = rig_.cameras()[k];
    camera_controls_.push_back(
        std::make_unique<CameraControl>(camera.name, camera.background, camera.threshold,
                                        rig_.config().cameras[k].fps.value_or(30.0)));
    controls.push_back(camera_controls_.back().get());
  }
  RemoteControl::Options control;
  control.state_directory = options_.state_directory;
  control.max_requests_per_s = options_.max_control_requests_per_s;
  control.wake_lcm = [this] { wake(publish_wakeup_); };
  control_ = std::make_unique<RemoteControl>(rig_.config(), std::move(controls), control);
}

Pipeline::~Pipeline() {
  stop();
  if (fusion_wakeup_ >= 0) ::close(fusion_wakeup_);
  if (publish_wakeup_ >= 0) ::close(publish_wakeup_);
}

void Pipeline::wake(int fd) {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t written = ::write(fd, &one, sizeof one);
}

void Pipeline::start() {
  if (started_) return;
  // The LCM thread first, so that it subscribes before the first map exists; it says whether LCM
  // opened before anything else starts.
  std::promise<std::string> lcm_opened;
  std::future<std::string> lcm_problem = lcm_opened.get_future();
  threads_.emplace_back([this, &lcm_opened] { lcmLoop(lcm_opened); });
  if (std::string problem = lcm_problem.get(); !problem.empty()) {
    threads_.back().join();
    threads_.clear();
    throw std::runtime_error(problem);
  }
  started_ = true;
  control_->start();
  start_ns_ = monotonicNanoseconds();
  last_fused_ns_ = start_ns_;
  threads_.emplace_back([this] { fusionLoop(); });
  for (std::size_t k = 0; k < rig_.cameras().size(); ++k) {
    threads_.emplace_back([this, k] { captureLoop(k); });
  }
}

void Pipeline::stop() {
  if (!started_ || stopping_.exchange(true)) return;
  // threads_: the LCM thread, the fusion thread, then one per camera.
  for (std::size_t t = 2; t < threads_.size(); ++t) threads_[t].join();
  control_->stop();  // a recapture under way is given up: its camera delivers no more frames
  stop_fusion_.store(true);
  wake(fusion_wakeup_);
  threads_[1].join();
  stop_lcm_.store(true);
  wake(publish_wakeup_);
  threads_[0].join();
  threads_.clear();
}

bool Pipeline::camerasReportedIn() const {
  for (const auto& counters : counters_) {
    if (counters->state.load(std::memory_order_relaxed) == CameraState::kStarting) return false;
  }
  return true;
}

std::uint64_t Pipeline::framesDropped() const {
  std::uint64_t dropped = 0;
  for (const auto& counters : counters_) {
    dropped += counters->frames_dropped.load(std::memory_order_relaxed);
  }
  return dropped;
}

std::string Pipeline::summary() const {
  std::size_t streaming = 0;
  std::uint64_t dropped = 0;
  for (const auto& counters : counters_) {
    streaming += counters->state.load(std::memory_order_relaxed) == CameraState::kStreaming;
    dropped += counters->frames_dropped.load(std::memory_order_relaxed);
  }
  char line[200];
  std::snprintf(line, sizeof line,
                "%zu of %zu cameras streaming; %llu maps published; %llu frames dropped", streaming,
                counters_.size(), static_cast<unsigned long long>(mapsPublished()),
                static_cast<unsigned long long>(dropped));
  return line;
}

// One camera: read (or wait for) a frame, copy it into the ring with its changed-pixel mask (the
// paper's difference, done here while the pixels are hot), wake fusion.
void Pipeline::captureLoop(std::size_t k) {
  RigCamera& camera = rig_.cameras()[k];
  FrameSource& source = *camera.source;
  CameraCounters& counters = *counters_[k];
  SpscRing<CapturedFrame>& ring = *rings_[k];
  CameraControl& control = *camera_controls_[k];
  const double fps = rig_.config().cameras[k].fps.value_or(30.0);
  const auto period_ns = static_cast<std::int64_t>(1e9 / fps);
  std::int64_t next_ns = monotonicNanoseconds();
  RateLimit error_warnings(std::chrono::seconds(10));
  const int ring_width = camera.background.width();
  const int ring_height = camera.background.height();
  bool lost = false;
  std::int64_t retry_ns = 100'000'000;
  std::int64_t next_retry_ns = 0;
  while (!stopping_.load(std::memory_order_relaxed)) {
    if (!source.isLive()) {
      // Recorded and simulated cameras run at their configured rate, as a camera would.
      sleepUntil(next_ns);
      next_ns += period_ns;
      const std::int64_t now = monotonicNanoseconds();
      if (next_ns < now - period_ns) next_ns = now;  // fell far behind: do not burst to catch up
    }
    if (lost) {
      // The camera is away: try to open it again, waiting longer after each failure (0.1 s up
      // to 1 s: a try that finds nothing already takes a second of Aravis's discovery), in
      // short sleeps so that a stop is noticed.
      const std::int64_t now = monotonicNanoseconds();
      if (now < next_retry_ns) {
        sleepUntil(std::min(next_retry_ns, now + 100'000'000));
        continue;
      }
      if (!source.reopen()) {
        retry_ns = std::min<std::int64_t>(retry_ns * 2, 1'000'000'000);
        next_retry_ns = monotonicNanoseconds() + retry_ns;
        continue;
      }
      lost = false;
      retry_ns = 100'000'000;
      counters.reconnects.fetch_add(1, std::memory_order_relaxed);
      counters.lost.store(false, std::memory_order_relaxed);
      logLine(LogLevel::kNotice, "camera %s is back", camera.name.c_str());
    }
    Frame frame;
    const FrameSource::Status status = source.read(frame);
    if (status == FrameSource::Status::kTimeout) continue;
    if (status == FrameSource::Status::kLost) {
      lost = true;
      next_retry_ns = monotonicNanoseconds() + retry_ns;
      counters.lost.store(true, std::memory_order_relaxed);
      counters.setLastError(source.lastError());
      logLine(LogLevel::kWarning, "camera %s lost: %s; reconnecting", camera.name.c_str(),
              source.lastError().c_str());
      continue;
    }
    if (status == FrameSource::Status::kEnd) {
      if (source.rewind()) continue;
      break;
    }
    const bool wrong_size = status == FrameSource::Status::kFrame &&
                            (frame.image.width != ring_width || frame.image.height != ring_height);
    if (status == FrameSource::Status::kError || wrong_size) {
      // A bad frame (corrupt, a device error, another size than the stream's): skip and count it.
      counters.frames_dropped.fetch_add(1, std::memory_order_relaxed);
      std::uint64_t suppressed = 0;
      if (error_warnings.allow(suppressed)) {
        const std::string why = wrong_size ? "a frame of " + std::to_string(frame.image.width) +
                                                 "x" + std::to_string(frame.image.height) +
                                                 " instead of " + std::to_string(ring_width) + "x" +
                                                 std::to_string(ring_height)
                                           : source.lastError();
        counters.setLastError(why);
        logLine(LogLevel::kWarning, "camera %s: %s, dropped (%llu more like this not shown)",
                camera.name.c_str(), why.c_str(), static_cast<unsigned long long>(suppressed));
      }
      continue;
    }
    const std::int64_t arrived_ns = monotonicNanoseconds();
    control.recorder.record(frame.image);  // one atomic load unless a recapture is under way
    CapturedFrame* slot = ring.writeSlot();
    if (slot == nullptr) {
      // Fusion is behind and holds every slot: drop the newest, count it, say so now and then.
      counters.frames_dropped.fetch_add(1, std::memory_order_relaxed);
      std::uint64_t suppressed = 0;
      if (drop_warnings_[k]->allow(suppressed)) {
        logLine(LogLevel::kWarning, "camera %s: frame dropped, fusion is behind (%llu more since)",
                camera.name.c_str(), static_cast<unsigned long long>(suppressed));
      }
      continue;
    }
    for (int v = 0; v < frame.image.height; ++v) {
      std::memcpy(slot->image.row(v), frame.image.row(v),
                  static_cast<std::size_t>(frame.image.width));
    }
    // Both may change at any frame (control requests): read once per frame, without a lock.
    const ImageView background = control.background.current().view();
    const int threshold = control.threshold.load(std::memory_order_relaxed);
    kernel_.markChangedPixels(k, frame.image, background, threshold, slot->changed.data());
    slot->sequence = frame.sequence;
    slot->capture_time_us = frame.capture_time_us;
    slot->monotonic_ns = arrived_ns;
    ring.commitWrite();
    counters.frames_in.fetch_add(1, std::memory_order_relaxed);
    counters.last_capture_us.store(frame.capture_time_us, std::memory_order_relaxed);
    counters.last_frame_ns.store(arrived_ns, std::memory_order_relaxed);
    wake(fusion_wakeup_);
  }
}

void Pipeline::fusionLoop() {
  const std::int64_t max_wait_ns =
      static_cast<std::int64_t>(rig_.config().fusion.max_wait_ms) * 1'000'000;
  const std::int64_t down_after_ns = toNs(options_.camera_down_after);
  const std::int64_t start_timeout_ns = toNs(options_.camera_start_timeout);
  const std::int64_t heartbeat_ns = toNs(options_.heartbeat);
  pollfd wakeup{fusion_wakeup_, POLLIN, 0};
  while (!stop_fusion_.load(std::memory_order_relaxed)) {
    std::int64_t now = monotonicNanoseconds();
    std::int64_t timeout_ns = set_deadline_ns_ != 0 ? set_deadline_ns_ - now : 100'000'000;
    timeout_ns = std::clamp<std::int64_t>(timeout_ns, 0, 100'000'000);
    ::poll(&wakeup, 1, static_cast<int>((timeout_ns + 999'999) / 1'000'000));
    drainEventfd(fusion_wakeup_);
    // On stop, the cameras have ended: what they left is fused below as a last (complete or
    // not) frame set, so no frame that reached a ring is lost without a map.
    const bool last_round = stop_fusion_.load(std::memory_order_relaxed);
    now = monotonicNanoseconds();
    bool any_fresh = false;
    bool all_fresh = true;
    for (std::size_t k = 0; k < rings_.size(); ++k) {
      // Keep only the newest frame of each ring; older ones were overtaken before fusion got them.
      SpscRing<CapturedFrame>& ring = *rings_[k];
      Held& held = held_[k];
      const std::size_t waiting = ring.size();
      const std::size_t newer = held.frame != nullptr ? waiting - 1 : waiting;
      if (newer > 0) {
        if (held.frame != nullptr) ring.pop();
        for (std::size_t i = 1; i < newer; ++i) ring.pop();
        held.frame = ring.front();
        held.fresh = true;
      }
      // The camera's state follows from the age of its newest frame.
      CameraCounters& counters = *counters_[k];
      const std::int64_t last = counters.last_frame_ns.load(std::memory_order_relaxed);
      CameraState state = CameraState::kStreaming;
      if (counters.lost.load(std::memory_order_relaxed)) {
        state = CameraState::kDown;  // the source said so: no need to wait for the silence
      } else if (last == 0) {
        state = now - start_ns_ > start_timeout_ns ? CameraState::kDown : CameraState::kStarting;
      } else if (now - last > down_after_ns) {
        state = CameraState::kDown;
      }
      if (counters.state.exchange(state, std::memory_order_relaxed) != state &&
          state == CameraState::kDown && !counters.lost.load(std::memory_order_relaxed)) {
        // Gone silent (a source that says why it was lost has said so already, and its reason is
        // the better one for the status).
        char why[96];
        std::snprintf(why, sizeof why, "no frame for %.1f s",
                      static_cast<double>(now - (last == 0 ? start_ns_ : last)) / 1e9);
        counters.setLastError(why);
        std::uint64_t suppressed = 0;
        if (counters.down_warnings.allow(suppressed)) {
          logLine(LogLevel::kWarning, "camera %s is down: %s (%llu more since)",
                  rig_.cameras()[k].name.c_str(), why, static_cast<unsigned long long>(suppressed));
        }
      }
      any_fresh = any_fresh || held.fresh;
      if (state != CameraState::kDown && !held.fresh) all_fresh = false;
    }
    if (any_fresh && set_deadline_ns_ == 0) set_deadline_ns_ = now + max_wait_ns;
    const bool set_complete = any_fresh && (all_fresh || now >= set_deadline_ns_ || last_round);
    if (set_complete || now - last_fused_ns_ >= heartbeat_ns) fuse(now);
    if (last_round) break;
  }
}

void Pipeline::fuse(std::int64_t now) {
  if (options_.stall_fusion_after_maps != 0 &&
      maps_fused_.load(std::memory_order_relaxed) >= options_.stall_fusion_after_maps) {
    // Injected fault: fusion hangs (until stop), as a deadlock or a stuck device call would.
    while (!stop_fusion_.load(std::memory_order_relaxed))
      sleepUntil(monotonicNanoseconds() + 10'000'000);
    return;
  }
  const std::int64_t down_after_ns = toNs(options_.camera_down_after);
  MapFrame& out = maps_.writeBuffer();
  std::int64_t newest = 0;
  std::int64_t newest_arrival = 0;
  for (std::size_t k = 0; k < held_.size(); ++k) {
    Held& held = held_[k];
    const CameraState state = counters_[k]->state.load(std::memory_order_relaxed);
    // The newest frame of each live camera; one that is late for this set still counts with its
    // previous frame as long as that is recent (a down camera's cells turn unseen instead).
    const bool used = held.frame != nullptr && state != CameraState::kDown &&
                      now - held.frame->monotonic_ns <= down_after_ns;
    changed_[k] = used ? held.frame->changed.data() : nullptr;
    out.cameras[k] =
        CameraContribution{state, used, used ? static_cast<std::int64_t>(held.frame->sequence) : -1,
                           used ? held.frame->capture_time_us : 0};
    if (used) {
      newest = std::max(newest, held.frame->capture_time_us);
      newest_arrival = std::max(newest_arrival, held.frame->monotonic_ns);
    }
    held.fresh = false;
  }
  const std::int64_t began = monotonicNanoseconds();
  kernel_.fuse(changed_, out.map.cells);
  fusion_times_.record(monotonicNanoseconds() - began);
  out.utime = newest != 0 ? newest : hostTimeMicroseconds();
  out.newest_arrival_ns = newest_arrival;
  if (maps_.publish()) maps_skipped_.fetch_add(1, std::memory_order_relaxed);
  wake(publish_wakeup_);
  set_deadline_ns_ = 0;
  last_fused_ns_ = now;
  maps_fused_.fetch_add(1, std::memory_order_relaxed);
}

// The one thread that owns the LCM handle: publishes maps as fusion makes them, answers status
// requests, publishes the status every status_period.
void Pipeline::lcmLoop(std::promise<std::string>& opened) {
  const Config& config = rig_.config();
  const TransportSettings& transport = config.transport;
  LcmBus bus(transport.lcm_url);
  if (!bus.good()) {
    opened.set_value("cannot open LCM at " + transport.lcm_url +
                     " (a udpm:// URL needs a network with a multicast route; see docs/daemon.md)");
    return;
  }
  opened.set_value("");
  std::vector<std::string> names;
  for (const RigCamera& camera : rig_.cameras()) names.push_back(camera.name);
  MapEncoder encoder(config.map, names, parseMapEncoding(transport.encoding).value());

  // Requests are only queued here (bounded); answers go out below at a bounded rate.
  constexpr std::size_t kMaxPending = 16;
  std::int64_t pending[kMaxPending] = {};
  std::size_t pending_count = 0;
  std::uint64_t requests_ignored = 0;
  bus.subscribe(statusRequestChannel(transport.status_channel),
                [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
                  // The same checked decode the status_request fuzz target runs.
                  const std::optional<std::int64_t> request_id = decodeStatusRequest(data, size);
                  if (!request_id || pending_count == kMaxPending) {
                    ++requests_ignored;
                    return;
                  }
                  pending[pending_count++] = *request_id;
                });
  // Control requests: checked and acted on here, in the LCM thread (remote_control.h).
  bus.subscribe(controlRequestChannel(transport.status_channel),
                [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
                  control_->handle(data, size, hostTimeMicroseconds(), bus);
                });
  for (const auto& [channel, handler] : options_.subscriptions) {
    bus.subscribe(channel, [handler](const std::uint8_t* data, std::size_t size, std::int64_t) {
      handler(data, size);
    });
  }

  const std::string host = hostName();
  const std::string config_file = config.file.string();  // made once: the status allocates nothing
  const std::int64_t status_period_ns = toNs(options_.status_period);
  const std::int64_t daemon_start_ns =
      toNs(options_.daemon_start.time_since_epoch());  // steady_clock is CLOCK_MONOTONIC
  std::int64_t next_status_ns = monotonicNanoseconds();
  // Rates are measured over the last few status periods (one alone is too short to be steady):
  // a fixed ring of samples, the oldest at `oldest_sample`, filled in place.
  struct Sample {
    std::int64_t ns = 0;
    std::uint64_t published = 0;
    std::vector<std::uint64_t> frames;
  };
  constexpr std::size_t kRateSamples = 5;
  std::vector<Sample> samples(
      kRateSamples, Sample{next_status_ns, 0, std::vector<std::uint64_t>(counters_.size())});
  std::size_t oldest_sample = 0;
  double answer_tokens = options_.max_status_answers_per_s;
  std::int64_t last_token_ns = next_status_ns;
  std::vector<std::uint8_t> status_buffer;
  occmap::status_t status;
  const std::string control_status_channel = controlStatusChannel(transport.status_channel);
  std::vector<std::uint8_t> control_status_buffer;
  occmap::control_status_t control_status;
  std::int64_t next_seq = 0;

  auto publishStatus = [&](std::int64_t request_id, std::int64_t now) {
    const Sample& oldest = samples[oldest_sample];
    const double window_s = std::max(1e-3, static_cast<double>(now - oldest.ns) / 1e9);
    status.utime = hostTimeMicroseconds();
    status.request_id = request_id;
    status.hostname = host;
    status.config_file = config_file;
    status.state = static_cast<std::int8_t>(state_.load(std::memory_order_relaxed));
    status.uptime_s = static_cast<double>(now - daemon_start_ns) / 1e9;
    const std::uint64_t published = maps_published_.load(std::memory_order_relaxed);
    status.maps_published = static_cast<std::int64_t>(published);
    status.publish_errors =
        static_cast<std::int64_t>(publish_errors_.load(std::memory_order_relaxed));
    status.maps_per_s = static_cast<double>(published - oldest.published) / window_s;
    status.fusion_p50_ms = fusion_times_.percentileMs(0.50);
    status.fusion_p99_ms = fusion_times_.percentileMs(0.99);
    status.num_cameras = static_cast<std::int16_t>(counters_.size());
    status.cameras.resize(counters_.size());
    for (std::size_t k = 0; k < counters_.size(); ++k) {
      const CameraCounters& c = *counters_[k];
      occmap::camera_status_t& s = status.cameras[k];
      const std::uint64_t frames = c.frames_in.load(std::memory_order_relaxed);
      s.name = rig_.cameras()[k].name;
      s.source = config.cameras[k].source;
      s.state = static_cast<std::int8_t>(c.state.load(std::memory_order_relaxed));
      s.frames_in = static_cast<std::int64_t>(frames);
      s.frames_dropped =
          static_cast<std::int64_t>(c.frames_dropped.load(std::memory_order_relaxed));
      s.fps = static_cast<double>(frames - oldest.frames[k]) / window_s;
      s.last_capture_utime = c.last_capture_us.load(std::memory_order_relaxed);
      const TransportCounters transport_counters = rig_.cameras()[k].source->transportCounters();
      s.frames_incomplete = transport_counters.frames_incomplete;
      s.missing_packets = transport_counters.missing_packets;
      s.resent_packets = transport_counters.resent_packets;
      s.underruns = transport_counters.underruns;
      s.reconnects = c.reconnects.load(std::memory_order_relaxed);
      s.last_error = counters_[k]->lastError();
    }
    if (request_id < 0) {
      // The oldest sample makes way for this one (the ring starts with copies of the start).
      Sample& sample = samples[oldest_sample];
      sample.ns = now;
      sample.published = published;
      for (std::size_t k = 0; k < counters_.size(); ++k) {
        sample.frames[k] = counters_[k]->frames_in.load(std::memory_order_relaxed);
      }
      oldest_sample = (oldest_sample + 1) % kRateSamples;
    }
    status_buffer.resize(static_cast<std::size_t>(status.getEncodedSize()));
    status.encode(status_buffer.data(), 0, static_cast<int>(status_buffer.size()));
    if (!bus.publish(transport.status_channel, status_buffer)) {
      publish_errors_.fetch_add(1, std::memory_order_relaxed);
    }
    // Its companion, control_status_t: a type of its own, so that status_t stays the type every
    // reader built before control requests decodes (lcmtypes/control_status_t.lcm). The same
    // utime, request_id and hostname pair the two. Filled in place like the status: once its
    // strings and vectors have their size (the first time), this allocates nothing.
    const ControlCounts control = control_->counts();
    control_status.utime = status.utime;
    control_status.request_id = request_id;
    control_status.hostname = host;
    control_status.control_enabled = control_->enabled();
    control_status.disabled = static_cast<std::int64_t>(control.disabled);
    control_status.malformed = static_cast<std::int64_t>(control.malformed);
    control_status.bad_mac = static_cast<std::int64_t>(control.bad_mac);
    control_status.stale = static_cast<std::int64_t>(control.stale);
    control_status.refused = static_cast<std::int64_t>(control.refused);
    control_status.accepted = static_cast<std::int64_t>(control.accepted);
    control_status.num_cameras = static_cast<std::int16_t>(counters_.size());
    control_status.camera_name.resize(counters_.size());
    control_status.camera_threshold.resize(counters_.size());
    control_status.camera_background_utime.resize(counters_.size());
    for (std::size_t k = 0; k < counters_.size(); ++k) {
      control_status.camera_name[k] = rig_.cameras()[k].name;
      control_status.camera_threshold[k] =
          camera_controls_[k]->threshold.load(std::memory_order_relaxed);
      control_status.camera_background_utime[k] =
          camera_controls_[k]->background_utime.load(std::memory_order_relaxed);
    }
    control_status_buffer.resize(static_cast<std::size_t>(control_status.getEncodedSize()));
    control_status.encode(control_status_buffer.data(), 0,
                          static_cast<int>(control_status_buffer.size()));
    if (!bus.publish(control_status_channel, control_status_buffer)) {
      publish_errors_.fetch_add(1, std::memory_order_relaxed);
    }
  };

  RateLimit publish_warnings(std::chrono::seconds(10));
  auto publishNewestMap = [&] {
    if (!maps_.takeLatest()) return;
    MapFrame& map = maps_.readBuffer();
    map.seq = next_seq++;
    const std::span<const std::uint8_t> message = encoder.encode(map);
    if (!message.empty() && bus.publish(transport.map_channel, message)) {
      if (map.newest_arrival_ns != 0) {
        publish_latency_.record(monotonicNanoseconds() - map.newest_arrival_ns);
      }
      maps_published_.fetch_add(1, std::memory_order_relaxed);
    } else {
      const int error = errno;  // what LCM's send left
      publish_errors_.fetch_add(1, std::memory_order_relaxed);
      std::uint64_t suppressed = 0;
      if (publish_warnings.allow(suppressed)) {
        logLine(LogLevel::kWarning,
                "a map could not be sent on %s (%s; %llu more failures since): is the network "
                "down? Maps go out again as soon as it is back",
                transport.lcm_url.c_str(), message.empty() ? "not encoded" : std::strerror(error),
                static_cast<unsigned long long>(suppressed));
      }
    }
  };

  pollfd fds[2] = {{publish_wakeup_, POLLIN, 0}, {bus.fileno(), POLLIN, 0}};
  while (!stop_lcm_.load(std::memory_order_relaxed)) {
    lcm_rounds_.fetch_add(1, std::memory_order_relaxed);
    std::int64_t now = monotonicNanoseconds();
    const std::int64_t timeout_ns = std::clamp<std::int64_t>(next_status_ns - now, 0, 100'000'000);
    ::poll(fds, 2, static_cast<int>((timeout_ns + 999'999) / 1'000'000));
    if (fds[0].revents & POLLIN) drainEventfd(publish_wakeup_);
    publishNewestMap();
    if (fds[1].revents & POLLIN) bus.handleTimeout(0);
    control_->publishReplies(bus);
    if (options_.each_lcm_round) options_.each_lcm_round(bus);
    now = monotonicNanoseconds();
    answer_tokens = std::min(options_.max_status_answers_per_s,
                             answer_tokens + static_cast<double>(now - last_token_ns) / 1e9 *
                                                 options_.max_status_answers_per_s);
    last_token_ns = now;
    std::size_t answered = 0;
    while (answered < pending_count && answer_tokens >= 1.0) {
      publishStatus(pending[answered++], now);
      answer_tokens -= 1.0;
    }
    // Requests beyond the rate wait for tokens; the queue's bound sheds a flood.
    std::copy(pending + answered, pending + pending_count, pending);
    pending_count -= answered;
    if (now >= next_status_ns) {
      publishStatus(-1, now);
      next_status_ns = now + status_period_ns;
    }
  }
  // Fusion has ended: its last map goes out, then a last status that says the daemon is stopping.
  publishNewestMap();
  publishStatus(-1, monotonicNanoseconds());
  // In-process subscribers (memq://, the tests' hooks) hear what was sent only when the bus is
  // handled: let them have the last map too.
  while (bus.handleTimeout(0) > 0) {
  }
  if (requests_ignored > 0) {
    logLine(LogLevel::kInfo, "%llu malformed or excess status requests were ignored",
            static_cast<unsigned long long>(requests_ignored));
  }
}

}  // namespace occmap
