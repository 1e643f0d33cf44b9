#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "core/image.h"

namespace occmap {

// Reads 8-bit images as grey, one after another, into buffers it keeps: grey as it is, colour
// converted to luminance (ITU-R BT.601, as OpenCV's cvtColor does). Once the first image has sized
// them, further images of that size and kind reuse the file bytes, the decoded picture and the grey
// one, so a camera that reads a file per frame allocates no pixel memory per frame (OpenCV's
// decoders still make their own small state for each file).
class GreyImageReader {
 public:
  GreyImageReader();
  ~GreyImageReader();
  GreyImageReader(const GreyImageReader&) = delete;
  GreyImageReader& operator=(const GreyImageReader&) = delete;

  // The image, valid until the next read(). Another bit depth, an unreadable, corrupt or
  // truncated file gives nothing and `error` says what is wrong with which file.
  std::optional<ImageView> read(const std::filesystem::path& file, std::string& error);

 private:
  struct Buffers;
  std::unique_ptr<Buffers> buffers_;
};

// One image read as GreyImageReader does, into an Image of its own.
std::optional<Image> readGreyImage(const std::filesystem::path& file, std::string& error);

// Writes an 8-bit grey PNG; false with `error` set when the file cannot be written.
bool writeGreyPng(const std::filesystem::path& file, const Image& image, std::string& error);
// The same for pixels the caller does not own (a source's frame), written where they lie.
bool writeGreyPng(const std::filesystem::path& file, ImageView image, std::string& error);

}  // namespace occmap
