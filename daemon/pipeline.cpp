#include "daemon/pipeline.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>

#include <poll.h>
#include <sys/resource.h>
#include <unistd.h>

#include "base/clock.h"
#include "base/log.h"
#include "config/calibration_file.h"
#include "core/opencv_camera.h"
#include "core/pacing.h"
#include "daemon/service_notifier.h"
#include "transport/camera_preview_message.h"
#include "transport/control_message.h"
#include "transport/status_requests.h"
#include "transport/status_text.h"

namespace occmap {
namespace {

constexpr std::int64_t kMs = 1'000'000;
// The footprints thread's nice value: the map's threads first (setpriority(2) on a thread id).
constexpr int kFootprintsNice = 10;
// The previewer's: below the footprints too. A preview late under load costs a client a picture;
// a late map or track costs more.
constexpr int kPreviewerNice = 15;
// The longest a fusion or publisher round sleeps: camera states are looked at this often.
constexpr std::int64_t kLongestWaitNs = 100 * kMs;

int pollTimeoutMs(std::int64_t until_ns, std::int64_t now_ns) {
  const std::int64_t ns = std::clamp<std::int64_t>(until_ns - now_ns, 0, kLongestWaitNs);
  return static_cast<int>((ns + kMs - 1) / kMs);
}

std::vector<std::string> cameraNames(const Rig& rig) {
  std::vector<std::string> names;
  for (const RigCamera& camera : rig.cameras()) names.push_back(camera.name);
  return names;
}

MapFrame emptyMap(const Rig& rig) {
  return MapFrame(rig.config().map, rig.cameras().size(), rig.config().zones.size());
}

}  // namespace

Pipeline::Camera::Camera(const RigCamera& camera, double fps, const CameraHealthPolicy& policy,
                         int width, int height)
    : health(policy, fps),
      control(camera.name, camera.background, camera.threshold, fps),
      changed_pixels(camera.lighting, *camera.camera),
      frames(CapturedFrame{std::vector<std::uint8_t>(changedMaskBytes(width, height))},
             CapturedFrame{std::vector<std::uint8_t>(changedMaskBytes(width, height))},
             CapturedFrame{std::vector<std::uint8_t>(changedMaskBytes(width, height))}) {}

Pipeline::Pipeline(PreparedRig prepared, std::unique_ptr<Bus> bus, PipelineOptions options)
    : prepared_(std::move(prepared)),
      bus_(std::move(bus)),
      options_(std::move(options)),
      kernel_(prepared_.tables),
      frame_set_(prepared_.rig.cameras().size(),
                 {static_cast<std::int64_t>(prepared_.rig.config().fusion.max_wait_ms) * kMs,
                  std::chrono::nanoseconds(options_.heartbeat).count()}),
      maps_(emptyMap(prepared_.rig), emptyMap(prepared_.rig), emptyMap(prepared_.rig)),
      zone_poses_(prepared_.rig.cameras().size()),
      map_publisher_(
          prepared_.rig.config().map, cameraNames(prepared_.rig),
          parseMapEncoding(prepared_.rig.config().transport.encoding).value(),
          prepared_.rig.config().transport.map_channel, prepared_.rig.config().transport.lcm_url,
          prepared_.rig.config().transport.tiles ? MapMessages::kTiles : MapMessages::kWhole),
      footprints_publisher_(prepared_.rig.config().transport.map_channel, hostName(),
                            prepared_.rig.config().zones) {
  const Config& config = prepared_.rig.config();
  const std::size_t cameras = prepared_.rig.cameras().size();
  if (prepared_.tables.size() != cameras) throw std::invalid_argument("one carve table per camera");
  if (!bus_) throw std::invalid_argument("a pipeline needs a bus to publish on");
  std::vector<CameraControl*> controls;
  report_.hostname = hostName();
  report_.config_file = config.file.string();
  report_.cameras.resize(cameras);
  for (std::size_t k = 0; k < cameras; ++k) {
    const RigCamera& camera = prepared_.rig.cameras()[k];
    const FrameSource& source = *camera.source;
    cameras_.push_back(std::make_unique<Camera>(camera, config.cameras[k].fps.value_or(30.0),
                                                options_.camera_health, source.width(),
                                                source.height()));
    controls.push_back(&cameras_.back()->control);
    report_.cameras[k].name = camera.name;
    report_.cameras[k].source = config.cameras[k].source;
    report_.cameras[k].last_error.reserve(kMaxErrorText);
  }
  states_.assign(cameras, CameraState::kStarting);
  logged_states_.assign(cameras, CameraState::kStarting);
  changed_.assign(cameras, nullptr);
  footprint_masks_.assign(cameras, nullptr);
  generations_.assign(cameras, 0);
  std::vector<occmap::Camera> posed;
  for (const RigCamera& camera : prepared_.rig.cameras()) posed.push_back(*camera.camera);
  if (!config.zones.empty()) {
    if (config.footprints.enabled && config.footprints.hidden_floor_unseen) {
      zones_.emplace(config.map, config.zones, posed, config.footprints,
                     config.fusion.column_height_m);
    } else {
      zones_.emplace(config.map, config.zones);
    }
  }
  if (config.footprints.enabled) {
    std::vector<std::size_t> mask_bytes;
    for (const RigCamera& camera : prepared_.rig.cameras()) {
      mask_bytes.push_back(changedMaskBytes(camera.source->width(), camera.source->height()));
    }
    footprints_ =
        std::make_unique<FootprintsStage>(config.map, posed, config.footprints, mask_bytes);
  }
  previewer_ = std::make_unique<Previewer>(report_.hostname, cameraNames(prepared_.rig),
                                           prepared_.tables, options_.preview_for);
  RemoteControl::Options control;
  control.state_directory = options_.state_directory;
  control.max_requests_per_s = options_.max_control_requests_per_s;
  control.wake_lcm = [this] { publish_wakeup_.signal(); };
  control_ = std::make_unique<RemoteControl>(config, std::move(controls), control);
}

Pipeline::~Pipeline() { stop(); }

template <typename Body>
void Pipeline::guarded(const char* thread, std::size_t camera, Body&& body) {
  try {
    body();
  } catch (const std::exception& error) {
    threadFailed(thread, camera, error.what());
  } catch (...) {
    threadFailed(thread, camera, "an exception of unknown type");
  }
}

void Pipeline::threadFailed(const char* thread, std::size_t camera, const char* what) {
  if (camera < cameras_.size()) {
    // That camera goes down with the reason in its status; the others go on.
    cameras_[camera]->last_error.format("its capture thread failed: %s", what);
    cameras_[camera]->health.lost();
    logLine(LogLevel::kError, "camera %s: the capture thread failed: %s",
            prepared_.rig.cameras()[camera].name.c_str(), what);
    return;
  }
  failed_.store(true, std::memory_order_relaxed);
  logLine(LogLevel::kError, "the %s thread failed: %s; no more maps will be made", thread, what);
}

void Pipeline::start() {
  if (started_) return;
  started_ = true;
  const std::int64_t now = monotonicNanoseconds();
  for (const auto& camera : cameras_) camera->health.opened(now);
  frame_set_.start(now);
  control_->start();
  // threads_: the publisher, fusion, then one per camera (stop() joins them in reverse).
  threads_.emplace_back([this] { guarded("publisher", kNoCamera, [this] { publisherLoop(); }); });
  threads_.emplace_back([this] { guarded("fusion", kNoCamera, [this] { fusionLoop(); }); });
  if (footprints_) {
    footprints_thread_ = std::thread([this] {
      // Below the map's path: on a machine with few cores the capture, fusion and publisher
      // threads go first (SCHED_IDLE measured no better, and would starve the tracks under
      // load; docs/detection.md has what the thread costs the map).
      if (::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kFootprintsNice) != 0) {
        logLine(LogLevel::kWarning, "the footprints thread keeps its priority: %s",
                std::strerror(errno));
      }
      guarded("footprints", kNoCamera, [this] { footprints_->run(publish_wakeup_); });
    });
  }
  previewer_thread_ = std::thread([this] {
    if (::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kPreviewerNice) != 0) {
      logLine(LogLevel::kWarning, "the previewer thread keeps its priority: %s",
              std::strerror(errno));
    }
    guarded("previewer", kNoCamera, [this] { previewer_->run(publish_wakeup_); });
  });
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    threads_.emplace_back([this, k] { guarded("capture", k, [this, k] { captureLoop(k); }); });
  }
}

