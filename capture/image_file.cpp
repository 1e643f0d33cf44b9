#include "capture/image_file.h"

#include <cerrno>
#include <cstring>
#include <vector>

#include <fcntl.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sys/stat.h>
#include <unistd.h>

namespace occmap {

struct GreyImageReader::Buffers {
  std::vector<char> bytes;  // the file as it is on disk
  cv::Mat decoded;          // as the file holds it: grey, BGR or BGRA
  cv::Mat grey;             // converted from colour
};

GreyImageReader::GreyImageReader() : buffers_(std::make_unique<Buffers>()) {}
GreyImageReader::~GreyImageReader() = default;

namespace {

// The whole file into `bytes`, with POSIX calls so that nothing but `bytes` (when it must grow)
// is allocated; false with errno set.
bool readFile(const std::filesystem::path& file, std::vector<char>& bytes) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat status {};
  if (::fstat(fd, &status) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    return false;
  }
  bytes.resize(static_cast<std::size_t>(status.st_size));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t got = ::read(fd, bytes.data() + done, bytes.size() - done);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int saved = errno;
      ::close(fd);
      errno = saved;
      return false;
    }
    if (got == 0) break;  // the file shrank while we read it: decode what there is
    done += static_cast<std::size_t>(got);
  }
  bytes.resize(done);
  ::close(fd);
  return true;
}

}  // namespace

std::optional<ImageView> GreyImageReader::read(const std::filesystem::path& file,
                                               std::string& error) {
  Buffers& b = *buffers_;
  // Read the bytes ourselves so that "cannot open" and "cannot decode" are told apart.
  if (!readFile(file, b.bytes)) {
    error = "cannot read image " + file.string() + ": " + std::strerror(errno);
    return std::nullopt;
  }
  bool decoded = false;
  try {
    // Decodes into b.decoded's pixels when size and type are those of the last image.
    const cv::Mat bytes(1, static_cast<int>(b.bytes.size()), CV_8UC1, b.bytes.data());
    cv::imdecode(bytes, cv::IMREAD_UNCHANGED, &b.decoded);
    decoded = !b.decoded.empty();
  } catch (const cv::Exception&) {
    decoded = false;
  }
  if (!decoded) {
    error = "cannot decode image " + file.string() +
            ": corrupt, truncated or not an image format OpenCV reads";
    return std::nullopt;
  }
  if (b.decoded.depth() != CV_8U) {
    error = "image " + file.string() + " has " + std::to_string(b.decoded.elemSize1() * 8) +
            "-bit samples; occmap needs 8-bit grey or colour images";
    return std::nullopt;
  }
  const cv::Mat* grey = &b.decoded;
  switch (b.decoded.channels()) {
    case 1:
      break;
    case 3:
      cv::cvtColor(b.decoded, b.grey, cv::COLOR_BGR2GRAY);
      grey = &b.grey;
      break;
    case 4:
      cv::cvtColor(b.decoded, b.grey, cv::COLOR_BGRA2GRAY);
      grey = &b.grey;
      break;
    default:
      error = "image " + file.string() + " has " + std::to_string(b.decoded.channels()) +
              " channels; occmap needs grey (1), colour (3) or colour with alpha (4)";
      return std::nullopt;
  }
  return ImageView{grey->ptr(), grey->cols, grey->rows, static_cast<std::ptrdiff_t>(grey->step)};
}

std::optional<Image> readGreyImage(const std::filesystem::path& file, std::string& error) {
  GreyImageReader reader;
  const std::optional<ImageView> view = reader.read(file, error);
  if (!view) return std::nullopt;
  Image image(view->width, view->height);
  for (int v = 0; v < view->height; ++v) {
    std::memcpy(image.row(v), view->row(v), static_cast<std::size_t>(view->width));
  }
  return image;
}

bool writeGreyPng(const std::filesystem::path& file, const Image& image, std::string& error) {
  const cv::Mat mat(image.height(), image.width(), CV_8UC1,
                    const_cast<std::uint8_t*>(image.data()));
  bool written = false;
  try {
    written = cv::imwrite(file.string(), mat);
  } catch (const cv::Exception& e) {
    error = "cannot write " + file.string() + ": " + e.what();
    return false;
  }
  if (!written) error = "cannot write " + file.string() + ": " + std::strerror(errno);
  return written;
}

}  // namespace occmap
