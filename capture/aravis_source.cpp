// aravis://<camera>: GigE Vision and USB3 Vision cameras through Aravis.
//
// The camera is opened by Aravis's device id ("Basler-21945843"), its address (GigE: "10.0.0.5")
// or its serial number; `aravis://` alone takes the first camera Aravis finds. Aravis's own
// receive thread fills a small pool of buffers allocated at (re)connect; read() takes the next
// full one with arv_stream_timeout_pop_buffer and hands it out without a copy (Mono8, Bayer) or
// reduced to luminance into a buffer of its own (RGB, YUV), and gives it back to the stream on the
// next read(). Nothing is allocated per frame.
#include "capture/aravis_source.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include <arv.h>
#include <opencv2/imgproc.hpp>
#include <strings.h>
#include <sys/types.h>
#include <time.h>

#include "base/clock.h"
#include "capture/frame_numbering.h"
#include "capture/live_source.h"

// ThreadSanitizer builds (GCC, clang): see "ThreadSanitizer and Aravis's buffer queues" below.
#if defined(__SANITIZE_THREAD__)
#define OCCMAP_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define OCCMAP_TSAN 1
#endif
#endif

namespace occmap {

// ---------------------------------------------------------------------------------------------
// Pixel formats

std::optional<CameraPixels> cameraPixelsOf(std::uint32_t pixel_format) {
  switch (pixel_format) {
    case ARV_PIXEL_FORMAT_MONO_8:
      return CameraPixels::kMono8;
    case ARV_PIXEL_FORMAT_BAYER_GR_8:
    case ARV_PIXEL_FORMAT_BAYER_RG_8:
    case ARV_PIXEL_FORMAT_BAYER_GB_8:
    case ARV_PIXEL_FORMAT_BAYER_BG_8:
      return CameraPixels::kBayer8;
    case ARV_PIXEL_FORMAT_RGB_8_PACKED:
      return CameraPixels::kRgb8;
    case ARV_PIXEL_FORMAT_BGR_8_PACKED:
      return CameraPixels::kBgr8;
    case ARV_PIXEL_FORMAT_YUV_422_YUYV_PACKED:
      return CameraPixels::kYuv422Yuyv;
    case ARV_PIXEL_FORMAT_YUV_422_PACKED:
      return CameraPixels::kYuv422Uyvy;
    default:
      return std::nullopt;
  }
}

std::string_view cameraPixelsTaken() {
  return "Mono8, BayerRG8 (or GR8, GB8, BG8), RGB8, BGR8, YUV422_8 (YUYV), YUV422Packed (UYVY)";
}

bool isEightBitImage(CameraPixels pixels) {
  return pixels == CameraPixels::kMono8 || pixels == CameraPixels::kBayer8;
}

int bytesPerPixel(CameraPixels pixels) {
  switch (pixels) {
    case CameraPixels::kMono8:
    case CameraPixels::kBayer8:
      return 1;
    case CameraPixels::kRgb8:
    case CameraPixels::kBgr8:
      return 3;
    case CameraPixels::kYuv422Yuyv:
    case CameraPixels::kYuv422Uyvy:
      return 2;
  }
  return 1;
}

void reduceToLuminance(CameraPixels pixels, const std::uint8_t* data, int width, int height,
                       std::ptrdiff_t stride, std::uint8_t* out) {
  // OpenCV only reads through these headers: the casts drop a const it does not need.
  const auto step = static_cast<std::size_t>(stride);
  cv::Mat grey(height, width, CV_8UC1, out);
  switch (pixels) {
    case CameraPixels::kMono8:
    case CameraPixels::kBayer8:
      cv::Mat(height, width, CV_8UC1, const_cast<std::uint8_t*>(data), step).copyTo(grey);
      return;
    case CameraPixels::kRgb8:
      cv::cvtColor(cv::Mat(height, width, CV_8UC3, const_cast<std::uint8_t*>(data), step), grey,
                   cv::COLOR_RGB2GRAY);
      return;
    case CameraPixels::kBgr8:
      cv::cvtColor(cv::Mat(height, width, CV_8UC3, const_cast<std::uint8_t*>(data), step), grey,
                   cv::COLOR_BGR2GRAY);
      return;
    case CameraPixels::kYuv422Yuyv:
      cv::cvtColor(cv::Mat(height, width, CV_8UC2, const_cast<std::uint8_t*>(data), step), grey,
                   cv::COLOR_YUV2GRAY_YUYV);
      return;
    case CameraPixels::kYuv422Uyvy:
      cv::cvtColor(cv::Mat(height, width, CV_8UC2, const_cast<std::uint8_t*>(data), step), grey,
                   cv::COLOR_YUV2GRAY_UYVY);
      return;
  }
}

namespace {

// ---------------------------------------------------------------------------------------------
// Small GLib helpers

std::string takeMessage(GError*& error) {
  std::string text = error != nullptr ? error->message : "unknown error";
  g_clear_error(&error);
  return text;
}

const char* bufferStatusText(ArvBufferStatus status) {
  switch (status) {
    case ARV_BUFFER_STATUS_SUCCESS:
      return "complete";
    case ARV_BUFFER_STATUS_CLEARED:
      return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT:
      return "timed out before all its packets came";
    case ARV_BUFFER_STATUS_MISSING_PACKETS:
      return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
      return "a packet of another frame";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH:
      return "larger than its buffer";
    case ARV_BUFFER_STATUS_FILLING:
      return "still filling";
    case ARV_BUFFER_STATUS_ABORTED:
      return "aborted";
    default:
      return "in an unknown state";
  }
}

// Whether what the camera reports back is what was asked: numbers within rounding, words alike
// (GenICam enumerations and booleans are case-insensitive in practice).
bool sameValue(const std::string& asked, const std::string& got) {
  char* asked_end = nullptr;
  char* got_end = nullptr;
  const double a = std::strtod(asked.c_str(), &asked_end);
  const double b = std::strtod(got.c_str(), &got_end);
  if (!asked.empty() && !got.empty() && *asked_end == '\0' && *got_end == '\0') {
    return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(a));  // float registers
  }
  return ::strcasecmp(asked.c_str(), got.c_str()) == 0;
}

// ---------------------------------------------------------------------------------------------
// Releasing a camera that vanished

// Drops our reference to an Aravis stream or camera, which stops its thread (the stream's receive
// thread, the GigE device's heartbeat thread) and frees it. A function of its own, named in
// tests/tsan.supp: to stop such a thread, GLib's GCancellable wakes it through an eventfd that the
// thread made and then closes, ordered by GLib's futex mutex and poll(), which TSan cannot see.
// TSan's stacks show an instrumented function only where it calls another instrumented one, so
// stopAravisThreads calls dropReference rather than g_object_unref, to be in the stack of what
// GLib does meanwhile.
[[gnu::noinline]] void dropReference(gpointer object) { g_object_unref(object); }
[[gnu::noinline]] void stopAravisThreads(gpointer stream_or_camera) {
  dropReference(stream_or_camera);
}

// Aravis's release of a camera talks to it (stops the stream channel, gives up control) and, when
// the camera is gone, waits out its control-protocol timeouts: 4 to 7 s measured against a killed
// arv-fake-gv-camera. The thread that noticed the loss must not wait that long (its daemon has to
// stop within a second and to reconnect within a few), so such cameras are released here, on a
// thread of their own. Healthy cameras are released in place, so that they stop streaming and
// are free for the next program before this one exits.
class Reaper {
 public:
  static Reaper& instance() {
    // Never destroyed: its thread may still wait on a dead camera when the process exits.
    static Reaper* reaper = new Reaper;
    return *reaper;
  }