void Pipeline::stop() {
  if (!started_ || stopping_.exchange(true)) return;
  for (std::size_t t = 2; t < threads_.size(); ++t) threads_[t].join();
  control_->stop();  // a recapture under way is given up: its camera delivers no more frames
  stop_fusion_.store(true);
  fusion_wakeup_.signal();
  threads_[1].join();
  if (footprints_thread_.joinable()) {
    footprints_->stop();  // it finds the people on the last map first
    footprints_thread_.join();
  }
  previewer_->stop();  // a preview under way is finished; those not yet made are not
  previewer_thread_.join();
  stop_publisher_.store(true);
  publish_wakeup_.signal();
  threads_[0].join();
  threads_.clear();
}

bool Pipeline::camerasReportedIn() const {
  const std::int64_t now = monotonicNanoseconds();
  return std::none_of(cameras_.begin(), cameras_.end(), [now](const auto& camera) {
    return camera->health.state(now) == CameraState::kStarting;
  });
}

std::uint64_t Pipeline::framesDropped() const {
  std::uint64_t dropped = 0;
  for (const auto& camera : cameras_)
    dropped += camera->frames_dropped.load(std::memory_order_relaxed);
  return dropped;
}

std::uint64_t Pipeline::framesOvertaken() const {
  std::uint64_t overtaken = 0;
  for (const auto& camera : cameras_) {
    overtaken += camera->frames_overtaken.load(std::memory_order_relaxed);
  }
  return overtaken;
}

