#pragma once
// A camera's background that follows the light (issue 13, docs/lighting.md). The paper compares
// every frame with a background captured once; a building's light does not keep still. Two of the
// three parts of the model live here:
// - The light's gain, estimated every frame from the pixels that look like the background: a
//   multiplicative change (daylight, a dimmer, the camera's gain and exposure; with the camera's
//   gamma still multiplicative) leaves live = gain x background wherever nothing stands. Each
//   frame is then compared in the background's own light: live / gain against the background with
//   the same threshold, so an object's contrast counts as it did when the background was taken
//   (the threshold is scaled with the light, and a dark object in dim light is still found).
// - Slow drift, followed conservatively: a background pixel moves toward the live one (in the
//   background's light) only while its whole 8 x 8 tile was judged unchanged, so never where
//   something stands or at its edges. A box put down stays changed, and so occupied, for as long as
//   it stays.
// When no gain explains what the camera sees (bumped, covered, lights out, or more than half of the
// view covered) the model says so (explained() false) and leaves its background as it is.
// No I/O, no threads; after construction nothing is allocated.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/image.h"
#include "core/local_light.h"

namespace occmap {

struct LightingSettings {
  bool adapt = true;  // false: today's fixed background, exactly
  // The time constant of the drift, in frames: an unchanged background pixel covers about 63 % of
  // a lasting difference in this many frames (256: about 8.5 s at 30 fps); below 16, as 16.
  int drift_frames = 256;
  // The share of the usable sampled pixels that must agree with one gain (within the agreement
  // band) for the change to count as light. Below it the camera is degraded. The trade: objects
  // may cover up to 30 % of a camera's view (people in the simulated room leave 89 to 95 % of the
  // samples agreeing), while a camera knocked aside by 1 degree leaves about half agreeing, since
  // the floor and walls look alike wherever they are.
  double min_agreement = 0.7;
  // Below min_agreement, a view that is not moved (core/view_motion.h: a crowd, people's shadows,
  // light the model does not explain) still counts while at least this share agrees: its gain is
  // then still the light's, and what it finds changed is no less than what stands there. Under it
  // (lights out, a covered lens) or moved, the camera is left out.
  double min_agreement_in_place = 0.4;
  // The agreement band in grey levels at gain 1 (wider in a brighter light), about a pixel's noise
  // plus the model's error; a sample agrees when |live - gain x background| is under it.
  int agreement_grey_levels = 8;
  // Whether changes of light in part of the view (a lamp, a patch of sun, a shadow) are told apart
  // from objects by the background's texture (core/local_light.h).
  bool local = true;
};

class LightingModel {
 public:
  // `background` is copied: it is the empty scene in the light of the moment it was taken.
  LightingModel(ImageView background, const LightingSettings& settings);

  // Starts again from a new background (a recapture): gain 1, nothing learnt kept.
  void reset(ImageView background);

  // Before the difference, once per frame: estimates the light's gain from `live` and returns the
  // frame in the background's light (live / gain, rounded, at most 255). Compare it with
  // background() under the usual threshold. The view is valid until the next call.
  // The whole frame, in one pass down its rows: measured faster for a frame that is not in the
  // cache than correcting only the strips the difference reads, or correcting on the way through
  // the difference (docs/lighting.md, "Measured").
  ImageView correct(ImageView live);
  // The background in its own light for the frame correct() last saw. Where that frame's light
  // saturates the sensor (gain > 1) it is capped at what a saturated pixel reads, since a pixel at
  // 255 may hide any brighter background.
  ImageView background() const;

  // After the difference, once per frame: `changed_tiles` is the frame's changed-pixel mask
  // (core/fusion_kernel.h's tile layout). Pixels of wholly unchanged tiles move toward the frame;
  // one band of tile rows a frame, in turn. Nothing moves in a frame the gain did not explain, nor
  // in a tile explainLocally cleared as light in part of the view.
  void follow(ImageView live, const std::uint8_t* changed_tiles);

  // Between the two, when settings.local: clears the changed tiles that a light in part of the view
  // explains (core/local_light.h); `corrected` is what correct() returned. Returns how many.
  std::size_t explainLocally(ImageView corrected, int threshold, std::uint8_t* changed_tiles);

  double gain() const { return gain_; }
  // The share of the usable sampled pixels that agreed with the gain, in the last frame (and of
  // those the gain says are clipped, which are, counted as agreeing).
  double agreement() const { return agreement_; }
  // Whether the last frame's change was light (agreement at least min_agreement). After
  // explainLocally, samples in tiles a local light explains count as agreeing.
  bool explained() const { return explained_; }
  // The pixels' noise in the background's light (standard deviation, grey levels): the spread of
  // the samples that agreed with the gain, in the last frame.
  double noise() const { return noise_; }
  // The local light's step, when settings.local.
  const LocalLight* local() const { return local_ ? &*local_ : nullptr; }
  // Tiles the local light explained in the last frame.
  std::size_t locallyExplained() const { return locally_explained_; }

  // Sampling: every kSampleStep-th pixel of every kSampleStep-th row.
  static constexpr int kSampleStep = 4;
  // follow() updates one of kBands bands of tile rows per frame: each row every 8 frames (a
  // quarter of a second at 30 fps), an eighth of the frame's pixels a frame. With 4 bands the drift
  // was a quarter of the model's time (measured); with 16, the day scene at 5 fps (a visit every
  // 3.2 s) lost 0.7 % of its worst map's free floor, with 8 nothing that matters
  // (docs/lighting.md).
  static constexpr int kBands = 8;

 private:
  void estimateGain(ImageView live);
  // The gain's samples in a sampled row (samples_ holds them row by row).
  std::size_t samplesPerRow() const {
    return static_cast<std::size_t>((width_ + kSampleStep - 1) / kSampleStep);
  }
  void updateInverse();

  LightingSettings settings_;
  int width_ = 0;
  int height_ = 0;
  std::vector<std::uint16_t> reference_q8_;  // background x 256: the drift's fine steps
  Image reference_;                          // reference_q8_ rounded to grey levels
  Image captured_;                           // the background as captured, for explainLocally
  Image corrected_;                          // the last frame in the background's light
  Image capped_;                             // reference_ capped where the light saturates
  bool capped_in_use_ = false;
  std::uint8_t capped_cap_ = 255;         // the cap capped_ holds; 255: none yet
  std::vector<std::uint32_t> histogram_;  // log-ratio bins of the gain estimate
  std::vector<std::uint16_t> samples_;    // this frame's, row by row: background << 8 | live
  float agreement_gain_ = 1.0f;  // the median's gain and the band the samples were judged by
  float agreement_band_ = 0.0f;
  std::size_t usable_ = 0;
  std::size_t clipped_ = 0;  // samples the light clips as it says: they agree, but are not usable
  std::size_t agreeing_ = 0;
  std::vector<std::uint8_t> quiet_row_;    // follow(): 1 per pixel of a wholly unchanged tile
  std::int32_t inverse_gain_q16_ = 65536;  // 1 / gain in 16.16
  double gain_ = 1.0;
  double agreement_ = 1.0;
  double noise_ = 1.0;
  bool explained_ = true;
  std::optional<LocalLight> local_;
  std::size_t locally_explained_ = 0;
  bool local_ran_ = false;  // whether local_ explained this frame's changed tiles
  std::uint64_t frames_ = 0;
};

}  // namespace occmap
