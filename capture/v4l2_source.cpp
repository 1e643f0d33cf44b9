// v4l2:///dev/videoN: a Video4Linux2 capture device through the kernel's own interface (open,
// ioctl, mmap, poll on <linux/videodev2.h>), not libv4l2: libv4l2 converts formats in software
// behind the program's back and allocates while doing so, and we want to see what the driver gives.
//
// GREY frames are handed out in place (the dequeued buffer, its rows bytesperline apart) and the
// buffer goes back to the driver at the next read(); YUYV frames are reduced to their luminance in
// a buffer allocated at open. Nothing is allocated or logged per frame.
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "base/clock.h"
#include "capture/frame_numbering.h"
#include "capture/live_source.h"

namespace occmap {
namespace {

// Enough for the driver to fill frames while one is with us, few enough to stay near live.
constexpr unsigned kBufferCount = 4;
// read() never waits longer, so that the capture thread notices a stop (frame_source.h). A driver
// that stalls (streams, yet finishes no frame) is not noticed here: read() says kTimeout, and the
// caller, which decides for every backend how long a silence may last, reopens the device.
constexpr std::int64_t kReadWaitNs = 100'000'000;

std::string errnoText(int number) { return std::strerror(number); }

std::string fourccText(std::uint32_t fourcc) {
  std::string text;
  for (int shift = 0; shift < 32; shift += 8) {
    const char c = static_cast<char>((fourcc >> shift) & 0xFF);
    if (c != ' ') text += c;
  }
  return text;
}

std::string sizeText(std::uint32_t width, std::uint32_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// A control's name as people write it in a config: "Exposure Time, Absolute" becomes
// exposure_time_absolute, the form `v4l2-ctl --list-ctrls` prints.
std::string controlName(std::string_view name) {
  std::string key;
  bool gap = false;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) != 0) {
      if (gap && !key.empty()) key += '_';
      key += static_cast<char>(std::tolower(u));
      gap = false;
    } else {
      gap = true;
    }
  }
  return key;
}

// Names compare without case and without separators, so that ExposureTimeAbsolute,
// exposure_time_absolute and "Exposure Time, Absolute" all name the same control.
std::string nameKey(std::string_view name) {
  std::string key;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) != 0) key += static_cast<char>(std::tolower(u));
  }
  return key;
}

// What the config's `settings` ask of a V4L2 device.
struct V4l2Settings {
  std::uint32_t pixel_format = 0;  // 0: GREY if the device offers it, else YUYV
  std::vector<std::pair<std::string, std::string>> controls;  // in the config's order
};

std::optional<V4l2Settings> parseSettings(
    const std::vector<std::pair<std::string, std::string>>& settings, std::string& error) {
  V4l2Settings parsed;
  for (const auto& [name, value] : settings) {
    if (nameKey(name) != "pixelformat") {
      parsed.controls.emplace_back(name, value);
      continue;
    }
    const std::string format = nameKey(value);
    if (format == "grey" || format == "gray") {
      parsed.pixel_format = V4L2_PIX_FMT_GREY;
    } else if (format == "yuyv") {
      parsed.pixel_format = V4L2_PIX_FMT_YUYV;
    } else {
      error = "pixel_format '" + value + "' is not one occmap reads from V4L2; use GREY or YUYV";
      return std::nullopt;
    }
  }
  return parsed;
}

// Why opening failed: the device is away (absent, unplugged, busy: try again later), or it is
// there and cannot do what the config asks (the config's fault: say so and stop).
enum class OpenOutcome { kOpen, kAway, kRefused };

struct OpenResult {
  OpenOutcome outcome = OpenOutcome::kOpen;
  std::string message;
};

OpenResult opened() { return {}; }

class V4l2Source final : public FrameSource {
 public:
  V4l2Source(std::string device, const LiveSourceOptions& options, V4l2Settings settings)
      : device_(std::move(device)),
        name_(options.name),
        notice_(options.notice),
        fps_asked_(options.fps),
        settings_(std::move(settings)),
        width_(options.width),
        height_(options.height) {}
  ~V4l2Source() override { closeDevice(); }

