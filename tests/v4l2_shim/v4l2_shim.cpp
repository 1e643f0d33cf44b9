// A V4L2 capture device in user space, for tests on machines where no kernel video device can
// exist (no vivid module, no root over the kernel). Preloaded (LD_PRELOAD), it serves the path in
// OCCMAP_V4L2_SHIM_DEVICE: open() returns a memfd, the ioctls on it answer as a capture driver
// built on videobuf2 answers (formats adjusted to what the "sensor" can do, MMAP buffers at page
// aligned offsets in the memfd, so the program's mmap is real memory), frames become ready by the
// clock at the frame rate, and poll() waits for the next one. Everything else passes through to
// the C library. v4l2_shim.h lists the variables that shape the device.
//
// Where a real driver is stricter or looser than this one, the shim follows videobuf2 (EBUSY for
// freeing mapped buffers or changing the format while buffers exist, POLLERR when not streaming,
// POLLERR|POLLHUP|POLLPRI and ENODEV once unplugged).

// The fortified headers define open() and poll() inline; this file defines the real symbols.
#undef _FORTIFY_SOURCE

#include "v4l2_shim.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <dlfcn.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#define OCCMAP_SHIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

using namespace occmap::v4l2_shim;

// The C library's function of that name, found past this library.
template <typename Function>
Function next(const char* name) {
  void* symbol = ::dlsym(RTLD_NEXT, name);
  Function function;
  static_assert(sizeof function == sizeof symbol);
  std::memcpy(&function, &symbol, sizeof function);
  return function;
}

std::int64_t monotonicNs() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return now.tv_sec * 1'000'000'000LL + now.tv_nsec;
}

void sleepNs(std::int64_t ns) {
  if (ns <= 0) return;
  timespec pause{ns / 1'000'000'000, ns % 1'000'000'000};
  ::nanosleep(&pause, nullptr);
}

bool fileExists(const std::string& path) {
  return !path.empty() && ::access(path.c_str(), F_OK) == 0;
}

std::string environment(const char* name, const char* fallback = "") {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : fallback;
}

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::size_t from = 0;
  while (from <= text.size()) {
    const std::size_t comma = std::min(text.find(',', from), text.size());
    if (comma > from) parts.push_back(text.substr(from, comma - from));
    from = comma + 1;
  }
  return parts;
}

std::uint32_t fourcc(const std::string& text) {
  char c[4] = {' ', ' ', ' ', ' '};
  for (std::size_t i = 0; i < 4 && i < text.size(); ++i) c[i] = text[i];
  return v4l2_fourcc(c[0], c[1], c[2], c[3]);
}

struct Size {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
};

// What the device is, from the environment when it is plugged in.
struct DeviceConfig {
  std::vector<std::uint32_t> formats;
  std::vector<Size> sizes;
  std::uint32_t padding = 0;
  std::vector<std::uint32_t> rates;
  std::uint64_t error_every = 0;
  std::string unplug_file;
  std::string stall_file;
  bool streaming = true;
};

DeviceConfig configFromEnvironment() {
  DeviceConfig config;
  for (const std::string& name : split(environment(kFormatsVariable, "GREY,YUYV"))) {
    config.formats.push_back(fourcc(name));
  }
  for (const std::string& size : split(environment(kSizesVariable, "640x480,320x240"))) {
    Size parsed;
    parsed.width = static_cast<std::uint32_t>(std::strtoul(size.c_str(), nullptr, 10));
    const std::size_t x = size.find('x');
    if (x != std::string::npos) {
      parsed.height = static_cast<std::uint32_t>(std::strtoul(size.c_str() + x + 1, nullptr, 10));
    }
    if (parsed.width > 0 && parsed.height > 0) config.sizes.push_back(parsed);
  }
  for (const std::string& rate : split(environment(kRatesVariable, "30,60"))) {
    const auto parsed = static_cast<std::uint32_t>(std::strtoul(rate.c_str(), nullptr, 10));
    if (parsed > 0) config.rates.push_back(parsed);
  }
  if (config.formats.empty()) config.formats.push_back(V4L2_PIX_FMT_GREY);
  if (config.sizes.empty()) config.sizes.push_back({640, 480});
  if (config.rates.empty()) config.rates.push_back(30);
  config.padding = static_cast<std::uint32_t>(
      std::strtoul(environment(kPaddingVariable, "0").c_str(), nullptr, 10));
  config.error_every = std::strtoull(environment(kErrorEveryVariable, "0").c_str(), nullptr, 10);
  config.unplug_file = environment(kUnplugFileVariable);
  config.stall_file = environment(kStallFileVariable);
  config.streaming = environment(kNoStreamingVariable).empty();
  return config;
}