  void release(ArvStream* stream, ArvCamera* camera) {
    {
      std::lock_guard lock(mutex_);
      queue_.emplace_back(stream, camera);
    }
    wake_.notify_one();
  }

 private:
  Reaper() {
    std::thread([this] { run(); }).detach();
  }

  void run() {
    for (;;) {
      std::pair<ArvStream*, ArvCamera*> next;
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [this] { return !queue_.empty(); });
        next = queue_.front();
        queue_.pop_front();
      }
      if (next.first != nullptr) stopAravisThreads(next.first);
      if (next.second != nullptr) stopAravisThreads(next.second);
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::pair<ArvStream*, ArvCamera*>> queue_;
};

// ---------------------------------------------------------------------------------------------
// The source

// Shared with Aravis's threads (the receive thread's callbacks, the heartbeat thread's
// control-lost signal), which may outlive the source by a few seconds when a lost camera is
// released on the reaper's thread: they hold a reference of their own.
struct StreamContext {
  std::string camera_name;
  int realtime_priority = 0;             // 0: leave the receive thread's priority alone
  std::atomic<int> realtime_granted{0};  // +1 granted, -1 refused, 0 not yet asked
  std::atomic<bool> control_lost{false};
#ifdef OCCMAP_TSAN
  std::atomic<std::uint64_t> buffers_done{0};  // BUFFER_DONE events so far (awaitBufferDone)
#endif
};

using ContextRef = std::shared_ptr<StreamContext>;

// ThreadSanitizer and Aravis's buffer queues. Buffers go to Aravis's stream thread through
// arv_stream_push_buffer and come back through arv_stream_timeout_pop_buffer: GAsyncQueues, which
// GLib synchronises with futexes of its own in a library built without TSan, so TSan sees no order
// between our use of a buffer and the stream thread's (google/sanitizers#490): it reports Aravis's
// copy of the GigE packets, the fake camera's drawing and our reads of the frame as races, and
// even suppressed, so many (one per frame) that the capture threads stop keeping up. In TSan builds
// occmap therefore tells TSan what the queues guarantee, and nothing more: what this thread did
// before a push happens before the stream thread starts on a buffer (its START_BUFFER event, keyed
// on the stream's context, as that event names no buffer); a popped buffer is read only after the
// stream thread's BUFFER_DONE event for it, which Aravis sends just after queueing it (see
// awaitBufferDone). A real misuse, such as reading a frame after its buffer went back, still races.
// Outside TSan builds none of this exists.
#ifdef OCCMAP_TSAN
extern "C" void __tsan_acquire(void* address);
extern "C" void __tsan_release(void* address);
void tsanHandOver(void* key) { __tsan_release(key); }
void tsanTakeOver(void* key) { __tsan_acquire(key); }
#else
void tsanHandOver(void* /*key*/) {}
void tsanTakeOver(void* /*key*/) {}
#endif

void releaseContextRef(gpointer data, GClosure* /*closure*/) {
  delete static_cast<ContextRef*>(data);
}
void releaseContextRefNotify(gpointer data) { delete static_cast<ContextRef*>(data); }

void onStreamEvent(void* data, ArvStreamCallbackType type, ArvBuffer* /*buffer*/) {
  StreamContext& context = **static_cast<ContextRef*>(data);
  if (type == ARV_STREAM_CALLBACK_TYPE_START_BUFFER) {
    tsanTakeOver(&context);  // the stream thread took a buffer we gave (see tsanHandOver)
    return;
  }
#ifdef OCCMAP_TSAN
  if (type == ARV_STREAM_CALLBACK_TYPE_BUFFER_DONE) {
    context.buffers_done.fetch_add(1, std::memory_order_release);  // see awaitBufferDone
    return;
  }
#endif
  if (type != ARV_STREAM_CALLBACK_TYPE_INIT) return;
  if (context.realtime_priority > 0) {
    // On Aravis's receive thread itself: a missed packet deadline there is a lost frame.
    const bool granted = arv_make_thread_realtime(context.realtime_priority) != 0;
    context.realtime_granted.store(granted ? 1 : -1);
  }
}

void onControlLost(ArvDevice* /*device*/, gpointer data) {
  (*static_cast<ContextRef*>(data))->control_lost.store(true);
}

// A stream setting: "stream.<property>" names a property of Aravis's stream object (for GigE
// Vision: socket-buffer, socket-buffer-size, packet-resend, packet-timeout, frame-retention,
// initial-packet-timeout, packet-request-ratio; '_' may stand for '-'). Two are occmap's own:
// stream.realtime_priority (SCHED_FIFO priority of the receive thread) and stream.packet_socket.
struct Setting {
  std::string name;
  std::string value;
  bool isStream() const { return name.rfind("stream.", 0) == 0; }
  std::string streamProperty() const {
    std::string property = name.substr(7);
    std::replace(property.begin(), property.end(), '_', '-');
    return property;
  }
};

class AravisSource final : public FrameSource {
 public:
  static constexpr int kBuffers = 8;
  static constexpr guint64 kWaitUs = 100'000;  // read() waits no longer, so a stop is seen