std::string Pipeline::summary() const {
  const std::int64_t now = monotonicNanoseconds();
  const auto streaming = std::count_if(cameras_.begin(), cameras_.end(), [now](const auto& c) {
    return c->health.state(now) == CameraState::kStreaming;
  });
  char line[200];
  std::snprintf(line, sizeof line,
                "%zu of %zu cameras streaming; %llu maps published; %llu frames dropped",
                static_cast<std::size_t>(streaming), cameras_.size(),
                static_cast<unsigned long long>(mapsPublished()),
                static_cast<unsigned long long>(framesDropped()));
  return line;
}

void Pipeline::publishZones(Bus& bus, const MapFrame& map) {
  sent_maps_[map.fused % kSentMaps] = SentMap{map.fused, map.seq};
  footprints_publisher_.publishZones(bus, map.seq, map.utime, map.zones, map.time_s);
}

void Pipeline::publishTracks(Bus& bus) {
  if (!footprints_) return;
  const FootprintsFound* found = footprints_->takeLatest();
  if (found == nullptr) return;
  const SentMap& sent = sent_maps_[found->fused % kSentMaps];
  const std::int64_t seq = sent.fused == found->fused ? sent.seq : -1;
  footprints_publisher_.publishTracks(bus, seq, found->utime, found->footprints, found->tracks);
}

// One camera: read (or wait for) a frame, mark its changed pixels into the camera's newest-frame
// buffer (the paper's difference, done here while the pixels are hot), wake fusion. Live cameras
// that are lost, or silent past their limit (camera_health.h), are reopened with a growing pause.
void Pipeline::captureLoop(std::size_t k) {
  const RigCamera& rig_camera = prepared_.rig.cameras()[k];
  FrameSource& source = *rig_camera.source;
  Camera& camera = *cameras_[k];
  const bool live = source.isLive();
  const int width = camera.control.width;
  const int height = camera.control.height;
  FramePacer pacer(prepared_.rig.config().cameras[k].fps.value_or(30.0), monotonicNanoseconds());
  ReconnectBackoff backoff;
  while (!stopping_.load(std::memory_order_relaxed)) {
    if (!live) sleepUntil(pacer.next(monotonicNanoseconds()));
    if (camera.health.isLost()) {
      // The camera is away: try to open it again, in short sleeps so that a stop is noticed.
      const std::int64_t now = monotonicNanoseconds();
      if (!backoff.due(now)) {
        sleepUntil(std::min(backoff.nextTryNs(), now + kLongestWaitNs));
        continue;
      }
      if (!source.reopen()) {
        backoff.failed(monotonicNanoseconds());
        continue;
      }
      camera.health.opened(monotonicNanoseconds());
      camera.reconnects.fetch_add(1, std::memory_order_relaxed);
      logLine(LogLevel::kNotice, "camera %s is back", rig_camera.name.c_str());
    }
    Frame frame;
    const FrameSource::Status status = source.read(frame);
    const std::int64_t now = monotonicNanoseconds();
    if (status == FrameSource::Status::kTimeout) {
      if (live && camera.health.stalled(now)) {
        char why[96];
        std::snprintf(why, sizeof why, "no frame for %.1f s (the camera stopped sending)",
                      static_cast<double>(camera.health.silenceNs(now)) / 1e9);
        loseCamera(k, why);
        backoff.lost(now);
      }
      continue;
    }
    if (status == FrameSource::Status::kLost) {
      loseCamera(k, source.lastError().c_str());
      backoff.lost(now);
      continue;
    }
    if (status == FrameSource::Status::kEnd) {
      if (source.rewind()) continue;
      break;
    }
    const bool wrong_size = status == FrameSource::Status::kFrame &&
                            (frame.image.width != width || frame.image.height != height);
    if (status == FrameSource::Status::kError || wrong_size) {
      // A bad frame (corrupt, a device error, another size than the stream's): skip and count it.
      camera.frames_dropped.fetch_add(1, std::memory_order_relaxed);
      std::uint64_t suppressed = 0;
      if (camera.error_warnings.allow(now, suppressed)) {
        char why[256];
        if (wrong_size) {
          std::snprintf(why, sizeof why, "a frame of %dx%d instead of %dx%d", frame.image.width,
                        frame.image.height, width, height);
        } else {
          std::snprintf(why, sizeof why, "%s", source.lastError().c_str());
        }
        camera.last_error.set(why);
        logLine(LogLevel::kWarning, "camera %s: %s, dropped (%llu more like this not shown)",
                rig_camera.name.c_str(), why, static_cast<unsigned long long>(suppressed));
      }
      continue;
    }
    camera.control.recorder.record(frame.image);  // one atomic load unless a recapture is under way
    CapturedFrame& slot = camera.frames.writeBuffer();
    // Both may change at any frame (control requests): read once per frame, without a lock. A
    // re-posed camera's own background is used until a recapture offers a new one.
    const Image& offered = camera.control.background.current();
    if (&offered != camera.offered) {
      camera.offered = &offered;
      camera.reposed_background = nullptr;
    }
    const Image& background =
        camera.reposed_background != nullptr ? *camera.reposed_background : offered;
    const int threshold = camera.control.threshold.load(std::memory_order_relaxed);
    slot.explained = camera.changed_pixels.mark(kernel_, k, frame.image, background, threshold,
                                                slot.changed.data(), frame.capture_time_us);
    slot.generation = camera.changed_pixels.generation();
    if (const LightingModel* model = camera.changed_pixels.lighting(); model != nullptr) {
      camera.lighting_gain.store(model->gain(), std::memory_order_relaxed);
      camera.lighting_agreement.store(model->agreement(), std::memory_order_relaxed);
    }
    if (!slot.explained) camera.unexplained_frames.fetch_add(1, std::memory_order_relaxed);
    if (slot.explained == camera.unexplained.load(std::memory_order_relaxed)) {
      noteLighting(k, slot.explained);
    }
    if (camera.changed_pixels.checkedUs() !=
            camera.view_checked_us.load(std::memory_order_relaxed) ||
        static_cast<std::int8_t>(camera.changed_pixels.view()) !=
            camera.view.load(std::memory_order_relaxed)) {
      noteView(k);
    }
    repose(k, background);
    slot.sequence = frame.sequence;
    slot.capture_time_us = frame.capture_time_us;
    slot.arrival_ns = now;
    if (camera.frames.publish()) camera.frames_overtaken.fetch_add(1, std::memory_order_relaxed);
    camera.frames_in.fetch_add(1, std::memory_order_relaxed);
    camera.last_capture_us.store(frame.capture_time_us, std::memory_order_relaxed);
    camera.health.frameArrived(now);
    fusion_wakeup_.signal();
    // A preview for a live view (previewer.h): one atomic load unless a client asks, a shrunk copy
    // at most twice a second when one does; after the hand-off, so that fusion never waits for
    // it. The mask handed over is only read from here on (as fusion and the footprints' copy only
    // read it), and this thread writes into it again only after a later publish() gives it back.
    if (previewer_->due(k, now, frame.capture_time_us)) {
      previewer_->offer(k, frame.image, slot.changed.data(), frame.sequence, frame.capture_time_us,
                        camera.health.state(now));
    }
  }
}