struct Control {
  std::uint32_t id;
  const char* name;
  std::uint32_t type;
  std::int32_t minimum, maximum, step, default_value;
  std::uint32_t flags;
  std::int32_t value;
};

// Ordered by id, as V4L2_CTRL_FLAG_NEXT_CTRL walks them; each class heads its controls.
std::vector<Control> defaultControls() {
  const std::uint32_t klass = V4L2_CTRL_FLAG_READ_ONLY | V4L2_CTRL_FLAG_WRITE_ONLY;
  return {
      {V4L2_CID_USER_CLASS, "User Controls", V4L2_CTRL_TYPE_CTRL_CLASS, 0, 0, 0, 0, klass, 0},
      {V4L2_CID_GAIN, "Gain", V4L2_CTRL_TYPE_INTEGER, 0, kGainMaximum, 1, kGainDefault, 0,
       kGainDefault},
      {V4L2_CID_CAMERA_CLASS, "Camera Controls", V4L2_CTRL_TYPE_CTRL_CLASS, 0, 0, 0, 0, klass, 0},
      {V4L2_CID_EXPOSURE_ABSOLUTE, "Exposure Time, Absolute", V4L2_CTRL_TYPE_INTEGER, 1,
       kExposureMaximum, kExposureStep, kExposureDefault, 0, kExposureDefault},
  };
}

struct BufferSlot {
  enum class State { kDequeued, kQueued, kDone };
  State state = State::kDequeued;
  int mappings = 0;
  std::uint32_t sequence = 0;
  std::uint32_t flags = 0;
  std::uint32_t bytesused = 0;
  std::int64_t timestamp_ns = 0;
};

// One plugged-in device: its format, rate and controls live as long as some descriptor holds it
// (as a driver's state lives while the device is plugged), its queue belongs to the descriptor
// that asked for buffers.
struct Device {
  DeviceConfig config;
  bool gone = false;  // unplugged: dead for good, a replug is a new Device
  v4l2_pix_format format{};
  std::uint32_t fps = 30;
  std::vector<Control> controls;
  int owner = -1;
  std::vector<BufferSlot> buffers;
  std::size_t buffer_stride = 0;   // from one buffer's offset to the next: whole pages
  std::uint8_t* memory = nullptr;  // the shim's own view of the owner's memfd
  std::size_t memory_size = 0;
  std::deque<std::uint32_t> queued;
  std::deque<std::uint32_t> done;
  bool streaming = false;
  std::int64_t stream_start_ns = 0;
  std::uint64_t next_frame = 0;
  bool stuck = false;  // this stream stalled: it stays so until it is stopped and started again
};

struct Handle {
  std::shared_ptr<Device> device;
  bool nonblocking = false;
};

struct Mapping {
  std::weak_ptr<Device> device;
  std::uint32_t index = 0;
};

struct Shim {
  std::mutex mutex;
  std::map<int, Handle> handles;
  std::shared_ptr<Device> plugged;  // empty: the next open plugs in a device made anew
  std::map<const void*, Mapping> mappings;
};

// Never destroyed: interposed calls keep coming while the program exits.
Shim& shim() {
  static Shim* instance = new Shim;
  return *instance;
}

// A quick "no device is open" for the calls every program makes (close, mmap, poll, ioctl).
std::atomic<int> open_handles{0};

std::uint32_t pixelBytes(std::uint32_t format) { return format == V4L2_PIX_FMT_YUYV ? 2 : 1; }

// What a driver does with a format it is asked for: the nearest it can do.
void adjustFormat(const Device& device, v4l2_pix_format& pix) {
  const auto& formats = device.config.formats;
  if (std::find(formats.begin(), formats.end(), pix.pixelformat) == formats.end()) {
    pix.pixelformat = formats.front();
  }
  const Size* best = &device.config.sizes.front();
  auto distance = [&](const Size& size) {
    return std::abs(static_cast<long>(size.width) - static_cast<long>(pix.width)) +
           std::abs(static_cast<long>(size.height) - static_cast<long>(pix.height));
  };
  for (const Size& size : device.config.sizes) {
    if (distance(size) < distance(*best)) best = &size;
  }
  pix.width = best->width;
  pix.height = best->height;
  pix.field = V4L2_FIELD_NONE;
  pix.bytesperline = pix.width * pixelBytes(pix.pixelformat) + device.config.padding;
  pix.sizeimage = pix.bytesperline * pix.height;
  pix.colorspace = V4L2_COLORSPACE_SRGB;
  pix.priv = 0;
  pix.flags = 0;
  pix.ycbcr_enc = V4L2_YCBCR_ENC_DEFAULT;
  pix.quantization = V4L2_QUANTIZATION_DEFAULT;
  pix.xfer_func = V4L2_XFER_FUNC_DEFAULT;
}