  AravisSource(std::string device, const LiveSourceOptions& options)
      : device_(std::move(device)), options_(options) {
    width_ = options.width;
    height_ = options.height;
    for (const auto& [name, value] : options.settings) settings_.push_back({name, value});
  }

  ~AravisSource() override { disconnect(); }

  // Opens the camera and starts it streaming. False with `error` when it cannot; `config_error`
  // then says whether the config is at fault (a setting refused, a format occmap cannot take) or
  // the camera is just not there.
  bool connect(std::string& error, bool& config_error) {
    config_error = false;
    GError* gerror = nullptr;
    ArvCamera* camera = arv_camera_new(device_.empty() ? nullptr : device_.c_str(), &gerror);
    if (camera == nullptr && !device_.empty()) {
      // Perhaps a serial number: Aravis knows cameras by id and address, people by their label.
      g_clear_error(&gerror);
      const std::string id = idOfSerial(device_);
      if (!id.empty()) camera = arv_camera_new(id.c_str(), &gerror);
    }
    if (camera == nullptr) {
      error = "camera '" + (device_.empty() ? std::string("(the first one)") : device_) +
              "' not found: " + takeMessage(gerror) +
              " (arv-tool-0.8 lists the cameras Aravis sees)";
      return false;
    }
    camera_ = camera;
    // A value outside a feature's bounds is refused (and named) rather than written as it is.
    arv_camera_set_range_check_policy(camera_, ARV_RANGE_CHECK_POLICY_ENABLE);
    if (!configure(error, config_error) || !startStream(error, config_error)) {
      releaseNow(false);
      return false;
    }
    silent_ = false;
    numbering_.restart();
    started();
    return true;
  }