  int width() const override { return width_; }
  int height() const override { return height_; }
  bool isLive() const override { return true; }
  Status read(Frame& frame) override;
  bool reopen() override;
  TransportCounters transportCounters() const override {
    TransportCounters counters;
    counters.frames_incomplete = frames_incomplete_.load(std::memory_order_relaxed);
    counters.underruns = underruns_.load(std::memory_order_relaxed);
    return counters;
  }

  // Opens the device, negotiates format, rate and controls, and starts streaming.
  OpenResult open();
  // For a device absent at start: the source is kLost, and read() says so with this message.
  void startLost(std::string message) {
    away_ = std::move(message);
    lost(away_);
  }

 private:
  struct Buffer {
    const std::uint8_t* data = nullptr;
    std::size_t length = 0;
  };

  OpenResult away(const std::string& what, int number) const {
    return {OpenOutcome::kAway, device_ + ": " + what + ": " + errnoText(number)};
  }
  OpenResult refused(const std::string& what) const {
    return {OpenOutcome::kRefused, device_ + ": " + what};
  }
  // An ioctl that failed while opening: the device went away (or is busy), or it refused.
  OpenResult failed(const char* request, int number) const {
    if (number == ENODEV || number == ENOENT || number == ENXIO || number == EBUSY ||
        number == EIO || number == ETIMEDOUT) {
      return away(request, number);
    }
    if (number == ENOSPC) {
      // What USB cameras say at STREAMON when the bus has no bandwidth left for the stream.
      return refused(std::string(request) + ": " + errnoText(number) +
                     " (the USB bus has too little bandwidth left: lower the size or rate, or "
                     "move the camera to another USB controller)");
    }
    return refused(std::string(request) + ": " + errnoText(number));
  }

  int xioctl(unsigned long request, void* argument) const {
    int result;
    do {
      result = ::ioctl(fd_, request, argument);
    } while (result == -1 && errno == EINTR);
    return result;
  }

  OpenResult checkCapabilities();
  OpenResult negotiateFormat();
  OpenResult negotiateFrameRate();
  OpenResult applyControls();
  OpenResult startStreaming();
  void closeDevice();
  Status deviceLost(const char* what, int number);
  bool queue(std::uint32_t index);

  // What a person should know that is not an error (a rate or value the driver adjusted): said on
  // each open, which is rare, never per frame.
  void notice(const std::string& message) const {
    if (notice_) notice_("camera " + name_ + ": " + device_ + ": " + message);
  }

  const std::string device_;
  const std::string name_;
  const std::function<void(const std::string&)> notice_;
  const double fps_asked_;
  const V4l2Settings settings_;
  int width_;
  int height_;

  int fd_ = -1;
  std::uint32_t pixel_format_ = 0;
  std::size_t bytes_per_line_ = 0;
  std::size_t frame_bytes_ = 0;  // the bytes a whole frame needs: its last row has no padding
  double fps_ = 0;               // the rate the driver answered (0: it does not say)
  bool buffers_requested_ = false;
  bool streaming_ = false;
  std::vector<Buffer> buffers_;
  int held_ = -1;    // the buffer behind the frame read last, queued again at the next read()
  Image luminance_;  // YUYV frames reduced to their Y bytes
  std::string away_;

  // The driver numbers the frames it captured; a jump means it dropped frames for want of a free
  // buffer (underruns). Counted from 0, going on across reopens.
  FrameNumbering numbering_{DeviceCounter::kV4l2Sequence};

  std::atomic<std::int64_t> frames_incomplete_{0};
  std::atomic<std::int64_t> underruns_{0};
};

OpenResult V4l2Source::open() {
  fd_ = ::open(device_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int number = errno;
    if (number == EACCES || number == EPERM) {
      // Not the config's fault either: udev may not have set the node's group yet after a replug.
      return away("cannot open (the user needs access to the device: the video group)", number);
    }
    return away("cannot open", number);
  }
  for (OpenResult (V4l2Source::*step)() :
       {&V4l2Source::checkCapabilities, &V4l2Source::negotiateFormat,
        &V4l2Source::negotiateFrameRate, &V4l2Source::applyControls, &V4l2Source::startStreaming}) {
    OpenResult result = (this->*step)();
    if (result.outcome != OpenOutcome::kOpen) {
      closeDevice();
      return result;
    }
  }
  return opened();
}

