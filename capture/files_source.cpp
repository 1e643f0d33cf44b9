#include "capture/files_source.h"

#include <algorithm>

#include <glob.h>

#include "capture/image_file.h"
#include "capture/source_spec.h"

namespace occmap {

std::unique_ptr<FilesSource> FilesSource::open(const std::string& pattern, std::string& error) {
  glob_t matches{};
  const int status = ::glob(pattern.c_str(), GLOB_ERR, nullptr, &matches);
  std::vector<std::filesystem::path> files;
  if (status == 0) {
    for (std::size_t i = 0; i < matches.gl_pathc; ++i) files.emplace_back(matches.gl_pathv[i]);
  }
  ::globfree(&matches);
  if (status == GLOB_NOMATCH || (status == 0 && files.empty())) {
    error = "no files match " + pattern;
    return nullptr;
  }
  if (status != 0) {
    error = "cannot list files for " + pattern + " (a folder on the way is unreadable?)";
    return nullptr;
  }
  std::sort(files.begin(), files.end(),
            [](const auto& a, const auto& b) { return naturalLess(a.string(), b.string()); });
  std::unique_ptr<FilesSource> source(new FilesSource(std::move(files)));
  std::optional<Image> first = readGreyImage(source->files_.front(), error);
  if (!first) return nullptr;
  source->width_ = first->width();
  source->height_ = first->height();
  return source;
}

FrameSource::Status FilesSource::read(Frame& frame) {
  if (next_ >= files_.size()) return Status::kEnd;
  const std::filesystem::path& file = files_[next_];
  std::string error;
  std::optional<Image> image = readGreyImage(file, error);
  if (!image) return fail(error);
  if (image->width() != width_ || image->height() != height_) {
    return fail("image " + file.string() + " is " + std::to_string(image->width()) + "x" +
                std::to_string(image->height()) + ", but this camera's first image is " +
                std::to_string(width_) + "x" + std::to_string(height_));
  }
  current_ = std::move(*image);
  frame.image = current_.view();
  frame.sequence = delivered_++;
  ++next_;
  frame.capture_time_us = hostTimeMicroseconds();
  return Status::kFrame;
}

}  // namespace occmap