  // The camera is not there yet: the source is kLost, read() says why, the daemon keeps trying.
  void startLost(std::string why) {
    pending_loss_ = std::move(why);
    lost(pending_loss_);
  }

  int width() const override { return width_; }
  int height() const override { return height_; }
  bool isLive() const override { return true; }

  Status read(Frame& frame) override {
    if (held_ != nullptr) {
      giveBack(held_);  // the previous frame's buffer goes back to Aravis
      held_ = nullptr;
    }
    if (stream_ == nullptr) return lost(pending_loss_.empty() ? "not connected" : pending_loss_);
    if (!acquiring_) {
      // Started by the reader, not at open: between the two the daemon builds its tables, and
      // frames taken then would only be stale ones in a burst (and underruns meanwhile).
      GError* gerror = nullptr;
      arv_camera_start_acquisition(camera_, &gerror);
      if (gerror != nullptr) return lost("the camera did not start: " + takeMessage(gerror));
      acquiring_ = true;
    }
    reportRealtime();
    if (context_->control_lost.load()) {
      return lost(
          "control of the camera was lost (unplugged, powered off, or the network is down)");
    }
    ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_, kWaitUs);
    if (buffer != nullptr) awaitBufferDone();
    updateCounters();
    // However long the camera is silent, that is the caller's to judge (frame_source.h); only how
    // it will be released depends on it (see disconnect).
    silent_ = buffer == nullptr;
    if (buffer == nullptr) return Status::kTimeout;
    const ArvBufferStatus status = arv_buffer_get_status(buffer);
    const std::uint64_t frame_id = arv_buffer_get_frame_id(buffer);
    // A damaged frame keeps its number (a gap where it was) when its id is the camera's: it came
    // with a leader, even if packets are missing. A buffer Aravis never filled has no id to count.
    const bool numbered =
        status == ARV_BUFFER_STATUS_SUCCESS || status == ARV_BUFFER_STATUS_MISSING_PACKETS ||
        status == ARV_BUFFER_STATUS_TIMEOUT || status == ARV_BUFFER_STATUS_SIZE_MISMATCH;
    const std::uint64_t number = numbered ? numbering_.number(frame_id) : 0;
    if (status != ARV_BUFFER_STATUS_SUCCESS) {
      giveBack(buffer);
      return fail("frame " + std::to_string(static_cast<unsigned long long>(frame_id)) +
                  " arrived " + bufferStatusText(status));
    }
    std::size_t received = 0;  // unused: not every stream fills it in (the in-process fake)
    const auto* data =
        static_cast<const std::uint8_t*>(arv_buffer_get_image_data(buffer, &received));
    const int width = arv_buffer_get_image_width(buffer);
    const int height = arv_buffer_get_image_height(buffer);
    const ArvPixelFormat format = arv_buffer_get_image_pixel_format(buffer);
    gint padding_x = 0;
    gint padding_y = 0;
    arv_buffer_get_image_padding(buffer, &padding_x, &padding_y);
    const std::ptrdiff_t stride =
        static_cast<std::ptrdiff_t>(width) * bytesPerPixel(pixels_) + padding_x;
    // What the buffer holds must be the stream's geometry and fit the pool's buffers (sized for it
    // at connect). Aravis's own status already refused frames larger than their buffer.
    const std::size_t needed =
        static_cast<std::size_t>(stride) * static_cast<std::size_t>(height - 1) +
        static_cast<std::size_t>(width) * static_cast<std::size_t>(bytesPerPixel(pixels_));
    if (data == nullptr || width != width_ || height != height_ || format != pixel_format_ ||
        needed > payload_) {
      giveBack(buffer);
      return fail("a frame of " + std::to_string(width) + "x" + std::to_string(height) +
                  " in pixel format 0x" + hex(format) + ", not the stream's " +
                  std::to_string(width_) + "x" + std::to_string(height_) + " in 0x" +
                  hex(pixel_format_));
    }
    if (isEightBitImage(pixels_)) {
      frame.image = ImageView{data, width, height, stride};
      held_ = buffer;  // handed out as it is: back to the stream on the next read()
    } else {
      reduceToLuminance(pixels_, data, width, height, stride, luminance_.data());
      frame.image = luminance_.view();
    }
    frame.sequence = number;
    // Aravis stamps each frame with the host's wall clock when its first packet arrived.
    const guint64 system_ns = arv_buffer_get_system_timestamp(buffer);
    frame.capture_time_us =
        system_ns != 0 ? static_cast<std::int64_t>(system_ns / 1000) : hostTimeMicroseconds();
    frame.device_time_ns = arv_buffer_get_timestamp(buffer);
    frame.device_frame_id = frame_id;
    if (held_ == nullptr) giveBack(buffer);
    return delivered();
  }

