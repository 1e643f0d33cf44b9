#pragma once
// Handing a camera a new background image while its capture thread runs (docs/control.md,
// recapture_background). The capture thread reads the background for every frame, so it takes no
// lock and waits for nothing: once per frame it looks whether a new image has been offered and, if
// so, switches to it and says so. The offering thread (one) keeps every image it offered and frees
// one only after the capture thread has said it switched to a later one: so no memory the capture
// thread may still read is ever freed. No I/O, no threads of its own.

#include <algorithm>
#include <atomic>
#include <memory>
#include <vector>

#include "core/image.h"

namespace occmap {

class BackgroundHandover {
 public:
  // `initial` (the config's background) is borrowed: it must outlive this object.
  explicit BackgroundHandover(const Image& initial) : current_(&initial) {}
  BackgroundHandover(const BackgroundHandover&) = delete;
  BackgroundHandover& operator=(const BackgroundHandover&) = delete;

  // Capture thread, once per frame: the background to difference this frame against. Two atomic
  // loads when nothing changed.
  const Image& current() {
    const Image* offered = offered_.load(std::memory_order_acquire);
    if (offered != nullptr && offered != current_) {
      current_ = offered;
      // Release: every read of the previous image happened before this store, which the offering
      // thread acquires before it frees that image.
      taken_.store(offered, std::memory_order_release);
    }
    return *current_;
  }

  // The offering thread: `image` becomes the background from the capture thread's next frame on.
  // Images offered before are freed once the capture thread has moved past them.
  void offer(std::unique_ptr<Image> image) {
    collect();
    owned_.push_back(std::move(image));
    offered_.store(owned_.back().get(), std::memory_order_release);
  }

  // The offering thread: frees the images the capture thread no longer reads; true when it reads
  // the newest one offered (or nothing was ever offered).
  bool collect() {
    const Image* taken = taken_.load(std::memory_order_acquire);
    const auto in_use = std::find_if(owned_.begin(), owned_.end(),
                                     [taken](const auto& image) { return image.get() == taken; });
    // Offers are switched to in order, so every one before the image in use is no longer read.
    // (taken is nullptr, found nowhere, until the first switch: then nothing may go.)
    if (in_use != owned_.end()) owned_.erase(owned_.begin(), in_use);
    return owned_.empty() || owned_.back().get() == taken;
  }

 private:
  const Image* current_;                        // capture thread only
  std::atomic<const Image*> offered_{nullptr};  // the newest offer
  std::atomic<const Image*> taken_{nullptr};    // the newest offer the capture thread switched to
  std::vector<std::unique_ptr<Image>> owned_;   // offering thread only, in the order offered
};

}  // namespace occmap