// Capture thread: a camera's view went from what a change of light explains to what it does not,
// or back. Said once each way; the frames in between do not count (fuse()).
void Pipeline::noteLighting(std::size_t k, bool explained) {
  Camera& camera = *cameras_[k];
  camera.unexplained.store(!explained, std::memory_order_relaxed);
  std::uint64_t suppressed = 0;
  if (!camera.lighting_notes.allow(suppressed)) return;  // a view on the edge flips often
  const LightingModel* model = camera.changed_pixels.lighting();
  const double agreement = model != nullptr ? model->agreement() : 0.0;
  if (explained) {
    logLine(LogLevel::kNotice,
            "camera %s: its view is explained by the light again (gain %.2f; %llu changes "
            "not shown)",
            prepared_.rig.cameras()[k].name.c_str(), model != nullptr ? model->gain() : 1.0,
            static_cast<unsigned long long>(suppressed));
  } else {
    logLine(LogLevel::kWarning,
            "camera %s: no change of light explains its view (%.0f %% of its pixels agree with "
            "one gain): covered, lights out, knocked, or hidden by a crowd; its cells count as "
            "unseen until it is (a knocked camera is re-posed by itself; occmap control "
            "recapture-background takes a new background; %llu changes not shown)",
            prepared_.rig.cameras()[k].name.c_str(), 100 * agreement,
            static_cast<unsigned long long>(suppressed));
  }
}