  // Also while streaming: the caller reopens a camera that went silent without a word from Aravis.
  bool reopen() override {
    disconnect();
    std::string error;
    bool config_error = false;
    if (!connect(error, config_error)) {
      // Said once per kind of failure, not at every try.
      if (error != last_reopen_error_) notice("reconnecting: " + error);
      last_reopen_error_ = error;
      pending_loss_ = error;
      lost(error);
      return false;
    }
    last_reopen_error_.clear();
    pending_loss_.clear();
    return true;
  }

  TransportCounters transportCounters() const override {
    TransportCounters counters;
    counters.frames_incomplete = failures_.load(std::memory_order_relaxed);
    counters.missing_packets = missing_.load(std::memory_order_relaxed);
    counters.resent_packets = resent_.load(std::memory_order_relaxed);
    counters.underruns = underruns_.load(std::memory_order_relaxed);
    return counters;
  }

 private:
  // A buffer back to the stream's pool, to be filled by Aravis's stream thread.
  void giveBack(ArvBuffer* buffer) {
    tsanHandOver(context_.get());
    arv_stream_push_buffer(stream_, buffer);
  }

  // TSan builds: the stream thread queues a filled buffer and then sends its BUFFER_DONE (the GigE,
  // fake and USB3 streams alike), one buffer at a time, so the n-th buffer popped since connecting
  // is the n-th BUFFER_DONE. Waiting for that event, an atomic TSan sees, orders everything the
  // stream thread did to the buffer before our reads of it. It takes microseconds; should Aravis
  // ever queue a buffer without the event, the wait gives up after 20 ms and catches up.
  void awaitBufferDone() {
#ifdef OCCMAP_TSAN
    ++buffers_popped_;
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(20);
    while (context_->buffers_done.load(std::memory_order_acquire) < buffers_popped_) {
      if (std::chrono::steady_clock::now() > give_up) {
        buffers_popped_ = context_->buffers_done.load(std::memory_order_acquire);
        break;
      }
      std::this_thread::yield();
    }
#endif
  }

  static std::string hex(std::uint32_t value) {
    char text[16];
    std::snprintf(text, sizeof text, "%08x", value);
    return text;
  }

  static std::string number(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", value);
    return text;
  }

