#pragma once

#include <filesystem>
#include <memory>
#include <vector>

#include "capture/frame_source.h"
#include "capture/image_file.h"

namespace occmap {

// files://<glob>: a camera's images from disk, in natural (numeric-aware) order of their paths.
class FilesSource final : public FrameSource {
 public:
  // Empty with `error` set when the glob matches nothing (saying so when its folder does not
  // exist) or the first image cannot be read.
  static std::unique_ptr<FilesSource> open(const std::string& pattern, std::string& error);

  int width() const override { return width_; }
  int height() const override { return height_; }
  std::uint64_t frameCount() const override { return files_.size(); }
  Status read(Frame& frame) override;
  bool rewind() override {
    next_ = 0;
    started();
    return true;
  }
  const std::vector<std::filesystem::path>& files() const { return files_; }

 private:
  explicit FilesSource(std::vector<std::filesystem::path> files) : files_(std::move(files)) {}

  std::vector<std::filesystem::path> files_;
  std::size_t next_ = 0;
  std::uint64_t delivered_ = 0;  // frame numbers keep counting across rewinds
  int width_ = 0;
  int height_ = 0;
  GreyImageReader reader_;  // holds the frame read() last gave out
};

}  // namespace occmap