// Capture thread: the camera's view was checked (ChangedPixels: while no light explains it, once a
// second), or is as calibrated again. A move is said when first found; the figures go to the
// status.
void Pipeline::noteView(std::size_t k) {
  Camera& camera = *cameras_[k];
  const ViewState view = camera.changed_pixels.view();
  const auto before = static_cast<ViewState>(camera.view.load(std::memory_order_relaxed));
  double turn_deg = 0;
  double residual_px = 0;
  const ViewMotion& motion = camera.changed_pixels.motion();
  if (view == ViewState::kMoved) {
    // The turn against the pose the camera has now (re-posed or not), as the check found it.
    const CameraTurn& turn = camera.changed_pixels.turn();
    turn_deg = turn.degrees();
    residual_px = turn.found ? turn.residual_px : motion.residual_px;
  }
  const bool moved = view == ViewState::kMoved;
  camera.view_shift_x_px.store(moved ? motion.shift_x_px : 0, std::memory_order_relaxed);
  camera.view_shift_y_px.store(moved ? motion.shift_y_px : 0, std::memory_order_relaxed);
  camera.view_turn_deg.store(turn_deg, std::memory_order_relaxed);
  camera.view_residual_px.store(residual_px, std::memory_order_relaxed);
  camera.view_checked_us.store(camera.changed_pixels.checkedUs(), std::memory_order_relaxed);
  camera.view.store(static_cast<std::int8_t>(view), std::memory_order_relaxed);
  if (moved && before != ViewState::kMoved) {
    logLine(LogLevel::kWarning,
            "camera %s: its view moved: it turned %.2f degrees on its mount (the image shifted %s "
            "at its centre, %.2f px off a turn alone); its calibration no longer holds, so its "
            "cells count as unseen. If it was turned (not moved along), it is re-posed once its "
            "view has been still for %.0f s; a new background alone would not make it right",
            prepared_.rig.cameras()[k].name.c_str(), turn_deg,
            imageShiftText(motion.shift_x_px, motion.shift_y_px).c_str(), residual_px,
            static_cast<double>(ReposePolicy::kSteadyUs) / 1e6);
  }
}

// Capture thread, every frame: a moved camera steady for long enough starts its re-pose
// (core/repose.h) on the reposer's thread; a re-pose that is ready is installed: the kernel's
// table, the camera the view is checked against, the background and mask. Recaptures are refused
// from when the view is found moved until then (CameraControl::view_moved).
void Pipeline::repose(std::size_t k, const Image& background) {
  Camera& camera = *cameras_[k];
  const RigCamera& rig_camera = prepared_.rig.cameras()[k];
  if (const auto turn = camera.changed_pixels.takeReposeTurn(); turn && !camera.reposer.busy()) {
    const Image& mask = camera.floor_mask != nullptr ? *camera.floor_mask : rig_camera.floor_mask;
    logLine(LogLevel::kNotice,
            "camera %s: its view has been still for %.0f s, moved by a turn of %.2f degrees: "
            "re-posing it (its table is being built; its cells stay unseen until then)",
            rig_camera.name.c_str(), static_cast<double>(ReposePolicy::kSteadyUs) / 1e6,
            turn->norm() * 180 / std::numbers::pi);
    camera.reposer.start(camera.changed_pixels.camera(), *turn, background, mask,
                         prepared_.rig.config().map, prepared_.column_height_m);
  }
  camera.control.view_moved.store(
      camera.reposer.busy() || camera.changed_pixels.view() == ViewState::kMoved,
      std::memory_order_relaxed);
  if (!camera.reposer.busy()) return;
  std::string error;
  std::optional<Reposer::Result> result = camera.reposer.take(error);
  if (!result) {
    if (!error.empty()) {
      logLine(LogLevel::kError, "camera %s: re-posing it failed: %s; it stays left out",
              rig_camera.name.c_str(), error.c_str());
    }
    return;
  }
  kernel_.replaceCamera(k, std::move(result->table));
  ReposedCamera& reposed = result->camera;
  // The people's boxes for the new pose, made on the footprints thread before its first mask.
  if (footprints_) footprints_->reposed(k, kernel_.generation(k), reposed.camera);
  // And the zones' view of the floor hidden behind them: its cells' columns in the new image are
  // made here (3.9 ms for the example's zones, once per knock), so the fusion thread only copies
  // them.
  if (zones_ && zones_->tellsHiddenFloor()) {
    zone_poses_.give(k, kernel_.generation(k), {reposed.camera, zones_->sightsOf(reposed.camera)});
  }
  camera.changed_pixels.reposed(reposed.camera);
  camera.reposed_images.push_back(std::make_unique<Image>(std::move(reposed.background)));
  camera.reposed_background = camera.reposed_images.back().get();
  camera.reposed_images.push_back(std::make_unique<Image>(std::move(reposed.floor_mask)));
  camera.floor_mask = camera.reposed_images.back().get();
  const double degrees = reposed.turn.norm() * 180 / std::numbers::pi;
  camera.reposed_turn_deg.store(degrees, std::memory_order_relaxed);
  camera.reposed_utime.store(hostTimeMicroseconds(), std::memory_order_relaxed);
  camera.reposes.fetch_add(1, std::memory_order_relaxed);
  camera.control.view_moved.store(false, std::memory_order_relaxed);
  // The file's rvec (in its own world frame, WorldFrame), where the camera is OpenCV's.
  const auto* opencv = dynamic_cast<const OpenCvCamera*>(&reposed.camera.model());
  const Eigen::Vector3d rvec = opencv != nullptr
                                   ? opencv->parameters().rvec
                                   : rodriguesFromRotation(reposed.camera.model().pose().rotation);
  const std::string saved = saveReposedCalibration(rig_camera.name, reposed.camera);
  logLine(LogLevel::kNotice,
          "camera %s: re-posed, turned %.2f degrees: its pose is corrected in memory and it is "
          "back in the maps. Its calibration file still has the old pose: the new rotation is "
          "rvec [%.6f, %.6f, %.6f] (OpenCV's Rodrigues vector, world to camera); the whole "
          "calibration %s",
          rig_camera.name.c_str(), degrees, rvec.x(), rvec.y(), rvec.z(), saved.c_str());
}