OpenResult V4l2Source::checkCapabilities() {
  v4l2_capability capability{};
  if (xioctl(VIDIOC_QUERYCAP, &capability) != 0) {
    const int number = errno;
    if (number == ENOTTY || number == EINVAL) return refused("is not a Video4Linux2 device");
    return failed("VIDIOC_QUERYCAP", number);
  }
  const std::uint32_t caps = (capability.capabilities & V4L2_CAP_DEVICE_CAPS) != 0
                                 ? capability.device_caps
                                 : capability.capabilities;
  if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0) {
    // USB cameras have a second node for metadata: the hint saves a user some searching.
    return refused(
        "is not a video capture device (a USB camera's second /dev/video node carries only "
        "metadata: try its other node)");
  }
  if ((caps & V4L2_CAP_STREAMING) == 0) {
    return refused("cannot stream through memory-mapped buffers (no V4L2_CAP_STREAMING)");
  }
  return opened();
}

OpenResult V4l2Source::negotiateFormat() {
  std::vector<std::uint32_t> offered;
  for (std::uint32_t index = 0;; ++index) {
    v4l2_fmtdesc description{};
    description.index = index;
    description.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(VIDIOC_ENUM_FMT, &description) != 0) {
      if (errno == EINVAL) break;
      return failed("VIDIOC_ENUM_FMT", errno);
    }
    offered.push_back(description.pixelformat);
  }
  auto offers = [&](std::uint32_t format) {
    return std::find(offered.begin(), offered.end(), format) != offered.end();
  };
  std::string offered_text;
  for (const std::uint32_t format : offered) {
    offered_text += (offered_text.empty() ? "" : ", ") + fourccText(format);
  }
  if (offered_text.empty()) offered_text = "none";
  std::uint32_t wanted = settings_.pixel_format;
  if (wanted == 0) {
    wanted = offers(V4L2_PIX_FMT_GREY) ? V4L2_PIX_FMT_GREY : V4L2_PIX_FMT_YUYV;
    if (!offers(wanted)) {
      return refused("offers the pixel formats " + offered_text +
                     "; occmap reads GREY or YUYV (reduced to luminance)");
    }
  } else if (!offers(wanted)) {
    return refused("pixel_format " + fourccText(wanted) + " is not offered; the device offers " +
                   offered_text);
  }

  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (width_ <= 0 || height_ <= 0) {
    // No size asked: the device's own.
    if (xioctl(VIDIOC_G_FMT, &format) != 0) return failed("VIDIOC_G_FMT", errno);
  } else {
    format.fmt.pix.width = static_cast<std::uint32_t>(width_);
    format.fmt.pix.height = static_cast<std::uint32_t>(height_);
  }
  const std::uint32_t asked_width = format.fmt.pix.width;
  const std::uint32_t asked_height = format.fmt.pix.height;
  format.fmt.pix.pixelformat = wanted;
  format.fmt.pix.field = V4L2_FIELD_NONE;
  format.fmt.pix.bytesperline = 0;  // the driver's choice
  if (xioctl(VIDIOC_S_FMT, &format) != 0) return failed("VIDIOC_S_FMT", errno);
  const v4l2_pix_format& pix = format.fmt.pix;
  if (pix.width == 0 || pix.height == 0) return refused("answered an empty frame size");
  if (pix.pixelformat != wanted) {
    return refused("asked for " + fourccText(wanted) + ", the driver answered " +
                   fourccText(pix.pixelformat));
  }
  if (pix.width != asked_width || pix.height != asked_height) {
    // Drivers adjust a size they cannot do to the nearest they can rather than refuse it.
    return refused("cannot deliver " + sizeText(asked_width, asked_height) +
                   " (the background image's size); the driver gives " +
                   sizeText(pix.width, pix.height) +
                   " instead: make the background at a size the camera supports");
  }
  if (pix.field != V4L2_FIELD_NONE && pix.field != V4L2_FIELD_INTERLACED &&
      pix.field != V4L2_FIELD_INTERLACED_TB && pix.field != V4L2_FIELD_INTERLACED_BT) {
    // Fields delivered one by one or one after the other are not a picture of the scene's rows.
    return refused("delivers separate fields (v4l2_field " + std::to_string(pix.field) +
                   "); occmap needs whole frames");
  }
  const std::size_t pixel_bytes = wanted == V4L2_PIX_FMT_YUYV ? 2 : 1;
  const std::size_t row_bytes = pix.width * pixel_bytes;
  std::size_t bytes_per_line = pix.bytesperline == 0 ? row_bytes : pix.bytesperline;
  if (bytes_per_line < row_bytes) {
    return refused("bytesperline " + std::to_string(pix.bytesperline) +
                   " is shorter than a row of " + std::to_string(pix.width) + " " +
                   fourccText(wanted) + " pixels");
  }
  const std::size_t frame_bytes = bytes_per_line * (pix.height - 1) + row_bytes;
  if (pix.sizeimage < frame_bytes) {
    return refused("sizeimage " + std::to_string(pix.sizeimage) + " is too small for " +
                   std::to_string(pix.height) + " rows of " + std::to_string(bytes_per_line) +
                   " bytes");
  }
  pixel_format_ = wanted;
  width_ = static_cast<int>(pix.width);
  height_ = static_cast<int>(pix.height);
  bytes_per_line_ = bytes_per_line;
  frame_bytes_ = frame_bytes;
  if (pixel_format_ == V4L2_PIX_FMT_YUYV &&
      (luminance_.width() != width_ || luminance_.height() != height_)) {
    luminance_ = Image(width_, height_);
  }
  return opened();
}

