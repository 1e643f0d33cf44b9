#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace occmap {

// Config and calibration files are a few kilobytes; anything this large is the wrong file (or a
// device such as /dev/zero that would never end).
inline constexpr std::size_t kMaxInputFileBytes = 16u << 20;

// The whole file as text. A missing, unreadable or oversized file is an InputError naming the file,
// with the system's reason; `what` says what kind of file it should have been ("config").
std::string readTextFile(const std::filesystem::path& file, std::string_view what);

// The text from its first character that is not a byte order mark or a blank: what tells the kinds
// of calibration file apart.
std::string_view firstContent(std::string_view text);

}  // namespace occmap