// A re-posed camera's calibration, in the kind of file it came from, saved to the state directory
// (written aside, then renamed: never a half-written file under the name); what happened, in
// words for the log.
std::string Pipeline::saveReposedCalibration(const std::string& name,
                                             const occmap::Camera& camera) const {
  if (!options_.state_directory) return "is not saved (no state directory)";
  const std::optional<CalibrationText> text = calibrationText(camera.model(), name);
  if (!text) return "is not saved (a lens model occmap cannot write)";
  const std::filesystem::path file =
      *options_.state_directory / ("calibration-" + name + text->extension);
  const std::filesystem::path part =
      *options_.state_directory / (".calibration-" + name + ".part" + text->extension);
  {
    std::ofstream out(part, std::ios::binary | std::ios::trunc);
    out << text->text;
    out.close();
    if (!out) return "is not saved (cannot write " + part.string() + ")";
  }
  std::error_code error;
  std::filesystem::rename(part, file, error);
  if (error) return "is not saved (" + file.string() + ": " + error.message() + ")";
  return "is saved to " + file.string();
}

void Pipeline::loseCamera(std::size_t k, const char* why) {
  Camera& camera = *cameras_[k];
  camera.health.lost();
  camera.last_error.set(why);
  std::uint64_t suppressed = 0;
  if (camera.down_warnings.allow(suppressed)) {
    logLine(LogLevel::kWarning, "camera %s lost: %s; reconnecting (%llu more since)",
            prepared_.rig.cameras()[k].name.c_str(), why,
            static_cast<unsigned long long>(suppressed));
  }
}

void Pipeline::fusionLoop() {
  pollfd wakeup{fusion_wakeup_.fd(), POLLIN, 0};
  while (!stop_fusion_.load(std::memory_order_relaxed)) {
    ::poll(&wakeup, 1, pollTimeoutMs(frame_set_.nextDeadline(), monotonicNanoseconds()));
    fusion_wakeup_.drain();
    // On stop, the cameras have ended: what they left is fused below as a last (complete or
    // not) frame set, so no frame that reached the pipeline is lost without a map.
    const bool last_round = stop_fusion_.load(std::memory_order_relaxed);
    const std::int64_t now = monotonicNanoseconds();
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      Camera& camera = *cameras_[k];
      if (camera.frames.takeLatest())
        frame_set_.frameArrived(k, camera.frames.readBuffer().arrival_ns);
      states_[k] = camera.health.state(now);
      noteState(k, states_[k], now);
    }
    if (frame_set_.shouldFuse(now, states_, last_round)) fuse(now);
    if (last_round) break;
  }
}

// A camera that went silent without its source saying why is said so here (a live camera's own
// thread says it when it gives the device up; a lost one has said why already).
void Pipeline::noteState(std::size_t k, CameraState state, std::int64_t now) {
  if (logged_states_[k] == state) return;
  logged_states_[k] = state;
  Camera& camera = *cameras_[k];
  if (state != CameraState::kDown || camera.health.isLost() ||
      prepared_.rig.cameras()[k].source->isLive()) {
    return;
  }
  char why[96];
  std::snprintf(why, sizeof why, "no frame for %.1f s",
                static_cast<double>(camera.health.silenceNs(now)) / 1e9);
  camera.last_error.set(why);
  std::uint64_t suppressed = 0;
  if (camera.down_warnings.allow(now, suppressed)) {
    logLine(LogLevel::kWarning, "camera %s is down: %s (%llu more since)",
            prepared_.rig.cameras()[k].name.c_str(), why,
            static_cast<unsigned long long>(suppressed));
  }
}