OpenResult V4l2Source::negotiateFrameRate() {
  v4l2_streamparm parameters{};
  parameters.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fps_ = 0;
  if (xioctl(VIDIOC_G_PARM, &parameters) != 0) {
    // Many drivers cannot tell their rate; `fps` is for sources that honour it (README).
    if (errno == ENODEV) return away("VIDIOC_G_PARM", errno);
    return opened();
  }
  v4l2_fract& period = parameters.parm.capture.timeperframe;
  const bool settable = (parameters.parm.capture.capability & V4L2_CAP_TIMEPERFRAME) != 0;
  if (fps_asked_ > 0 && settable) {
    // The period as a fraction in milliseconds of a second: exact for 30, 29.97 or 7.5 fps.
    period.numerator = 1000;
    period.denominator = static_cast<std::uint32_t>(fps_asked_ * 1000.0 + 0.5);
    if (xioctl(VIDIOC_S_PARM, &parameters) != 0) return failed("VIDIOC_S_PARM", errno);
  }
  // Whatever was asked, the driver's answer is the rate: it picks the nearest it can do.
  if (period.numerator != 0 && period.denominator != 0) {
    fps_ = static_cast<double>(period.denominator) / static_cast<double>(period.numerator);
  }
  if (fps_asked_ > 0 && !settable) {
    notice("cannot set its frame rate; it runs at its own");
  } else if (fps_asked_ > 0 && std::abs(fps_ - fps_asked_) > 0.01) {
    char text[96];
    std::snprintf(text, sizeof text, "runs at %.4g fps, the nearest it can do to the %.4g asked",
                  fps_, fps_asked_);
    notice(text);
  }
  return opened();
}

