#include "capture/files_source.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <glob.h>

#include "base/clock.h"
#include "capture/image_file.h"
#include "capture/source_spec.h"

namespace occmap {

namespace {

// glob(3) names the folder it could not open only to a callback without a context pointer: the
// first failure of this thread's glob() is kept here.
struct GlobFailure {
  std::string folder;
  int error = 0;
};
thread_local GlobFailure glob_failure;

int noteGlobFailure(const char* folder, int error) {
  if (glob_failure.error == 0) glob_failure = {folder, error};
  return 1;  // stop: the rest of the list would be incomplete
}

}  // namespace

std::unique_ptr<FilesSource> FilesSource::open(const std::string& pattern, std::string& error) {
  glob_t matches{};
  glob_failure = {};
  const int status = ::glob(pattern.c_str(), GLOB_ERR, noteGlobFailure, &matches);
  std::vector<std::filesystem::path> files;
  if (status == 0) {
    for (std::size_t i = 0; i < matches.gl_pathc; ++i) files.emplace_back(matches.gl_pathv[i]);
  }
  ::globfree(&matches);
  if (status == GLOB_NOMATCH || (status == 0 && files.empty())) {
    error = "no files match " + pattern;
    return nullptr;
  }
  if (status == GLOB_ABORTED && glob_failure.error == ENOENT) {
    error = "no files match " + pattern + ": the folder " + glob_failure.folder + " does not exist";
    return nullptr;
  }
  if (status == GLOB_ABORTED && glob_failure.error != 0) {
    error = "cannot list files for " + pattern + ": cannot open the folder " + glob_failure.folder +
            ": " + std::strerror(glob_failure.error);
    return nullptr;
  }
  if (status != 0) {
    error = "cannot list files for " + pattern +
            (status == GLOB_NOSPACE ? ": out of memory" : ": glob() failed");
    return nullptr;
  }
  std::sort(files.begin(), files.end(),
            [](const auto& a, const auto& b) { return naturalLess(a.string(), b.string()); });
  std::unique_ptr<FilesSource> source(new FilesSource(std::move(files)));
  // The first image sets the camera's size, and sizes the reader's buffers for the frames after.
  const std::optional<ImageView> first = source->reader_.read(source->files_.front(), error);
  if (!first) return nullptr;
  source->width_ = first->width;
  source->height_ = first->height;
  return source;
}

FrameSource::Status FilesSource::read(Frame& frame) {
  if (next_ >= files_.size()) return ended();
  // Past this file whatever becomes of it: a bad one is skipped (the caller drops and counts it),
  // not read again and again while the good ones after it wait.
  const std::filesystem::path& file = files_[next_++];
  std::string error;
  const std::optional<ImageView> image = reader_.read(file, error);
  if (!image) return fail(error);
  if (image->width != width_ || image->height != height_) {
    return fail("image " + file.string() + " is " + std::to_string(image->width) + "x" +
                std::to_string(image->height) + ", but this camera's first image is " +
                std::to_string(width_) + "x" + std::to_string(height_));
  }
  frame.image = *image;  // the reader's buffer: valid until the next read(), as Frame says
  frame.sequence = delivered_++;
  frame.capture_time_us = hostTimeMicroseconds();
  return delivered();
}

}  // namespace occmap