void Pipeline::fuse(std::int64_t now) {
  MapFrame& out = maps_.writeBuffer();
  std::int64_t newest = 0;
  std::int64_t newest_arrival = 0;
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    Camera& camera = *cameras_[k];
    const CapturedFrame& frame = camera.frames.readBuffer();
    // The newest frame of each live camera; one that is late for this set still counts with its
    // previous frame as long as that is recent (a down camera's cells turn unseen instead).
    const bool used =
        frame_set_.uses(k, states_[k], now, camera.health.downAfterNs()) && frame.explained;
    changed_[k] = used ? frame.changed.data() : nullptr;
    generations_[k] = frame.generation;
    out.cameras[k] =
        CameraContribution{states_[k], used, used ? static_cast<std::int64_t>(frame.sequence) : -1,
                           used ? frame.capture_time_us : 0};
    if (used) {
      newest = std::max(newest, frame.capture_time_us);
      newest_arrival = std::max(newest_arrival, frame.arrival_ns);
    }
  }
  const std::int64_t began = monotonicNanoseconds();
  const std::uint64_t fused = kernel_.fuse(changed_, out.map.cells, generations_);
  fusion_times_.record(monotonicNanoseconds() - began);
  // A mask marked under a table a re-pose has replaced since did not count (once, at the switch).
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    if (changed_[k] != nullptr && ((fused >> k) & 1u) == 0) {
      out.cameras[k] = CameraContribution{states_[k], false, -1, 0};
    }
  }
  out.utime = newest != 0 ? newest : hostTimeMicroseconds();
  out.newest_arrival_ns = newest_arrival;
  out.fused = maps_fused_.load(std::memory_order_relaxed);  // fusion alone writes it
  out.time_s = static_cast<double>(now) * 1e-9;
  if (zones_) {
    // A re-posed camera's pose for the zones' hidden floor, with its first frame of that pose (an
    // atomic load a camera until one waits).
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      if (std::optional<ZonePose> pose = zone_poses_.take(k, generations_[k])) {
        zones_->replaceCamera(k, std::move(pose->camera), pose->sights);
      }
    }
    // The people found on a map just before this one (the footprints thread is a map or two
    // behind): enough to tell the floor hidden behind them, not to be trusted once they are old.
    constexpr double kFoundMaxAgeS = 0.1;
    const std::span<const Detection> found = footprints_
                                                 ? footprints_->foundFor(out.time_s, kFoundMaxAgeS)
                                                 : std::span<const Detection>{};
    const std::vector<ZoneStatus>& zones = zones_->update(out.map.cells, out.time_s, found);
    std::copy(zones.begin(), zones.end(), out.zones.begin());
  }
  if (maps_.publish()) maps_skipped_.fetch_add(1, std::memory_order_relaxed);
  publish_wakeup_.signal();
  if (footprints_) {
    // After the map is on its way: its copy for the detector must not delay it. `out` is only
    // read from here on (the publisher reads it too), and fusion writes to it again only after
    // another publish() has handed it back.
    // With each mask the generation of the pose it was marked under: a camera re-posed after a
    // knock counts again once the detector has its boxes for the new pose (repose()).
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      footprint_masks_[k] = ((fused >> k) & 1u) != 0 ? changed_[k] : nullptr;
    }
    footprints_->offer(out.fused, out.utime, out.time_s, footprint_masks_, out.map.cells,
                       generations_);
  }
  frame_set_.fused(now);
  maps_fused_.fetch_add(1, std::memory_order_relaxed);
}

// The one thread that uses the bus: publishes maps as fusion makes them, answers status and
// control requests, publishes the status every status_period.
void Pipeline::publisherLoop() {
  Bus& bus = *bus_;
  const TransportSettings& transport = prepared_.rig.config().transport;
  std::int64_t now = monotonicNanoseconds();
  StatusRequests requests(options_.max_status_answers_per_s, now);
  requests.subscribe(bus, transport.status_channel);
  // Control requests: checked and acted on here (remote_control.h).
  bus.subscribe(controlRequestChannel(transport.status_channel),
                [this, &bus](const std::uint8_t* data, std::size_t size, std::int64_t) {
                  control_->handle(data, size, hostTimeMicroseconds(), bus);
                });
  // Preview requests only move the named cameras' deadlines (previewer.h): nothing is queued, so a
  // flood of them costs no more than their decoding. A request naming no camera of ours is for
  // another daemon on the channel.
  bus.subscribe(cameraPreviewRequestChannel(transport.status_channel),
                [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
                  const std::optional<std::string_view> camera =
                      decodeCameraPreviewRequest(data, size);
                  if (!camera) {
                    ++preview_requests_ignored_;
                    return;
                  }
                  previewer_->requested(*camera, monotonicNanoseconds());
                });
  const std::string preview_channel = cameraPreviewChannel(transport.status_channel);
  StatusPublisher status(transport.status_channel, cameras_.size(), now);
  const std::int64_t status_period_ns = std::chrono::nanoseconds(options_.status_period).count();
  std::int64_t next_status_ns = now;
  auto publishStatus = [&](std::int64_t request_id, std::int64_t at) {
    fillReport(at);
    status.publish(bus, report_, request_id, at);
  };
  auto publishNewestMap = [&] {
    if (maps_.takeLatest()) {
      map_publisher_.publish(bus, maps_.readBuffer());
      publishZones(bus, maps_.readBuffer());
    }
    publishTracks(bus);
  };
  // After the maps: the newest preview of each camera, if the previewer made one since.
  auto publishPreviews = [&] {
    for (std::size_t k = 0; k < previewer_->cameraCount(); ++k) {
      if (const std::vector<std::uint8_t>* preview = previewer_->takeMessage(k)) {
        if (bus.publish(preview_channel, *preview)) {
          previews_published_.fetch_add(1, std::memory_order_relaxed);
        }
      }
    }
  };

  pollfd fds[2] = {{publish_wakeup_.fd(), POLLIN, 0}, {bus.fileno(), POLLIN, 0}};
  while (!stop_publisher_.load(std::memory_order_relaxed)) {
    publisher_rounds_.fetch_add(1, std::memory_order_relaxed);
    ::poll(fds, 2, pollTimeoutMs(next_status_ns, monotonicNanoseconds()));
    if (fds[0].revents & POLLIN) publish_wakeup_.drain();
    publishNewestMap();
    publishPreviews();
    if (fds[1].revents & POLLIN) bus.handleTimeout(0);
    control_->publishReplies(bus);
    now = monotonicNanoseconds();
    requests.answer(now, [&](std::int64_t request_id) { publishStatus(request_id, now); });
    if (now >= next_status_ns) {
      publishStatus(-1, now);
      next_status_ns = now + status_period_ns;
    }
  }
  // Fusion has ended: its last map goes out, then a last status that says the daemon is stopping.
  publishNewestMap();
  publishStatus(-1, monotonicNanoseconds());
  // Subscribers on this very bus (memq://) hear what was sent only when the bus is handled: let
  // them have the last map too.
  while (bus.handleTimeout(0) > 0) {
  }
  if (requests.ignored() > 0) {
    logLine(LogLevel::kInfo, "%llu malformed or excess status requests were ignored",
            static_cast<unsigned long long>(requests.ignored()));
  }
  if (preview_requests_ignored_ > 0) {
    logLine(LogLevel::kInfo, "%llu malformed preview requests were ignored",
            static_cast<unsigned long long>(preview_requests_ignored_));
  }
}

