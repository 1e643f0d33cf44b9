#pragma once
// Frame numbers from the device's own count (Frame::sequence), one rule for every live backend:
// the first frame after a source opened is 0, each later one is the previous number plus the
// device's step, so that a gap is a frame the device made and occmapd never got. Pure: no I/O,
// tested directly in tests/aravis_source_test.cpp.

#include <cstdint>

namespace occmap {

// How a device counts its frames.
enum class DeviceCounter {
  // V4L2's v4l2_buffer.sequence: 32 bits, from 0 at STREAMON, wrapping to 0.
  kV4l2Sequence,
  // A GenICam camera's frame id, as Aravis gives it (arv_buffer_get_frame_id): 64 bits for GigE
  // Vision 2's extended ids and USB3 Vision; 16 bits for GigE Vision 1.x block ids, which go from
  // 65535 to 1 (block id 0 is reserved). Aravis does not say which a camera uses, so the wrap is
  // recognised by itself: a step back from the upper half of the 16-bit range into its lower half.
  kGenicamFrameId,
};

class FrameNumbering {
 public:
  explicit FrameNumbering(DeviceCounter counter) : counter_(counter) {}

  // The number of the frame the device counted `device_count`. Drivers that never count (always
  // 0) or jump back still get increasing numbers, as do implausible leaps (2^30 or more frames
  // ahead): one more, no gap.
  std::uint64_t number(std::uint64_t device_count) {
    missed_ = 0;
    if (have_last_) {
      const std::uint64_t step = stepFrom(last_count_, device_count);
      missed_ = step - 1;
      next_ += step - 1;
    }
    have_last_ = true;
    last_count_ = device_count;
    return next_++;
  }

  // Frames the device counted between the last two numbered: lost before occmapd saw them.
  std::uint64_t missed() const { return missed_; }

  // The device was opened again: its count starts over, ours goes on from the next number (the
  // frames it made while away are unknown, so none is counted missed).
  void restart() {
    have_last_ = false;
    missed_ = 0;
  }

 private:
  static constexpr std::uint64_t kLeap = std::uint64_t{1} << 30;

  // How many frames on from `from` the device's `to` is: 1 for the next one.
  std::uint64_t stepFrom(std::uint64_t from, std::uint64_t to) const {
    std::uint64_t step = 0;
    if (counter_ == DeviceCounter::kV4l2Sequence) {
      step = static_cast<std::uint32_t>(to - from);  // wraps as the driver's count does
    } else if (to > from) {
      step = to - from;
    } else if (from <= 0xFFFF && from - to >= 0x8000) {
      // A 16-bit block id wrapped: from `from` up to 65535, then 1 (skipping 0), up to `to`.
      step = 0xFFFF - from + to;
    }
    return step >= 1 && step < kLeap ? step : 1;
  }

  DeviceCounter counter_;
  bool have_last_ = false;
  std::uint64_t last_count_ = 0;
  std::uint64_t next_ = 0;
  std::uint64_t missed_ = 0;
};

}  // namespace occmap
