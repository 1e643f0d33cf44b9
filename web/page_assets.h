#pragma once
// The page `occmap web` serves (web/page/: HTML, CSS, JavaScript, the icon), compiled into the
// binary by web/embed_page.cmake: it works on a site without internet, with nothing installed
// beside the binary and nothing for a user to build.

#include <cstdint>
#include <span>
#include <string_view>

namespace occmap::web {

struct PageAsset {
  std::string_view path;          // "/index.html": the file's name under web/page/
  std::string_view content_type;  // "text/html; charset=utf-8"
  std::span<const std::uint8_t> bytes;
};

// Every file of the page (generated: page_files.cpp in the build tree).
std::span<const PageAsset> pageAssets();

// The file served at `path` ("/" is "/index.html"), or nullptr.
const PageAsset* findPageAsset(std::string_view path);

}  // namespace occmap::web