// The status's counters, gathered in place: nothing allocates once the first status was made.
void Pipeline::fillReport(std::int64_t now) {
  report_.state = state_.load(std::memory_order_relaxed);
  report_.uptime_s =
      static_cast<double>(now - options_.daemon_start.time_since_epoch().count()) / 1e9;
  report_.maps_published = map_publisher_.published();
  report_.publish_errors = map_publisher_.errors();
  report_.fusion_p50_ms = fusion_times_.percentileMs(0.50);
  report_.fusion_p99_ms = fusion_times_.percentileMs(0.99);
  report_.control_enabled = control_->enabled();
  report_.control = control_->counts();
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    const Camera& camera = *cameras_[k];
    CameraReport& c = report_.cameras[k];
    c.state = camera.health.state(now);
    c.frames_in = camera.frames_in.load(std::memory_order_relaxed);
    c.frames_dropped = camera.frames_dropped.load(std::memory_order_relaxed);
    c.last_capture_utime = camera.last_capture_us.load(std::memory_order_relaxed);
    const TransportCounters transport = prepared_.rig.cameras()[k].source->transportCounters();
    c.frames_incomplete = transport.frames_incomplete;
    c.missing_packets = transport.missing_packets;
    c.resent_packets = transport.resent_packets;
    c.underruns = transport.underruns;
    c.reconnects = camera.reconnects.load(std::memory_order_relaxed);
    camera.last_error.copyTo(c.last_error);
    c.threshold = camera.control.threshold.load(std::memory_order_relaxed);
    c.background_utime = camera.control.background_utime.load(std::memory_order_relaxed);
    c.lighting_adapt = prepared_.rig.cameras()[k].lighting.adapt;
    c.lighting_gain = camera.lighting_gain.load(std::memory_order_relaxed);
    c.lighting_agreement = camera.lighting_agreement.load(std::memory_order_relaxed);
    c.lighting_explained = !camera.unexplained.load(std::memory_order_relaxed);
    c.unexplained_frames = camera.unexplained_frames.load(std::memory_order_relaxed);
    c.view = camera.view.load(std::memory_order_relaxed);
    c.view_shift_x_px = camera.view_shift_x_px.load(std::memory_order_relaxed);
    c.view_shift_y_px = camera.view_shift_y_px.load(std::memory_order_relaxed);
    c.view_turn_deg = camera.view_turn_deg.load(std::memory_order_relaxed);
    c.view_residual_px = camera.view_residual_px.load(std::memory_order_relaxed);
    c.view_checked_utime = camera.view_checked_us.load(std::memory_order_relaxed);
    c.reposes = camera.reposes.load(std::memory_order_relaxed);
    c.reposed_turn_deg = camera.reposed_turn_deg.load(std::memory_order_relaxed);
    c.reposed_utime = camera.reposed_utime.load(std::memory_order_relaxed);
  }
}

}  // namespace occmap