OpenResult V4l2Source::applyControls() {
  if (settings_.controls.empty()) return opened();
  std::vector<v4l2_queryctrl> controls;
  v4l2_queryctrl query{};
  query.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  while (xioctl(VIDIOC_QUERYCTRL, &query) == 0) {
    if ((query.flags & V4L2_CTRL_FLAG_DISABLED) == 0 && query.type != V4L2_CTRL_TYPE_CTRL_CLASS) {
      controls.push_back(query);
    }
    query.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  if (errno == ENODEV) return away("VIDIOC_QUERYCTRL", errno);
  if (controls.empty()) {
    // A driver without V4L2_CTRL_FLAG_NEXT_CTRL: ask for the standard controls one by one.
    for (std::uint32_t id = V4L2_CID_BASE; id < V4L2_CID_LASTP1; ++id) {
      v4l2_queryctrl one{};
      one.id = id;
      if (xioctl(VIDIOC_QUERYCTRL, &one) == 0 && (one.flags & V4L2_CTRL_FLAG_DISABLED) == 0) {
        controls.push_back(one);
      }
    }
  }
  for (const auto& [name, value] : settings_.controls) {
    // An init-capture: clang 14 cannot capture a structured binding (C++20's P1091).
    const auto control =
        std::find_if(controls.begin(), controls.end(), [&name = name](const auto& c) {
          return nameKey(reinterpret_cast<const char*>(c.name)) == nameKey(name);
        });
    if (control == controls.end()) {
      std::string names;
      for (const v4l2_queryctrl& c : controls) {
        names += (names.empty() ? "" : ", ") + controlName(reinterpret_cast<const char*>(c.name));
      }
      return refused("has no control '" + name + "'; its controls are: " +
                     (names.empty() ? "none" : names) + " (and the setting pixel_format)");
    }
    const std::string shown = controlName(reinterpret_cast<const char*>(control->name));
    if ((control->flags & V4L2_CTRL_FLAG_READ_ONLY) != 0) {
      return refused("control " + shown + " is read-only");
    }
    if (control->type != V4L2_CTRL_TYPE_INTEGER && control->type != V4L2_CTRL_TYPE_BOOLEAN &&
        control->type != V4L2_CTRL_TYPE_MENU && control->type != V4L2_CTRL_TYPE_INTEGER_MENU) {
      return refused("control " + shown +
                     " is not a number, a switch or a menu: occmap cannot set it");
    }
    std::int64_t number = 0;
    const std::string word = nameKey(value);
    if (control->type == V4L2_CTRL_TYPE_BOOLEAN && (word == "true" || word == "on")) {
      number = 1;
    } else if (control->type == V4L2_CTRL_TYPE_BOOLEAN && (word == "false" || word == "off")) {
      number = 0;
    } else {
      const char* end = value.data() + value.size();
      const auto [at, problem] = std::from_chars(value.data(), end, number);
      if (problem != std::errc() || at != end) {
        return refused("control " + shown + ": '" + value + "' is not a whole number");
      }
    }
    if (number < control->minimum || number > control->maximum) {
      return refused("control " + shown + " = " + value + " is outside the device's range " +
                     std::to_string(control->minimum) + " to " + std::to_string(control->maximum));
    }
    v4l2_control setting{};
    setting.id = control->id;
    setting.value = static_cast<std::int32_t>(number);
    if (xioctl(VIDIOC_S_CTRL, &setting) != 0) {
      const int number_error = errno;
      if (number_error == ENODEV) return away("VIDIOC_S_CTRL", number_error);
      return refused("refused control " + shown + " = " + value + ": " + errnoText(number_error) +
                     ((control->flags & V4L2_CTRL_FLAG_INACTIVE) != 0
                          ? " (the control is inactive: set its automatic mode off first)"
                          : ""));
    }
    // Drivers round a value onto the control's step: read back what it took.
    if (xioctl(VIDIOC_G_CTRL, &setting) == 0 && setting.value != number) {
      notice("control " + shown + " = " + value + " became " + std::to_string(setting.value));
    }
  }
  return opened();
}

OpenResult V4l2Source::startStreaming() {
  v4l2_requestbuffers request{};
  request.count = kBufferCount;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (xioctl(VIDIOC_REQBUFS, &request) != 0) {
    if (errno == EBUSY) return away("busy (another program streams from it)", errno);
    return failed("VIDIOC_REQBUFS", errno);
  }
  buffers_requested_ = true;
  if (request.count < 2) {
    return refused("gave " + std::to_string(request.count) + " buffers; streaming needs two");
  }
  buffers_.assign(request.count, Buffer{});
  for (std::uint32_t index = 0; index < request.count; ++index) {
    v4l2_buffer buffer{};
    buffer.index = index;
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    if (xioctl(VIDIOC_QUERYBUF, &buffer) != 0) return failed("VIDIOC_QUERYBUF", errno);
    if (buffer.length < frame_bytes_) {
      return refused("buffer " + std::to_string(index) + " holds " + std::to_string(buffer.length) +
                     " bytes, less than a frame's " + std::to_string(frame_bytes_));
    }
    void* memory = ::mmap(nullptr, buffer.length, PROT_READ, MAP_SHARED, fd_,
                          static_cast<off_t>(buffer.m.offset));
    if (memory == MAP_FAILED) return failed("mmap", errno);
    buffers_[index] = {static_cast<const std::uint8_t*>(memory), buffer.length};
  }
  for (std::uint32_t index = 0; index < request.count; ++index) {
    if (!queue(index)) return failed("VIDIOC_QBUF", errno);
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(VIDIOC_STREAMON, &type) != 0) return failed("VIDIOC_STREAMON", errno);
  streaming_ = true;
  numbering_.restart();
  started();
  return opened();
}

void V4l2Source::closeDevice() {
  if (fd_ < 0) return;
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(VIDIOC_STREAMOFF, &type);  // fails on a vanished device; the close below still frees
  }
  for (const Buffer& buffer : buffers_) {
    if (buffer.data != nullptr) {
      ::munmap(const_cast<std::uint8_t*>(buffer.data), buffer.length);
    }
  }
  buffers_.clear();
  if (buffers_requested_) {
    // Buffers are freed only once unmapped (hence the order); on a gone device this fails
    // harmlessly.
    v4l2_requestbuffers request{};
    request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = V4L2_MEMORY_MMAP;
    xioctl(VIDIOC_REQBUFS, &request);
  }
  ::close(fd_);
  fd_ = -1;
  held_ = -1;
  streaming_ = false;
  buffers_requested_ = false;
}

