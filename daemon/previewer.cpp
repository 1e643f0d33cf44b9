#include "daemon/previewer.h"

#include <algorithm>
#include <exception>
#include <stdexcept>

#include <occmap/camera_frame_t.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <poll.h>

#include "base/clock.h"
#include "base/log.h"
#include "core/fusion_kernel.h"
#include "transport/camera_preview_message.h"

namespace occmap {
namespace {

static_assert(static_cast<int>(CameraState::kStarting) == occmap::camera_frame_t::STATE_STARTING);
static_assert(static_cast<int>(CameraState::kStreaming) == occmap::camera_frame_t::STATE_STREAMING);
static_assert(static_cast<int>(CameraState::kDown) == occmap::camera_frame_t::STATE_DOWN);

// The JPEG's quality, tried in turn until the message fits (a 320 x 240 grey picture of a room is
// some 10 to 20 KB at the first); then the preview is halved and they are tried again.
constexpr int kJpegQualities[] = {80, 60, 40, 20};
// Halved no further than this: a narrower picture tells nothing.
constexpr int kMinPreviewWidth = 20;
// The least room worth giving a JPEG (its headers alone are some 300 bytes).
constexpr std::size_t kMinJpegBytes = 512;

PreviewFrame emptyPreview(int stream_width, int stream_height) {
  PreviewFrame frame;
  frame.stream_width = stream_width;
  frame.stream_height = stream_height;
  frame.scale = previewScale(stream_width);
  frame.width = previewSide(stream_width, frame.scale);
  frame.height = previewSide(stream_height, frame.scale);
  const std::size_t pixels =
      static_cast<std::size_t>(frame.width) * static_cast<std::size_t>(frame.height);
  frame.grey.assign(pixels, 0);
  frame.changed.assign(pixels, 0);
  return frame;
}

// The camera's coverage: bit per cell, set when its table gives the cell pixels (`occmap
// coverage`'s rule), packed and compressed.
std::vector<std::uint8_t> coverageOf(const CarveTable& table) {
  const std::size_t cells = table.map().cellCount();
  std::vector<std::uint8_t> packed(packedBytes(cells), 0);
  for (std::size_t cell = 0; cell < cells; ++cell) {
    if (table.sees(cell)) packed[cell / 8] |= static_cast<std::uint8_t>(0x80u >> (cell % 8));
  }
  return compressCoverage(packed);
}

// A message's buffer with room for the largest message sent: handing one over allocates nothing.
std::vector<std::uint8_t> messageRoom() {
  std::vector<std::uint8_t> bytes;
  bytes.reserve(kMaxPreviewMessageBytes);
  return bytes;
}

// Stream pixels a preview pixel at `index` covers along a side of `stream` pixels at `scale`.
int coveredAlong(int index, int scale, int stream) {
  return std::min(scale, stream - index * scale);
}

}  // namespace

void shrinkForPreview(ImageView image, const std::uint8_t* changed, int scale,
                      std::span<std::uint32_t> sums, PreviewFrame& out) {
  out.stream_width = image.width;
  out.stream_height = image.height;
  out.scale = scale;
  out.width = previewSide(image.width, scale);
  out.height = previewSide(image.height, scale);
  const std::size_t tiles_across = tilesAcross(image.width);
  const auto stream_width = static_cast<std::size_t>(image.width);
  for (int y = 0; y < out.height; ++y) {
    std::uint8_t* grey = out.grey.data() + static_cast<std::ptrdiff_t>(y) * out.width;
    std::uint8_t* marked = out.changed.data() + static_cast<std::ptrdiff_t>(y) * out.width;
    std::fill_n(marked, out.width, std::uint8_t{0});
    // Each stream column's sum over the preview row's stream rows first (a loop the compiler
    // vectorises), then the columns of each preview pixel.
    std::fill_n(sums.begin(), stream_width, 0u);
    const int rows = coveredAlong(y, scale, image.height);
    for (int v = y * scale; v < y * scale + rows; ++v) {
      const std::uint8_t* pixel = image.row(v);
      for (std::size_t u = 0; u < stream_width; ++u) sums[u] += pixel[u];
      // Row v's changed bits: byte v % 8 of each tile in its row of tiles, bit u % 8 for pixel u.
      const std::uint8_t* bits = changed + (static_cast<std::size_t>(v / 8) * tiles_across * 8 +
                                            static_cast<std::size_t>(v % 8));
      for (std::size_t tile = 0; tile < tiles_across; ++tile) {
        const std::uint8_t byte = bits[tile * 8];
        if (byte == 0) continue;
        for (int bit = 0; bit < 8; ++bit) {
          const int u = static_cast<int>(tile) * 8 + bit;
          if ((byte >> bit & 1u) != 0 && u < image.width) marked[u / scale] = 1;
        }
      }
    }
    for (int x = 0; x < out.width; ++x) {
      const int columns = coveredAlong(x, scale, image.width);
      const std::uint32_t* column = sums.data() + static_cast<std::ptrdiff_t>(x) * scale;
      std::uint32_t sum = 0;
      for (int i = 0; i < columns; ++i) sum += column[i];
      const auto pixels = static_cast<std::uint32_t>(rows * columns);
      grey[x] = static_cast<std::uint8_t>((sum + pixels / 2) / pixels);
    }
  }
}

void halvePreview(const PreviewFrame& in, PreviewFrame& out) {
  out.capture_time_us = in.capture_time_us;
  out.sequence = in.sequence;
  out.state = in.state;
  out.stream_width = in.stream_width;
  out.stream_height = in.stream_height;
  out.scale = in.scale * 2;
  out.width = previewSide(in.stream_width, out.scale);
  out.height = previewSide(in.stream_height, out.scale);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      std::uint32_t sum = 0;
      std::uint32_t pixels = 0;
      std::uint8_t marked = 0;
      for (int j = 2 * y; j < std::min(2 * y + 2, in.height); ++j) {
        for (int i = 2 * x; i < std::min(2 * x + 2, in.width); ++i) {
          // Weighted by the stream pixels each covers, so that the edges' means stay means.
          const auto covered =
              static_cast<std::uint32_t>(coveredAlong(i, in.scale, in.stream_width) *
                                         coveredAlong(j, in.scale, in.stream_height));
          const std::size_t at = static_cast<std::size_t>(j) * static_cast<std::size_t>(in.width) +
                                 static_cast<std::size_t>(i);
          sum += in.grey[at] * covered;
          pixels += covered;
          marked |= in.changed[at];
        }
      }
      const std::size_t at = static_cast<std::size_t>(y) * static_cast<std::size_t>(out.width) +
                             static_cast<std::size_t>(x);
      out.grey[at] = static_cast<std::uint8_t>((sum + pixels / 2) / pixels);
      out.changed[at] = marked;
    }
  }
}

