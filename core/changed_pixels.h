#pragma once
// One camera's share of the work for each frame, as its capture thread in occmapd does it and as
// `occmap fuse` repeats it, so that off-line maps equal live ones: the light's model (when the
// config adapts to the light), the difference into changed-pixel tiles, and the model's drift.
// No I/O, no threads; the model is made at the first frame and again only when the background is
// replaced (a recapture), never per frame.

#include <cstddef>
#include <cstdint>
#include <optional>

#include "core/fusion_kernel.h"
#include "core/image.h"
#include "core/lighting_model.h"

namespace occmap {

class ChangedPixels {
 public:
  explicit ChangedPixels(const LightingSettings& lighting) : settings_(lighting) {}

  // Marks camera k's changed pixels of `live` into `changed` (changedMaskBytes of the stream).
  // False when the light's model does not explain the frame: then its changes are no evidence of
  // anything (a bumped camera, lights out) and the frame must not count.
  bool mark(const FusionKernel& kernel, std::size_t k, ImageView live, const Image& background,
            int threshold, std::uint8_t* changed) {
    if (!settings_.adapt) {
      kernel.markChangedPixels(k, live, background.view(), threshold, changed);
      return true;
    }
    if (model_background_ != &background) {
      if (model_) {
        model_->reset(background.view());
      } else {
        model_.emplace(background.view(), settings_);
      }
      model_background_ = &background;
    }
    const ImageView corrected = model_->correct(live);
    kernel.markChangedPixels(k, corrected, model_->background(), threshold, changed);
    model_->explainLocally(corrected, threshold, changed);
    model_->follow(live, changed);
    return model_->explained();
  }

  // The model, once a frame has been marked with one.
  const LightingModel* lighting() const { return model_ ? &*model_ : nullptr; }

 private:
  LightingSettings settings_;
  std::optional<LightingModel> model_;
  const Image* model_background_ = nullptr;
};

}  // namespace occmap