bool V4l2Source::queue(std::uint32_t index) {
  v4l2_buffer buffer{};
  buffer.index = index;
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  return xioctl(VIDIOC_QBUF, &buffer) == 0;
}

FrameSource::Status V4l2Source::deviceLost(const char* what, int number) {
  std::string message = device_ + ": " + what;
  if (number != 0) {
    message += ": " + errnoText(number);
    if (number == ENODEV) message += " (unplugged?)";
  }
  closeDevice();
  away_ = message;
  return lost(std::move(message));
}

FrameSource::Status V4l2Source::read(Frame& frame) {
  if (fd_ < 0) return lost(away_);
  if (held_ >= 0) {
    if (!queue(static_cast<std::uint32_t>(held_))) return deviceLost("VIDIOC_QBUF", errno);
    held_ = -1;
  }
  const std::int64_t give_up_ns = monotonicNanoseconds() + kReadWaitNs;
  for (;;) {
    const std::int64_t wait_ns = give_up_ns - monotonicNanoseconds();
    if (wait_ns <= 0) return Status::kTimeout;
    pollfd device{fd_, POLLIN, 0};
    const int ready = ::poll(&device, 1, static_cast<int>((wait_ns + 999'999) / 1'000'000));
    if (ready < 0) {
      if (errno == EINTR) continue;
      return deviceLost("poll", errno);
    }
    if (ready == 0) continue;  // the loop says kTimeout once the wait is over
    if ((device.revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
      // The driver ends the stream with POLLERR when the device goes or fails; an ioctl tells
      // which.
      v4l2_capability capability{};
      const int probe = xioctl(VIDIOC_QUERYCAP, &capability) == 0 ? 0 : errno;
      return deviceLost(probe == ENODEV ? "gone" : "the driver ended the stream (POLLERR)", probe);
    }
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    if (xioctl(VIDIOC_DQBUF, &buffer) != 0) {
      if (errno == EAGAIN) continue;
      return deviceLost("VIDIOC_DQBUF", errno);
    }
    // Damaged frames have their number too: a gap where they were.
    const std::uint64_t number = numbering_.number(buffer.sequence);
    if (numbering_.missed() > 0) {
      underruns_.fetch_add(static_cast<std::int64_t>(numbering_.missed()),
                           std::memory_order_relaxed);
    }
    if (buffer.index >= buffers_.size())
      return deviceLost("VIDIOC_DQBUF gave an unknown buffer", 0);
    const bool damaged = (buffer.flags & V4L2_BUF_FLAG_ERROR) != 0 ||
                         (buffer.bytesused != 0 && buffer.bytesused < frame_bytes_);
    if (damaged) {
      // Dropped and counted; kError lets the daemon count and (rate-limited) report it. The
      // messages fit std::string's inline buffer: no allocation even for damaged frames.
      frames_incomplete_.fetch_add(1, std::memory_order_relaxed);
      if (!queue(buffer.index)) return deviceLost("VIDIOC_QBUF", errno);
      return fail((buffer.flags & V4L2_BUF_FLAG_ERROR) != 0 ? "damaged frame" : "short frame");
    }
    const std::uint8_t* data = buffers_[buffer.index].data;
    if (pixel_format_ == V4L2_PIX_FMT_YUYV) {
      // Y0 U Y1 V: every other byte is a pixel's luminance.
      for (int v = 0; v < height_; ++v) {
        const std::uint8_t* in = data + static_cast<std::size_t>(v) * bytes_per_line_;
        std::uint8_t* out = luminance_.row(v);
        for (int u = 0; u < width_; ++u) out[u] = in[2 * u];
      }
      frame.image = luminance_.view();
    } else {
      frame.image = {data, width_, height_, static_cast<std::ptrdiff_t>(bytes_per_line_)};
    }
    // Either way the buffer goes back at the next read(), so that both paths are one.
    held_ = static_cast<int>(buffer.index);
    frame.sequence = number;
    if ((buffer.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
        (buffer.timestamp.tv_sec != 0 || buffer.timestamp.tv_usec != 0)) {
      // The driver stamps the monotonic clock; the daemon's clock is the wall clock. Taking the
      // offset now rather than once follows any step of the wall clock (NTP) at once.
      timespec wall{}, monotonic{};
      ::clock_gettime(CLOCK_REALTIME, &wall);
      ::clock_gettime(CLOCK_MONOTONIC, &monotonic);
      const std::int64_t offset_us = (wall.tv_sec - monotonic.tv_sec) * 1'000'000LL +
                                     (wall.tv_nsec - monotonic.tv_nsec) / 1000;
      frame.capture_time_us =
          buffer.timestamp.tv_sec * 1'000'000LL + buffer.timestamp.tv_usec + offset_us;
    } else {
      frame.capture_time_us = hostTimeMicroseconds();
    }
    return delivered();
  }
}

// Also while streaming: a stalled driver is brought back by exactly this, a new stream.
bool V4l2Source::reopen() {
  closeDevice();
  OpenResult result = open();
  if (result.outcome == OpenOutcome::kOpen) return true;
  away_ = std::move(result.message);
  lost(away_);
  return false;
}

}  // namespace

std::unique_ptr<FrameSource> openV4l2Source(const std::string& device,
                                            const LiveSourceOptions& options, std::string& error) {
  std::optional<V4l2Settings> settings = parseSettings(options.settings, error);
  if (!settings) return nullptr;
  auto source = std::make_unique<V4l2Source>(device, options, std::move(*settings));
  OpenResult result = source->open();
  switch (result.outcome) {
    case OpenOutcome::kOpen:
      return source;
    case OpenOutcome::kRefused:
      error = std::move(result.message);
      return nullptr;
    case OpenOutcome::kAway:
      break;
  }
  if (options.width <= 0 || options.height <= 0) {
    error = result.message +
            "; without the camera its stream size is unknown: connect it, or give the camera a "
            "background image (its size is the stream's)";
    return nullptr;
  }
  source->startLost(std::move(result.message));
  return source;
}

}  // namespace occmap