std::shared_ptr<Device> plugIn() {
  auto device = std::make_shared<Device>();
  device->config = configFromEnvironment();
  device->format.pixelformat = device->config.formats.front();
  device->format.width = device->config.sizes.front().width;
  device->format.height = device->config.sizes.front().height;
  adjustFormat(*device, device->format);
  device->fps = device->config.rates.front();
  device->controls = defaultControls();
  return device;
}

bool unplugged(Device& device) {
  if (!device.gone && fileExists(device.config.unplug_file)) {
    device.gone = true;
    device.streaming = false;
  }
  return device.gone;
}

std::int64_t periodNs(const Device& device) { return 1'000'000'000LL / device.fps; }

std::int64_t nextDueNs(const Device& device) {
  return device.stream_start_ns +
         static_cast<std::int64_t>(device.next_frame + 1) * periodNs(device);
}

int controlValue(const Device& device, std::uint32_t id) {
  for (const Control& control : device.controls) {
    if (control.id == id) return control.value;
  }
  return 0;
}

// Frame `frame` into buffer `index`: the pattern, padding bytes marked, chroma out of its range.
void draw(Device& device, std::uint32_t index, std::uint64_t frame, std::int64_t due_ns) {
  const v4l2_pix_format& pix = device.format;
  std::uint8_t* base = device.memory + index * device.buffer_stride;
  const bool damaged = device.config.error_every > 0 &&
                       frame % device.config.error_every == device.config.error_every - 1;
  // A damaged frame shows another frame's picture: delivered by mistake, a test sees it.
  const std::uint64_t picture = damaged ? frame + 100 : frame;
  const int gain = controlValue(device, V4L2_CID_GAIN);
  const std::uint32_t row_bytes = pix.width * pixelBytes(pix.pixelformat);
  for (std::uint32_t v = 0; v < pix.height; ++v) {
    std::uint8_t* row = base + static_cast<std::size_t>(v) * pix.bytesperline;
    for (std::uint32_t u = 0; u < pix.width; ++u) {
      const std::uint8_t y =
          patternLuminance(picture, static_cast<int>(u), static_cast<int>(v), gain);
      if (pix.pixelformat == V4L2_PIX_FMT_YUYV) {
        row[2 * u] = y;
        row[2 * u + 1] = u % 2 == 0 ? kChromaU : kChromaV;
      } else {
        row[u] = y;
      }
    }
    std::memset(row + row_bytes, kPaddingByte, pix.bytesperline - row_bytes);
  }
  BufferSlot& slot = device.buffers[index];
  slot.sequence = static_cast<std::uint32_t>(frame);
  slot.timestamp_ns = due_ns;
  slot.flags = damaged ? V4L2_BUF_FLAG_ERROR : 0;
  slot.bytesused = pix.sizeimage;
}

// The frames that have come due by now: each fills the oldest queued buffer, or is lost for want
// of one (its sequence number is skipped, as drivers do).
void advance(Device& device) {
  if (!device.streaming) return;
  const std::int64_t now = monotonicNs();
  if (fileExists(device.config.stall_file)) device.stuck = true;
  while (nextDueNs(device) <= now) {
    const std::int64_t due = nextDueNs(device);
    const std::uint64_t frame = device.next_frame++;
    if (device.stuck || device.queued.empty()) continue;
    const std::uint32_t index = device.queued.front();
    device.queued.pop_front();
    draw(device, index, frame, due);
    device.buffers[index].state = BufferSlot::State::kDone;
    device.done.push_back(index);
  }
}

void freeBuffers(Device& device) {
  static const auto real_munmap = next<int (*)(void*, std::size_t) noexcept>("munmap");
  if (device.memory != nullptr) real_munmap(device.memory, device.memory_size);
  if (device.owner >= 0) {
    [[maybe_unused]] const int ignored = ::ftruncate(device.owner, 0);
  }
  device.memory = nullptr;
  device.memory_size = 0;
  device.buffers.clear();
  device.queued.clear();
  device.done.clear();
  device.streaming = false;
  device.owner = -1;
}

void fillBuffer(const Device& device, std::uint32_t index, v4l2_buffer& buffer) {
  const BufferSlot& slot = device.buffers[index];
  buffer.index = index;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.m.offset = static_cast<std::uint32_t>(index * device.buffer_stride);
  buffer.length = device.format.sizeimage;
  buffer.bytesused = slot.bytesused;
  buffer.field = V4L2_FIELD_NONE;
  buffer.sequence = slot.sequence;
  buffer.timestamp.tv_sec = slot.timestamp_ns / 1'000'000'000;
  buffer.timestamp.tv_usec = (slot.timestamp_ns % 1'000'000'000) / 1000;
  buffer.flags = slot.flags | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
  if (slot.mappings > 0) buffer.flags |= V4L2_BUF_FLAG_MAPPED;
  if (slot.state == BufferSlot::State::kQueued) buffer.flags |= V4L2_BUF_FLAG_QUEUED;
  if (slot.state == BufferSlot::State::kDone) buffer.flags |= V4L2_BUF_FLAG_DONE;
}

const Control* findControl(const Device& device, std::uint32_t id) {
  for (const Control& control : device.controls) {
    if (control.id == id) return &control;
  }
  return nullptr;
}

// One ioctl on an open device, the shim's lock held: 0 or -errno.
int deviceIoctl(int fd, Device& device, unsigned long request, void* argument) {
  if (unplugged(device)) return -ENODEV;
  const bool owner = device.owner == fd;
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto& capability = *static_cast<v4l2_capability*>(argument);
      capability = {};
      std::strncpy(reinterpret_cast<char*>(capability.driver), "occmap_shim",
                   sizeof capability.driver - 1);
      std::strncpy(reinterpret_cast<char*>(capability.card), "occmap V4L2 test shim",
                   sizeof capability.card - 1);
      std::strncpy(reinterpret_cast<char*>(capability.bus_info), "platform:occmap-shim",
                   sizeof capability.bus_info - 1);
      capability.version = (6u << 16) | (1u << 8);
      capability.device_caps = V4L2_CAP_VIDEO_CAPTURE |
                               (device.config.streaming ? V4L2_CAP_STREAMING : V4L2_CAP_READWRITE);
      capability.capabilities = capability.device_caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto& description = *static_cast<v4l2_fmtdesc*>(argument);
      if (description.type != V4L2_BUF_TYPE_VIDEO_CAPTURE ||
          description.index >= device.config.formats.size()) {
        return -EINVAL;
      }
      const std::uint32_t format = device.config.formats[description.index];
      description.flags = 0;
      description.pixelformat = format;
      std::memset(description.description, 0, sizeof description.description);
      std::strncpy(reinterpret_cast<char*>(description.description),
                   format == V4L2_PIX_FMT_YUYV   ? "YUYV 4:2:2"
                   : format == V4L2_PIX_FMT_GREY ? "8-bit Greyscale"
                                                 : "other",
                   sizeof description.description - 1);
      return 0;
    }
    case VIDIOC_G_FMT:
    case VIDIOC_TRY_FMT:
    case VIDIOC_S_FMT: {
      auto& format = *static_cast<v4l2_format*>(argument);
      if (format.type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (request == VIDIOC_G_FMT) {
        format.fmt.pix = device.format;
        return 0;
      }
      if (request == VIDIOC_S_FMT && !device.buffers.empty()) return -EBUSY;
      adjustFormat(device, format.fmt.pix);
      if (request == VIDIOC_S_FMT) device.format = format.fmt.pix;
      return 0;
    }
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: {
      auto& parameters = *static_cast<v4l2_streamparm*>(argument);
      if (parameters.type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      v4l2_fract& period = parameters.parm.capture.timeperframe;
      if (request == VIDIOC_S_PARM && period.numerator != 0 && period.denominator != 0) {
        if (device.streaming) return -EBUSY;
        const double asked = static_cast<double>(period.denominator) / period.numerator;
        std::uint32_t best = device.config.rates.front();
        for (const std::uint32_t rate : device.config.rates) {
          if (std::fabs(rate - asked) < std::fabs(best - asked)) best = rate;
        }
        device.fps = best;
      }
      parameters.parm.capture = {};
      parameters.parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      parameters.parm.capture.timeperframe = {1, device.fps};
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto& request_buffers = *static_cast<v4l2_requestbuffers*>(argument);
      if (request_buffers.type != V4L2_BUF_TYPE_VIDEO_CAPTURE ||
          request_buffers.memory != V4L2_MEMORY_MMAP) {
        return -EINVAL;
      }
      if (device.owner >= 0 && !owner) return -EBUSY;
      if (device.streaming) return -EBUSY;
      for (const BufferSlot& slot : device.buffers) {
        if (slot.mappings > 0) return -EBUSY;  // videobuf2: memory in use
      }
      freeBuffers(device);
      request_buffers.capabilities = V4L2_BUF_CAP_SUPPORTS_MMAP;
      if (request_buffers.count == 0) return 0;
      const std::uint32_t count = std::clamp<std::uint32_t>(request_buffers.count, 2, 8);
      const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
      device.buffer_stride = (device.format.sizeimage + page - 1) / page * page;
      device.memory_size = device.buffer_stride * count;
      static const auto real_mmap =
          next<void* (*)(void*, std::size_t, int, int, int, off_t) noexcept>("mmap");
      if (::ftruncate(fd, static_cast<off_t>(device.memory_size)) != 0) return -ENOMEM;
      void* memory =
          real_mmap(nullptr, device.memory_size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
      if (memory == MAP_FAILED) return -ENOMEM;
      device.memory = static_cast<std::uint8_t*>(memory);
      device.buffers.assign(count, BufferSlot{});
      device.owner = fd;
      request_buffers.count = count;
      return 0;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF:
    case VIDIOC_DQBUF: {
      auto& buffer = *static_cast<v4l2_buffer*>(argument);
      if (buffer.type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (!owner) return device.owner >= 0 ? -EBUSY : -EINVAL;
      if (request == VIDIOC_DQBUF) {
        if (!device.streaming) return -EINVAL;
        advance(device);
        if (device.done.empty()) return -EAGAIN;
        const std::uint32_t index = device.done.front();
        device.done.pop_front();
        device.buffers[index].state = BufferSlot::State::kDequeued;
        fillBuffer(device, index, buffer);
        return 0;
      }
      if (buffer.index >= device.buffers.size()) return -EINVAL;
      if (request == VIDIOC_QBUF) {
        if (buffer.memory != V4L2_MEMORY_MMAP) return -EINVAL;
        // Frames that came due while the buffer was away found no buffer: the clock first.
        advance(device);
        BufferSlot& slot = device.buffers[buffer.index];
        if (slot.state != BufferSlot::State::kDequeued) return -EINVAL;
        slot.state = BufferSlot::State::kQueued;
        device.queued.push_back(buffer.index);
      }
      fillBuffer(device, buffer.index, buffer);
      return 0;
    }
    case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF: {
      if (*static_cast<const int*>(argument) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (!owner) return device.owner >= 0 ? -EBUSY : -EINVAL;
      if (request == VIDIOC_STREAMON) {
        if (device.buffers.empty()) return -EINVAL;
        if (!device.streaming) {
          device.streaming = true;
          device.stream_start_ns = monotonicNs();
          device.next_frame = 0;
          device.stuck = false;  // a new stream; stuck again at once while the stall file exists
        }
        return 0;
      }
      // STREAMOFF hands every buffer back to the program, filled or not.
      device.streaming = false;
      device.queued.clear();
      device.done.clear();
      for (BufferSlot& slot : device.buffers) slot.state = BufferSlot::State::kDequeued;
      return 0;
    }
    case VIDIOC_QUERYCTRL: {
      auto& query = *static_cast<v4l2_queryctrl*>(argument);
      const std::uint32_t flags = V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
      const Control* found = nullptr;
      if ((query.id & flags) != 0) {
        const std::uint32_t after = query.id & ~flags;
        for (const Control& control : device.controls) {
          if (control.id > after) {
            found = &control;
            break;
          }
        }
      } else {
        found = findControl(device, query.id);
      }
      if (found == nullptr) return -EINVAL;
      query = {};
      query.id = found->id;
      query.type = found->type;
      std::strncpy(reinterpret_cast<char*>(query.name), found->name, sizeof query.name - 1);
      query.minimum = found->minimum;
      query.maximum = found->maximum;
      query.step = found->step;
      query.default_value = found->default_value;
      query.flags = found->flags;
      return 0;
    }
    case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL: {
      auto& value = *static_cast<v4l2_control*>(argument);
      Control* control = const_cast<Control*>(findControl(device, value.id));
      if (control == nullptr) return -EINVAL;
      if (control->type == V4L2_CTRL_TYPE_CTRL_CLASS) return -EACCES;
      if (request == VIDIOC_S_CTRL) {
        // The kernel's control framework clamps integers into range and rounds them onto the
        // nearest step.
        const std::int32_t clamped = std::clamp(value.value, control->minimum, control->maximum);
        const std::int32_t steps = (clamped - control->minimum + control->step / 2) / control->step;
        control->value = std::min(control->minimum + steps * control->step, control->maximum);
      }
      value.value = control->value;
      return 0;
    }
    default:
      return -ENOTTY;
  }
}

int openDevice(int flags) {
  const std::string unplug_file = environment(kUnplugFileVariable);
  Shim& s = shim();
  std::lock_guard lock(s.mutex);
  if (fileExists(unplug_file)) {
    if (s.plugged) {
      s.plugged->config.unplug_file = unplug_file;
      unplugged(*s.plugged);
    }
    errno = ENOENT;
    return -1;
  }
  const int fd = ::memfd_create("occmap-v4l2-shim", (flags & O_CLOEXEC) != 0 ? MFD_CLOEXEC : 0);
  if (fd < 0) return -1;
  if (!s.plugged || s.plugged->gone) s.plugged = plugIn();
  s.handles[fd] = Handle{s.plugged, (flags & O_NONBLOCK) != 0};
  open_handles.fetch_add(1);
  return fd;
}

bool isDevicePath(const char* path) {
  const char* device = std::getenv(kDeviceVariable);
  return path != nullptr && device != nullptr && *device != '\0' && std::strcmp(path, device) == 0;
}

int openMode(int flags, va_list arguments) {
  return (flags & O_CREAT) != 0 || (flags & O_TMPFILE) == O_TMPFILE ? va_arg(arguments, int) : 0;
}

// The poll events of a device descriptor now (0: none yet, and `wake_ns` lowered to when the next
// frame is due).
short deviceEvents(Device& device, short events, std::int64_t& wake_ns) {
  if (unplugged(device)) return POLLERR | POLLHUP | POLLPRI;
  if (!device.streaming) return POLLERR;  // videobuf2: nothing to wait for
  advance(device);
  if (!device.done.empty()) return static_cast<short>(events & (POLLIN | POLLRDNORM));
  wake_ns = std::min(wake_ns, nextDueNs(device));
  return 0;
}

// poll() over a set holding shim devices: the devices are looked at by the clock, the others by
// the real poll(); both at least every 10 ms, so that an unplug is noticed at once.
int shimPoll(pollfd* fds, nfds_t count, std::int64_t timeout_ns) {
  static const auto real_poll = next<int (*)(pollfd*, nfds_t, int)>("poll");
  Shim& s = shim();
  const std::int64_t deadline = timeout_ns < 0 ? INT64_MAX : monotonicNs() + timeout_ns;
  std::vector<bool> is_device(count);
  bool others = false;
  {
    std::lock_guard lock(s.mutex);
    for (nfds_t i = 0; i < count; ++i) {
      is_device[i] = fds[i].fd >= 0 && s.handles.count(fds[i].fd) != 0;
      others = others || (fds[i].fd >= 0 && !is_device[i]);
    }
  }
  // The real poll() skips negative descriptors: the devices are hidden from it that way.
  auto pollOthers = [&](int timeout_ms) {
    for (nfds_t i = 0; i < count; ++i) {
      if (is_device[i]) fds[i].fd = -fds[i].fd - 1;
    }
    const int ready = real_poll(fds, count, timeout_ms);
    for (nfds_t i = 0; i < count; ++i) {
      if (is_device[i]) fds[i].fd = -fds[i].fd - 1;
    }
    return ready;
  };
  for (;;) {
    int ready = 0;
    if (others) {
      ready = pollOthers(0);
      if (ready < 0) return ready;
    }
    std::int64_t wake_ns = deadline;
    {
      std::lock_guard lock(s.mutex);
      for (nfds_t i = 0; i < count; ++i) {
        if (!is_device[i]) continue;
        const auto handle = s.handles.find(fds[i].fd);
        fds[i].revents = handle == s.handles.end()
                             ? POLLNVAL
                             : deviceEvents(*handle->second.device, fds[i].events, wake_ns);
        if (fds[i].revents != 0) ++ready;
      }
    }
    if (ready > 0) return ready;
    const std::int64_t now = monotonicNs();
    if (now >= deadline) return 0;
    const std::int64_t pause =
        std::min<std::int64_t>(std::max<std::int64_t>(wake_ns - now, 0), 10'000'000);
    if (others) {
      if (pollOthers(static_cast<int>((pause + 999'999) / 1'000'000)) < 0) return -1;
    } else {
      sleepNs(std::max<std::int64_t>(pause, 100'000));
    }
  }
}

bool holdsDevice(const pollfd* fds, nfds_t count) {
  if (open_handles.load() == 0) return false;
  Shim& s = shim();
  std::lock_guard lock(s.mutex);
  for (nfds_t i = 0; i < count; ++i) {
    if (s.handles.count(fds[i].fd) != 0) return true;
  }
  return false;
}

}  // namespace

OCCMAP_SHIM_EXPORT int occmap_v4l2_shim_loaded() { return 1; }

OCCMAP_SHIM_EXPORT int open(const char* path, int flags, ...) {
  static const auto real = next<int (*)(const char*, int, ...)>("open");
  va_list arguments;
  va_start(arguments, flags);
  const int mode = openMode(flags, arguments);
  va_end(arguments);
  if (isDevicePath(path)) return openDevice(flags);
  return real(path, flags, mode);
}

OCCMAP_SHIM_EXPORT int open64(const char* path, int flags, ...) {
  static const auto real = next<int (*)(const char*, int, ...)>("open64");
  va_list arguments;
  va_start(arguments, flags);
  const int mode = openMode(flags, arguments);
  va_end(arguments);
  if (isDevicePath(path)) return openDevice(flags);
  return real(path, flags, mode);
}

OCCMAP_SHIM_EXPORT int openat(int directory, const char* path, int flags, ...) {
  static const auto real = next<int (*)(int, const char*, int, ...)>("openat");
  va_list arguments;
  va_start(arguments, flags);
  const int mode = openMode(flags, arguments);
  va_end(arguments);
  if (isDevicePath(path)) return openDevice(flags);
  return real(directory, path, flags, mode);
}

OCCMAP_SHIM_EXPORT int openat64(int directory, const char* path, int flags, ...) {
  static const auto real = next<int (*)(int, const char*, int, ...)>("openat64");
  va_list arguments;
  va_start(arguments, flags);
  const int mode = openMode(flags, arguments);
  va_end(arguments);
  if (isDevicePath(path)) return openDevice(flags);
  return real(directory, path, flags, mode);
}

// What fortified callers (-D_FORTIFY_SOURCE) call instead of open() without a mode.
OCCMAP_SHIM_EXPORT int __open_2(const char* path, int flags) {
  static const auto real = next<int (*)(const char*, int)>("__open_2");
  if (isDevicePath(path)) return openDevice(flags);
  return real(path, flags);
}

OCCMAP_SHIM_EXPORT int __open64_2(const char* path, int flags) {
  static const auto real = next<int (*)(const char*, int)>("__open64_2");
  if (isDevicePath(path)) return openDevice(flags);
  return real(path, flags);
}

OCCMAP_SHIM_EXPORT int close(int fd) {
  static const auto real = next<int (*)(int)>("close");
  if (open_handles.load() > 0) {
    Shim& s = shim();
    std::lock_guard lock(s.mutex);
    const auto handle = s.handles.find(fd);
    if (handle != s.handles.end()) {
      Device& device = *handle->second.device;
      // Closing the descriptor that owns the buffers frees them, as closing a V4L2 file does
      // (memory still mapped by the program stays valid until unmapped).
      if (device.owner == fd) freeBuffers(device);
      s.handles.erase(handle);
      open_handles.fetch_sub(1);
      // Nobody holds the device any more: the next open plugs in one made anew from the
      // environment (so a test can change it between devices).
      bool held = false;
      for (const auto& [other_fd, other] : s.handles) held = held || other.device == s.plugged;
      if (!held) s.plugged.reset();
    }
  }
  return real(fd);
}

OCCMAP_SHIM_EXPORT int ioctl(int fd, unsigned long request, ...) noexcept {
  static const auto real = next<int (*)(int, unsigned long, ...) noexcept>("ioctl");
  va_list arguments;
  va_start(arguments, request);
  void* argument = va_arg(arguments, void*);
  va_end(arguments);
  if (open_handles.load() == 0) return real(fd, request, argument);
  Shim& s = shim();
  for (;;) {
    int result = 0;
    std::int64_t wake_ns = 0;
    {
      std::lock_guard lock(s.mutex);
      const auto handle = s.handles.find(fd);
      if (handle == s.handles.end()) break;
      Device& device = *handle->second.device;
      result = deviceIoctl(fd, device, request, argument);
      // A blocking descriptor's DQBUF waits for the next frame.
      if (result != -EAGAIN || handle->second.nonblocking || request != VIDIOC_DQBUF) {
        if (result >= 0) return result;
        errno = -result;
        return -1;
      }
      wake_ns = nextDueNs(device);
    }
    sleepNs(std::clamp<std::int64_t>(wake_ns - monotonicNs(), 100'000, 10'000'000));
  }
  return real(fd, request, argument);
}

OCCMAP_SHIM_EXPORT void* mmap(void* address, std::size_t length, int protection, int flags, int fd,
                              off_t offset) noexcept {
  static const auto real =
      next<void* (*)(void*, std::size_t, int, int, int, off_t) noexcept>("mmap");
  if (open_handles.load() > 0) {
    Shim& s = shim();
    std::lock_guard lock(s.mutex);
    const auto handle = s.handles.find(fd);
    if (handle != s.handles.end()) {
      Device& device = *handle->second.device;
      if (unplugged(device)) {
        errno = ENODEV;
        return MAP_FAILED;
      }
      // videobuf2: a shared mapping of one whole buffer at the offset QUERYBUF gave.
      const auto at = static_cast<std::size_t>(offset);
      if (device.owner != fd || (flags & MAP_SHARED) == 0 || device.buffer_stride == 0 ||
          at % device.buffer_stride != 0 || at / device.buffer_stride >= device.buffers.size() ||
          length == 0 || length > device.buffer_stride) {
        errno = EINVAL;
        return MAP_FAILED;
      }
      void* memory = real(address, length, protection, flags, fd, offset);
      if (memory != MAP_FAILED) {
        const auto index = static_cast<std::uint32_t>(at / device.buffer_stride);
        ++device.buffers[index].mappings;
        s.mappings[memory] = Mapping{handle->second.device, index};
      }
      return memory;
    }
  }
  return real(address, length, protection, flags, fd, offset);
}

OCCMAP_SHIM_EXPORT void* mmap64(void* address, std::size_t length, int protection, int flags,
                                int fd, off64_t offset) noexcept {
  return mmap(address, length, protection, flags, fd, static_cast<off_t>(offset));
}

OCCMAP_SHIM_EXPORT int munmap(void* address, std::size_t length) noexcept {
  static const auto real = next<int (*)(void*, std::size_t) noexcept>("munmap");
  {
    Shim& s = shim();
    std::lock_guard lock(s.mutex);
    const auto mapping = s.mappings.find(address);
    if (mapping != s.mappings.end()) {
      if (const auto device = mapping->second.device.lock()) {
        if (mapping->second.index < device->buffers.size()) {
          --device->buffers[mapping->second.index].mappings;
        }
      }
      s.mappings.erase(mapping);
    }
  }
  return real(address, length);
}

OCCMAP_SHIM_EXPORT int poll(pollfd* fds, nfds_t count, int timeout_ms) {
  static const auto real = next<int (*)(pollfd*, nfds_t, int)>("poll");
  if (!holdsDevice(fds, count)) return real(fds, count, timeout_ms);
  return shimPoll(fds, count, timeout_ms < 0 ? -1 : timeout_ms * 1'000'000LL);
}

// The signal mask is not applied while a device is polled: the tests' programs do not rely on it.
OCCMAP_SHIM_EXPORT int ppoll(pollfd* fds, nfds_t count, const timespec* timeout,
                             const sigset_t* mask) {
  static const auto real =
      next<int (*)(pollfd*, nfds_t, const timespec*, const sigset_t*)>("ppoll");
  if (!holdsDevice(fds, count)) return real(fds, count, timeout, mask);
  return shimPoll(fds, count,
                  timeout == nullptr ? -1 : timeout->tv_sec * 1'000'000'000LL + timeout->tv_nsec);
}

OCCMAP_SHIM_EXPORT int __poll_chk(pollfd* fds, nfds_t count, int timeout_ms, std::size_t) {
  return poll(fds, count, timeout_ms);
}

OCCMAP_SHIM_EXPORT int __ppoll_chk(pollfd* fds, nfds_t count, const timespec* timeout,
                                   const sigset_t* mask, std::size_t) {
  return ppoll(fds, count, timeout, mask);
}