Previewer::Camera::Camera(const std::string& hostname, const std::string& name,
                          const CarveTable& table)
    : frames(emptyPreview(table.imageWidth(), table.imageHeight()),
             emptyPreview(table.imageWidth(), table.imageHeight()),
             emptyPreview(table.imageWidth(), table.imageHeight())),
      messages(messageRoom(), messageRoom(), messageRoom()) {
  const PreviewFrame& shape = frames.writeBuffer();
  sums.assign(static_cast<std::size_t>(shape.stream_width), 0);
  message.hostname = hostname;
  message.camera = name;
  message.stream_width = table.imageWidth();
  message.stream_height = table.imageHeight();
  message.map_width = table.map().width;
  message.map_height = table.map().height;
  message.coverage = coverageOf(table);
  message.coverage_size = static_cast<std::int32_t>(message.coverage.size());
  message.jpeg.reserve(kMaxPreviewMessageBytes);
  message.changed.reserve(packedBytes(shape.grey.size()));
}

Previewer::Previewer(std::string hostname, std::span<const std::string> cameras,
                     std::span<const CarveTable> tables, std::chrono::nanoseconds preview_for)
    : preview_for_ns_(preview_for.count()), jpeg_parameters_{cv::IMWRITE_JPEG_QUALITY, 80} {
  std::size_t largest = 0;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    cameras_.push_back(std::make_unique<Camera>(hostname, cameras[k], tables[k]));
    largest = std::max(largest, cameras_.back()->frames.writeBuffer().grey.size());
  }
  for (PreviewFrame& halved : halved_) {
    halved.grey.assign(largest, 0);
    halved.changed.assign(largest, 0);
  }
  jpeg_.reserve(kMaxPreviewMessageBytes);
}

bool Previewer::requested(std::string_view camera, std::int64_t now_ns) {
  bool named = false;
  for (const auto& slot : cameras_) {
    if (!camera.empty() && camera != slot->message.camera) continue;
    slot->wanted_until_ns.store(now_ns + preview_for_ns_, std::memory_order_relaxed);
    named = true;
  }
  return named;
}

void Previewer::offer(std::size_t k, ImageView image, const std::uint8_t* changed,
                      std::uint64_t sequence, std::int64_t capture_time_us, CameraState state) {
  Camera& camera = *cameras_[k];
  PreviewFrame& frame = camera.frames.writeBuffer();
  // The buffers are the table's stream size (the capture thread drops frames of another size).
  if (image.width != frame.stream_width || image.height != frame.stream_height) return;
  shrinkForPreview(image, changed, frame.scale, camera.sums, frame);
  frame.sequence = sequence;
  frame.capture_time_us = capture_time_us;
  frame.state = state;
  camera.frames.publish();
  wakeup_.signal();
}

