#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace occmap {

// A borrowed view of an 8-bit single-channel image (grey, or raw Bayer compared against a raw
// Bayer background): row-major, `stride` bytes from one row to the next. It never owns the pixels.
struct ImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;

  bool empty() const { return data == nullptr; }
  const std::uint8_t* row(int v) const { return data + v * stride; }
  std::uint8_t at(int u, int v) const { return row(v)[u]; }
};

// An owned 8-bit single-channel image with packed rows.
class Image {
 public:
  Image() = default;
  Image(int width, int height, std::uint8_t fill = 0)
      : width_(width),
        height_(height),
        pixels_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return pixels_.empty(); }
  std::uint8_t* data() { return pixels_.data(); }
  const std::uint8_t* data() const { return pixels_.data(); }
  std::uint8_t* row(int v) { return pixels_.data() + static_cast<std::ptrdiff_t>(v) * width_; }
  const std::uint8_t* row(int v) const {
    return pixels_.data() + static_cast<std::ptrdiff_t>(v) * width_;
  }
  std::uint8_t& at(int u, int v) { return row(v)[u]; }
  std::uint8_t at(int u, int v) const { return row(v)[u]; }
  ImageView view() const { return {pixels_.data(), width_, height_, width_}; }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<std::uint8_t> pixels_;
};

}  // namespace occmap