  static std::string idOfSerial(const std::string& serial) {
    arv_update_device_list();
    for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
      const char* number = arv_get_device_serial_nbr(i);
      if (number != nullptr && serial == number) return arv_get_device_id(i);
    }
    return {};
  }

  void notice(const std::string& message) const {
    const std::string line = "camera " + options_.name + ": " + message;
    if (options_.notice) {
      options_.notice(line);
    } else {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
  }

  // A setting the camera refused: on the first connection the config is at fault; on a later
  // one (the camera came back different) it is only said, and the connection fails.
  bool refuse(std::string& error, bool& config_error, std::string message) {
    error = std::move(message);
    config_error = first_connection_;
    return false;
  }

  ArvGcFeatureNode* feature(const std::string& name) {
    ArvGcNode* node = arv_device_get_feature(arv_camera_get_device(camera_), name.c_str());
    return node != nullptr && ARV_IS_GC_FEATURE_NODE(node) ? ARV_GC_FEATURE_NODE(node) : nullptr;
  }

  // Sets one GenICam feature and reads back what the camera took.
  bool applyFeature(const std::string& name, const std::string& value, std::string& error,
                    bool& config_error) {
    ArvGcFeatureNode* node = feature(name);
    if (node == nullptr) {
      return refuse(error, config_error,
                    "setting '" + name + "': the camera has no such feature (arv-tool-0.8 -n '" +
                        device_ + "' features lists them)");
    }
    GError* gerror = nullptr;
    arv_gc_feature_node_set_value_from_string(node, value.c_str(), &gerror);
    if (gerror != nullptr) {
      return refuse(error, config_error,
                    "setting " + name + ": " + value + " refused: " + takeMessage(gerror));
    }
    const char* took = arv_gc_feature_node_get_value_as_string(node, &gerror);
    if (gerror != nullptr || took == nullptr) {
      g_clear_error(&gerror);
      return true;  // write-only (a command): nothing to compare
    }
    if (!sameValue(value, took)) {
      notice("setting " + name + ": asked " + value + ", the camera took " + took);
    }
    return true;
  }

  bool configure(std::string& error, bool& config_error) {
    GError* gerror = nullptr;
    // What must come first: the pixel format and binning decide which sizes are possible.
    static constexpr const char* kFirst[] = {"PixelFormat", "BinningHorizontal", "BinningVertical",
                                             "DecimationHorizontal", "DecimationVertical"};
    auto isFirst = [](const std::string& name) {
      return std::any_of(std::begin(kFirst), std::end(kFirst),
                         [&](const char* first) { return name == first; });
    };
    for (const Setting& s : settings_) {
      if (!s.isStream() && isFirst(s.name) && !applyFeature(s.name, s.value, error, config_error))
        return false;
    }
    // The stream's size is the background's: the camera must deliver it.
    if (width_ > 0 && height_ > 0) {
      for (const auto& [name, size] : {std::pair{"Width", width_}, std::pair{"Height", height_}}) {
        arv_camera_set_integer(camera_, name, size, &gerror);
        if (gerror != nullptr) {
          return refuse(
              error, config_error,
              std::string(name) + " " + std::to_string(size) +
                  " (the background image's) refused by the camera: " + takeMessage(gerror));
        }
      }
    }
    for (const Setting& s : settings_) {
      if (!s.isStream() && !isFirst(s.name) && !applyFeature(s.name, s.value, error, config_error))
        return false;
    }
    if (options_.fps > 0) {
      arv_camera_set_frame_rate(camera_, options_.fps, &gerror);
      if (gerror != nullptr) {
        notice("fps " + number(options_.fps) + " not set: " + takeMessage(gerror));
      } else {
        const double took = arv_camera_get_frame_rate(camera_, &gerror);
        g_clear_error(&gerror);
        // Cameras round the rate to their clock: a thousandth off is what was asked.
        if (std::abs(took - options_.fps) > 1e-3 * options_.fps) {
          notice("fps: asked " + number(options_.fps) + ", the camera runs at " + number(took));
        }
      }
    }
    // What the camera will send, as it says now.
    gint x = 0, y = 0, width = 0, height = 0;
    arv_camera_get_region(camera_, &x, &y, &width, &height, &gerror);
    if (gerror != nullptr) {
      return refuse(error, config_error, "cannot read the camera's region: " + takeMessage(gerror));
    }
    if (width_ > 0 && (width != width_ || height != height_)) {
      return refuse(error, config_error,
                    "the camera sends " + std::to_string(width) + "x" + std::to_string(height) +
                        " but the background is " + std::to_string(width_) + "x" +
                        std::to_string(height_));
    }
    width_ = width;
    height_ = height;
    pixel_format_ = arv_camera_get_pixel_format(camera_, &gerror);
    g_clear_error(&gerror);
    std::optional<CameraPixels> pixels = cameraPixelsOf(pixel_format_);
    const bool format_asked = std::any_of(settings_.begin(), settings_.end(),
                                          [](const Setting& s) { return s.name == "PixelFormat"; });
    if (!pixels && !format_asked) {
      // The camera's own default is one occmap cannot take: Mono8 is the natural choice.
      arv_camera_set_pixel_format(camera_, ARV_PIXEL_FORMAT_MONO_8, &gerror);
      g_clear_error(&gerror);
      pixel_format_ = arv_camera_get_pixel_format(camera_, &gerror);
      g_clear_error(&gerror);
      pixels = cameraPixelsOf(pixel_format_);
    }
    if (!pixels) {
      const char* name = arv_camera_get_pixel_format_as_string(camera_, &gerror);
      g_clear_error(&gerror);
      return refuse(error, config_error,
                    std::string("pixel format ") + (name != nullptr ? name : "?") +
                        " is not one occmap takes: " + std::string(cameraPixelsTaken()) +
                        "; set settings: {PixelFormat: Mono8}");
    }
    pixels_ = *pixels;
    if (!isEightBitImage(pixels_)) luminance_ = Image(width_, height_);
    return true;
  }

  bool setStreamProperty(const Setting& s, std::string& error, bool& config_error) {
    const std::string property = s.streamProperty();
    GObjectClass* object_class = G_OBJECT_GET_CLASS(stream_);
    GParamSpec* spec = g_object_class_find_property(object_class, property.c_str());
    if (spec == nullptr || (spec->flags & G_PARAM_WRITABLE) == 0) {
      return refuse(error, config_error,
                    "setting '" + s.name + "': this camera's stream has no such property (" +
                        (arv_camera_is_gv_device(camera_) != 0
                             ? "GigE Vision: socket_buffer, socket_buffer_size, packet_resend, "
                               "packet_timeout, frame_retention, initial_packet_timeout, "
                               "packet_request_ratio"
                             : "USB3 Vision streams have none") +
                        ")");
    }
    GValue value = G_VALUE_INIT;
    g_value_init(&value, spec->value_type);
    bool parsed = true;
    char* end = nullptr;
    errno = 0;
    if (G_TYPE_IS_ENUM(spec->value_type)) {
      auto* enums = static_cast<GEnumClass*>(g_type_class_ref(spec->value_type));
      const GEnumValue* entry = g_enum_get_value_by_nick(enums, s.value.c_str());
      if (entry != nullptr) g_value_set_enum(&value, entry->value);
      parsed = entry != nullptr;
      g_type_class_unref(enums);
    } else if (spec->value_type == G_TYPE_INT) {
      const long number = std::strtol(s.value.c_str(), &end, 10);
      parsed = *end == '\0' && errno == 0 && number >= G_MININT && number <= G_MAXINT;
      g_value_set_int(&value, static_cast<gint>(number));
    } else if (spec->value_type == G_TYPE_UINT) {
      const unsigned long number = std::strtoul(s.value.c_str(), &end, 10);
      parsed = *end == '\0' && errno == 0 && number <= G_MAXUINT && s.value[0] != '-';
      g_value_set_uint(&value, static_cast<guint>(number));
    } else if (spec->value_type == G_TYPE_DOUBLE) {
      g_value_set_double(&value, std::strtod(s.value.c_str(), &end));
      parsed = *end == '\0';
    } else if (spec->value_type == G_TYPE_BOOLEAN) {
      parsed = s.value == "true" || s.value == "false";
      g_value_set_boolean(&value, s.value == "true");
    } else {
      parsed = false;
    }
    if (parsed) {
      GValue check = G_VALUE_INIT;
      g_value_init(&check, spec->value_type);
      g_value_copy(&value, &check);
      parsed = !g_param_value_validate(spec, &check);  // true when it had to be changed
      g_value_unset(&check);
    }
    if (!parsed) {
      g_value_unset(&value);
      std::string allowed;
      if (G_TYPE_IS_ENUM(spec->value_type)) {
        auto* enums = static_cast<GEnumClass*>(g_type_class_ref(spec->value_type));
        for (guint i = 0; i < enums->n_values; ++i) {
          allowed += (i ? ", " : "") + std::string(enums->values[i].value_nick);
        }
        g_type_class_unref(enums);
      } else {
        allowed = g_type_name(spec->value_type);
      }
      return refuse(error, config_error,
                    "setting " + s.name + ": '" + s.value + "' is not valid (" + allowed + ")");
    }
    g_object_set_property(G_OBJECT(stream_), property.c_str(), &value);
    g_value_unset(&value);
    return true;
  }

  bool startStream(std::string& error, bool& config_error) {
    GError* gerror = nullptr;
    ArvDevice* device = arv_camera_get_device(camera_);
    auto context = std::make_shared<StreamContext>();
    context->camera_name = options_.name;
    for (const Setting& s : settings_) {
      if (s.name == "stream.realtime_priority") {
        char* end = nullptr;
        const long priority = std::strtol(s.value.c_str(), &end, 10);
        if (*end != '\0' || priority < 1 || priority > 99) {
          return refuse(error, config_error,
                        "setting stream.realtime_priority: '" + s.value +
                            "' must be a SCHED_FIFO priority from 1 to 99");
        }
        context->realtime_priority = static_cast<int>(priority);
      } else if (s.name == "stream.packet_socket") {
        if (s.value != "true" && s.value != "false") {
          return refuse(error, config_error, "setting stream.packet_socket: true or false");
        }
        if (s.value == "false" && ARV_IS_GV_DEVICE(device)) {
          arv_gv_device_set_stream_options(ARV_GV_DEVICE(device),
                                           ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
        }
      }
    }
    stream_ = arv_camera_create_stream_full(camera_, onStreamEvent, new ContextRef(context),
                                            releaseContextRefNotify, &gerror);
    if (stream_ == nullptr) {
      error = "cannot open the camera's stream: " + takeMessage(gerror);
      return false;
    }
    context_ = context;
#ifdef OCCMAP_TSAN
    buffers_popped_ = 0;  // a new stream counts its BUFFER_DONE events from 0
#endif
    for (const Setting& s : settings_) {
      if (s.isStream() && s.name != "stream.realtime_priority" &&
          s.name != "stream.packet_socket" && !setStreamProperty(s, error, config_error))
        return false;
    }
    const guint payload = arv_camera_get_payload(camera_, &gerror);
    if (gerror != nullptr || payload == 0) {
      error = "cannot read the camera's payload size: " + takeMessage(gerror);
      return false;
    }
    payload_ = payload;
    for (int i = 0; i < kBuffers; ++i) giveBack(arv_buffer_new_allocate(payload));
    control_lost_handler_ =
        g_signal_connect_data(device, "control-lost", G_CALLBACK(onControlLost),
                              new ContextRef(context), releaseContextRef, GConnectFlags{});
    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &gerror);
    g_clear_error(&gerror);  // some cameras have only continuous acquisition
    first_connection_ = false;
    acquiring_ = false;  // the first read() starts it (see there)
    return true;
  }

  void reportRealtime() {
    const int granted = context_->realtime_granted.exchange(0);
    if (granted < 0) {
      notice("realtime priority " + std::to_string(context_->realtime_priority) +
             " for Aravis's receive thread refused: the service needs LimitRTPRIO= (see "
             "systemd/occmapd-realtime.conf)");
    } else if (granted > 0) {
      notice("Aravis's receive thread runs at realtime priority " +
             std::to_string(context_->realtime_priority));
    }
  }

  void updateCounters() {
    guint64 completed = 0, failures = 0, underruns = 0;
    arv_stream_get_statistics(stream_, &completed, &failures, &underruns);
    guint64 resent = 0, missing = 0;
    if (ARV_IS_GV_STREAM(stream_))
      arv_gv_stream_get_statistics(ARV_GV_STREAM(stream_), &resent, &missing);
    stream_counts_ = {static_cast<std::int64_t>(failures), static_cast<std::int64_t>(missing),
                      static_cast<std::int64_t>(resent), static_cast<std::int64_t>(underruns)};
    failures_.store(base_.frames_incomplete + stream_counts_.frames_incomplete,
                    std::memory_order_relaxed);
    missing_.store(base_.missing_packets + stream_counts_.missing_packets,
                   std::memory_order_relaxed);
    resent_.store(base_.resent_packets + stream_counts_.resent_packets, std::memory_order_relaxed);
    underruns_.store(base_.underruns + stream_counts_.underruns, std::memory_order_relaxed);
  }

  // Lets go of the camera. One that still answers is stopped and released here; one that is gone
  // (or silent) goes to the reaper, so that this thread can go on at once.
  void releaseNow(bool answering) {
    if (held_ != nullptr) {
      g_object_unref(held_);
      held_ = nullptr;
    }
    if (camera_ != nullptr && control_lost_handler_ != 0) {
      g_signal_handler_disconnect(arv_camera_get_device(camera_), control_lost_handler_);
    }
    control_lost_handler_ = 0;
    // An in-process fake camera answers whatever happened, and released in place its thread is
    // gone with the source (a program that draws into the fake camera relies on that).
    if (camera_ != nullptr && ARV_IS_FAKE_DEVICE(arv_camera_get_device(camera_))) answering = true;
    if (answering) {
      if (stream_ != nullptr && acquiring_) arv_camera_stop_acquisition(camera_, nullptr);
      if (stream_ != nullptr) stopAravisThreads(stream_);
      if (camera_ != nullptr) stopAravisThreads(camera_);
    } else if (stream_ != nullptr || camera_ != nullptr) {
      Reaper::instance().release(stream_, camera_);
    }
    stream_ = nullptr;
    camera_ = nullptr;
    acquiring_ = false;
  }

  void disconnect() {
    if (camera_ == nullptr) return;
    if (stream_ != nullptr) {
      updateCounters();
      base_.frames_incomplete += stream_counts_.frames_incomplete;
      base_.missing_packets += stream_counts_.missing_packets;
      base_.resent_packets += stream_counts_.resent_packets;
      base_.underruns += stream_counts_.underruns;
      stream_counts_ = {};
    }
    // Answering: control not lost, and the last wait for a frame was not in vain (or none was made
    // yet). A camera released after silence is most likely dead: the reaper waits for it.
    const bool answering = !context_ || (!context_->control_lost.load() && !silent_);
    releaseNow(answering);
  }

  std::string device_;
  LiveSourceOptions options_;
  std::vector<Setting> settings_;
  int width_ = 0;
  int height_ = 0;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  ArvBuffer* held_ = nullptr;  // handed out by the last read(), back to the stream at the next
  ArvPixelFormat pixel_format_ = 0;
  std::size_t payload_ = 0;  // bytes of each buffer of the pool
  CameraPixels pixels_ = CameraPixels::kMono8;
  Image luminance_;  // for formats that need converting
  std::shared_ptr<StreamContext> context_;
  gulong control_lost_handler_ = 0;
  bool first_connection_ = true;
  bool acquiring_ = false;
  std::string pending_loss_;
  std::string last_reopen_error_;
  bool silent_ = false;  // the last read() waited in vain
  // The camera's frame ids, counted from 0 and on across reconnects (frame_numbering.h).
  FrameNumbering numbering_{DeviceCounter::kGenicamFrameId};
#ifdef OCCMAP_TSAN
  std::uint64_t buffers_popped_ = 0;  // since the last connect (awaitBufferDone)
#endif
  // Stream statistics: those of earlier connections, and this one's as last read.
  TransportCounters base_;
  TransportCounters stream_counts_;
  std::atomic<std::int64_t> failures_{0};
  std::atomic<std::int64_t> missing_{0};
  std::atomic<std::int64_t> resent_{0};
  std::atomic<std::int64_t> underruns_{0};
};

}  // namespace

std::unique_ptr<FrameSource> openAravisSource(const std::string& device,
                                              const LiveSourceOptions& options,
                                              std::string& error) {
  auto source = std::make_unique<AravisSource>(device, options);
  bool config_error = false;
  if (source->connect(error, config_error)) return source;
  if (config_error) return nullptr;
  if (options.width <= 0 || options.height <= 0) {
    error += "; without its background image the stream's size is unknown";
    return nullptr;
  }
  // Not there now: the daemon starts anyway and connects when the camera appears.
  if (options.notice) options.notice("camera " + options.name + ": " + error + "; waiting for it");
  source->startLost(error);
  return source;
}

}  // namespace occmap
