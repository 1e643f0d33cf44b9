#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "core/image.h"

namespace occmap {

// Reads an 8-bit image as grey: grey as it is, colour converted to luminance (ITU-R BT.601, as
// OpenCV's cvtColor does). Another bit depth, an unreadable, corrupt or truncated file gives
// nothing and `error` says what is wrong with which file.
std::optional<Image> readGreyImage(const std::filesystem::path& file, std::string& error);

// Writes an 8-bit grey PNG; false with `error` set when the file cannot be written.
bool writeGreyPng(const std::filesystem::path& file, const Image& image, std::string& error);

}  // namespace occmap
