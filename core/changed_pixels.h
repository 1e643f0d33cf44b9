#pragma once
// One camera's share of the work for each frame, as its capture thread in occmapd does it and as
// `occmap fuse` repeats it, so that off-line maps equal live ones: the light's model (when the
// config adapts to the light), the difference into changed-pixel tiles, and the model's drift.
// When the model does not explain a frame, whether the camera was moved (core/view_motion.h), at
// most once a second of capture time (the first such frame allocates the check's pyramids), and
// when a moved camera is steady enough to be re-posed (core/repose.h: the host builds the
// re-posed camera and hands it back).
// No I/O, no threads; the model is made at the first frame and again only when the background is
// replaced (a recapture or a re-pose), never per frame.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>

#include "core/camera.h"
#include "core/fusion_kernel.h"
#include "core/image.h"
#include "core/lighting_model.h"
#include "core/repose.h"
#include "core/view_motion.h"

namespace occmap {

// Whether a camera looks where its calibration says (lcmtypes/view_status_t.lcm).
enum class ViewState : std::uint8_t { kAsCalibrated = 0, kUnexplained = 1, kMoved = 2 };

class ChangedPixels {
 public:
  // `camera`: the camera as its carve table was built (the turns of a moved view are its).
  ChangedPixels(const LightingSettings& lighting, Camera camera)
      : settings_(lighting), camera_(std::move(camera)) {}

  // Marks camera k's changed pixels of `live`, captured at `time_us`, into `changed`
  // (changedMaskBytes of the stream). False when the frame must not count: the light's model does
  // not explain it and the camera was moved, or too little of it agrees with the light's gain
  // (LightingSettings::min_agreement_in_place: lights out, a covered lens); then its changes are
  // no evidence of anything.
  bool mark(const FusionKernel& kernel, std::size_t k, ImageView live, const Image& background,
            int threshold, std::uint8_t* changed, std::int64_t time_us) {
    if (!settings_.adapt) {
      generation_ = kernel.markChangedPixels(k, live, background.view(), threshold, changed);
      return true;
    }
    if (model_background_ != &background) {
      if (model_) {
        model_->reset(background.view());
      } else {
        model_.emplace(background.view(), settings_);
      }
      view_motion_.reset();
      model_background_ = &background;
      view_ = ViewState::kAsCalibrated;
      moved_ = false;
      checked_us_.reset();
      repose_.reset();
      repose_turn_.reset();
    }
    const ImageView corrected = model_->correct(live);
    generation_ = kernel.markChangedPixels(k, corrected, model_->background(), threshold, changed);
    model_->explainLocally(corrected, threshold, changed);
    model_->follow(live, changed);
    if (model_->explained()) {
      view_ = ViewState::kAsCalibrated;
      moved_ = false;
      return true;
    }
    // No change of light explains the frame. Whether the camera was moved is checked at the first
    // such frame, then once a second, and again at once when the agreement falls further (a knock
    // amid a crowd): some 7 ms each for 640 x 480. The estimator's pyramids (some 5 bytes a pixel)
    // are made for a camera only once its view is first unexplained.
    const double agreement = model_->agreement();
    const bool due = !checked_us_ || time_us - *checked_us_ >= kViewCheckPeriodUs ||
                     time_us < *checked_us_ || agreement < checked_agreement_ - kAgreementFall;
    if (due) {
      if (!view_motion_) view_motion_.emplace(background.view());
      motion_ = view_motion_->estimate(live);
      moved_ = motion_.moved;
      turn_ = moved_ ? cameraTurn(camera_, motion_) : CameraTurn{};
      checked_us_ = time_us;
      checked_agreement_ = agreement;
      if (auto turn =
              repose_.check(time_us, moved_ && turn_.found, turn_.turn, turn_.residual_px)) {
        repose_turn_ = *turn;
      }
    }
    view_ = moved_ ? ViewState::kMoved : ViewState::kUnexplained;
    // A view in place that enough of agrees with the light's gain still counts (a crowd, shadows:
    // what it finds changed stays changed); a moved one, or one nothing agrees with, does not.
    return !moved_ && agreement >= settings_.min_agreement_in_place;
  }

  // The model, once a frame has been marked with one.
  const LightingModel* lighting() const { return model_ ? &*model_ : nullptr; }
  // Whether the camera looks where its calibration says; when kMoved, the motion found, at the
  // capture time checkedUs().
  ViewState view() const { return view_; }
  const ViewMotion& motion() const { return motion_; }
  const CameraTurn& turn() const { return turn_; }
  std::int64_t checkedUs() const { return checked_us_.value_or(0); }
  const Camera& camera() const { return camera_; }
  // The generation of the kernel's table the last mask was marked with (FusionKernel::fuse).
  std::uint32_t generation() const { return generation_; }

  // Once a moved view has been steady (ReposePolicy): the turn to re-pose the camera by, given
  // once. The host makes the re-posed camera (reposeCamera), calls reposed() with it, and
  // differences the next frames against its background.
  std::optional<Eigen::Vector3d> takeReposeTurn() {
    return std::exchange(repose_turn_, std::nullopt);
  }
  void reposed(const Camera& camera) { camera_ = camera; }

  static constexpr std::int64_t kViewCheckPeriodUs = 1'000'000;
  // A fall of the agreement since the last check that calls for another at once.
  static constexpr double kAgreementFall = 0.05;

 private:
  LightingSettings settings_;
  Camera camera_;
  std::optional<LightingModel> model_;
  std::optional<ViewMotionEstimator> view_motion_;
  const Image* model_background_ = nullptr;
  ViewState view_ = ViewState::kAsCalibrated;
  ViewMotion motion_;
  CameraTurn turn_;
  bool moved_ = false;  // what the last check found, until the light explains the view again
  std::optional<std::int64_t> checked_us_;
  double checked_agreement_ = 0;
  ReposePolicy repose_;
  std::optional<Eigen::Vector3d> repose_turn_;
  std::uint32_t generation_ = 0;
};

}  // namespace occmap