void Previewer::stop() {
  stopping_.store(true, std::memory_order_relaxed);
  wakeup_.signal();
}

void Previewer::run(const EventFd& ready) {
  pollfd wakeup{wakeup_.fd(), POLLIN, 0};
  while (!stopping_.load(std::memory_order_relaxed)) {
    // A bounded wait: stop() signals too, so this is only a guard against a lost wake-up.
    ::poll(&wakeup, 1, 100);
    wakeup_.drain();
    if (makeNewest()) ready.signal();
  }
}

bool Previewer::makeNewest() {
  bool made = false;
  for (const auto& camera : cameras_) {
    if (!camera->frames.takeLatest()) continue;
    try {
      made = make(*camera, camera->frames.readBuffer()) || made;
    } catch (const std::exception& error) {
      // A preview is not worth the daemon: this one is lost, said now and then.
      failed_.fetch_add(1, std::memory_order_relaxed);
      std::uint64_t suppressed = 0;
      if (failure_warnings_.allow(suppressed)) {
        logLine(LogLevel::kWarning, "camera %s: a preview failed: %s (%llu more not shown)",
                camera->message.camera.c_str(), error.what(),
                static_cast<unsigned long long>(suppressed));
      }
    }
  }
  return made;
}

bool Previewer::make(Camera& camera, const PreviewFrame& frame) {
  const std::int64_t began = monotonicNanoseconds();
  occmap::camera_preview_t& message = camera.message;
  message.utime = frame.capture_time_us;
  message.sequence = static_cast<std::int64_t>(frame.sequence);
  message.state = static_cast<std::int8_t>(frame.state);
  const PreviewFrame* shown = &frame;
  for (int halvings = 0;; ++halvings) {
    message.width = shown->width;
    message.height = shown->height;
    message.scale = shown->scale;
    const std::size_t pixels =
        static_cast<std::size_t>(shown->width) * static_cast<std::size_t>(shown->height);
    message.changed.resize(packedBytes(pixels));
    packBits({shown->changed.data(), pixels}, message.changed);
    message.changed_size = static_cast<std::int32_t>(message.changed.size());
    message.jpeg.clear();
    message.jpeg_size = 0;
    const auto without_jpeg = static_cast<std::size_t>(message.getEncodedSize());
    if (without_jpeg + kMinJpegBytes <= kMaxPreviewMessageBytes) {
      const std::size_t room = kMaxPreviewMessageBytes - without_jpeg;
      // cv::Mat borrows the pixels; nothing is copied.
      const cv::Mat grey(shown->height, shown->width, CV_8UC1,
                         const_cast<std::uint8_t*>(shown->grey.data()));
      for (const int quality : kJpegQualities) {
        jpeg_parameters_[1] = quality;
        if (!cv::imencode(".jpg", grey, jpeg_, jpeg_parameters_)) {
          throw std::runtime_error("OpenCV could not encode the JPEG");
        }
        if (jpeg_.size() > room) continue;
        message.jpeg.assign(jpeg_.begin(), jpeg_.end());
        message.jpeg_size = static_cast<std::int32_t>(jpeg_.size());
        encodeCameraPreview(message, camera.messages.writeBuffer());
        camera.messages.publish();
        made_.fetch_add(1, std::memory_order_relaxed);
        times_.record(monotonicNanoseconds() - began);
        return true;
      }
    }
    if (shown->width / 2 < kMinPreviewWidth) break;
    PreviewFrame& halved = halved_[halvings % 2];
    halvePreview(*shown, halved);
    shown = &halved;
  }
  // Even small and coarse the message does not fit: the coverage alone is too large (a large map
  // whose camera sees a ragged part of it). Counted, said now and then, never sent cut.
  too_large_.fetch_add(1, std::memory_order_relaxed);
  std::uint64_t suppressed = 0;
  if (too_large_warnings_.allow(suppressed)) {
    logLine(LogLevel::kWarning,
            "camera %s: its preview does not fit %zu bytes even at %d x %d (its coverage alone "
            "is %zu bytes); previews of it are not sent (%llu more not shown)",
            camera.message.camera.c_str(), kMaxPreviewMessageBytes, shown->width, shown->height,
            camera.message.coverage.size(), static_cast<unsigned long long>(suppressed));
  }
  return false;
}

}  // namespace occmap
