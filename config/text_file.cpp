#include "config/text_file.h"

#include <cerrno>
#include <cstdio>
#include <memory>
#include <system_error>

#include "config/input_error.h"

namespace occmap {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

[[noreturn]] void throwCannotRead(const std::filesystem::path& file, std::string_view what,
                                  int error) {
  // std::generic_category().message is strerror without its shared buffer: loading may run on any
  // thread (a reload).
  throw InputError(
      file.string(), 0, "",
      "cannot read " + std::string(what) + " file: " + std::generic_category().message(error));
}

}  // namespace

std::string readTextFile(const std::filesystem::path& file, std::string_view what) {
  errno = 0;
  const std::unique_ptr<std::FILE, FileCloser> stream(std::fopen(file.c_str(), "rb"));
  if (!stream) throwCannotRead(file, what, errno);
  std::string text;
  char buffer[65536];
  for (;;) {
    const std::size_t count = std::fread(buffer, 1, sizeof buffer, stream.get());
    text.append(buffer, count);
    if (text.size() > kMaxInputFileBytes) {
      throw InputError(file.string(), 0, "",
                       "is larger than " + std::to_string(kMaxInputFileBytes >> 20) + " MiB; a " +
                           std::string(what) +
                           " file is a few kilobytes of text: check that this is the right file");
    }
    if (count < sizeof buffer) break;
  }
  // A folder opens but does not read (EISDIR): report that, not an empty file.
  if (std::ferror(stream.get())) throwCannotRead(file, what, errno != 0 ? errno : EIO);
  return text;
}

std::string_view firstContent(std::string_view text) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  return first == std::string_view::npos ? std::string_view{} : text.substr(first);
}

}  // namespace occmap
