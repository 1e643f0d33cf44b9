#include "capture/image_file.h"

#include <cerrno>
#include <cstring>
#include <mutex>
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

// libjpeg decodes a JPEG that was cut short without an error: it warns, fills the missing rows
// with grey, and OpenCV hands that out as the picture. A background or a frame with a grey band
// carves a wrong map, so a JPEG must reach its end-of-image marker (FF D9). It is found by walking
// the segments (each gives its length) and, after a start of scan, the entropy-coded data, in
// which FF is always followed by 00 (a stuffed byte), FF (fill) or a restart marker unless a
// marker starts. Bytes after the end of the image (some cameras append their own) are allowed.
bool jpegReachesItsEnd(const std::vector<char>& file) {
  const auto* b = reinterpret_cast<const unsigned char*>(file.data());
  const std::size_t n = file.size();
  std::size_t at = 2;  // after the start-of-image marker FF D8
  for (;;) {
    if (at >= n || b[at] != 0xFF) return false;  // a marker must start here
    while (at < n && b[at] == 0xFF) ++at;        // fill bytes before the marker's code
    if (at >= n) return false;
    const unsigned marker = b[at++];
    if (marker == 0xD9) return true;
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length follows
    if (at + 2 > n) return false;
    const std::size_t length = (static_cast<std::size_t>(b[at]) << 8) | b[at + 1];
    if (length < 2 || length > n - at) return false;
    at += length;
    if (marker != 0xDA) continue;
    for (;;) {  // a start of scan: its entropy-coded data runs up to the next marker
      const void* ff = at < n ? std::memchr(b + at, 0xFF, n - at) : nullptr;
      if (ff == nullptr) return false;
      at = static_cast<std::size_t>(static_cast<const unsigned char*>(ff) - b);
      if (at + 1 >= n) return false;
      const unsigned next = b[at + 1];
      if (next == 0x00 || (next >= 0xD0 && next <= 0xD7)) {
        at += 2;
      } else if (next == 0xFF) {
        at += 1;
      } else {
        break;
      }
    }
  }
}

bool isJpeg(const std::vector<char>& file) {
  return file.size() >= 2 && static_cast<unsigned char>(file[0]) == 0xFF &&
         static_cast<unsigned char>(file[1]) == 0xD8;
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
  if (isJpeg(b.bytes) && !jpegReachesItsEnd(b.bytes)) {
    error = "cannot decode image " + file.string() +
            ": the JPEG data ends before its end-of-image marker (truncated or corrupt)";
    return std::nullopt;
  }
  // cv::imdecode leaves its `dst` as it was, and says nothing, when no decoder knows the bytes or
  // the header cannot be read: the last image would come out again as this one. A decoder that
  // succeeds writes every pixel, so a stamp put into the held picture's first bytes and found
  // there unchanged afterwards means nothing was decoded. (A picture that really starts with
  // these 16 bytes would be taken for a failure, once in 2^128.)
  static constexpr unsigned char kStamp[16] = {0x6f, 0x63, 0x63, 0x6d, 0x61, 0x70, 0x00, 0xff,
                                               0x5a, 0xa5, 0x13, 0x37, 0xc0, 0xde, 0x01, 0xfe};
  const std::uint8_t* stamped = nullptr;
  if (!b.decoded.empty() && b.decoded.isContinuous() &&
      b.decoded.total() * b.decoded.elemSize() >= sizeof kStamp) {
    std::memcpy(b.decoded.data, kStamp, sizeof kStamp);
    stamped = b.decoded.data;
  } else {
    b.decoded.release();
  }
  bool decoded = false;
  try {
    // Decodes into b.decoded's pixels when size and type are those of the last image.
    const cv::Mat bytes(1, static_cast<int>(b.bytes.size()), CV_8UC1, b.bytes.data());
    cv::imdecode(bytes, cv::IMREAD_UNCHANGED, &b.decoded);
    decoded = !b.decoded.empty() &&
              !(b.decoded.data == stamped && std::memcmp(stamped, kStamp, sizeof kStamp) == 0);
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
  return writeGreyPng(file, image.view(), error);
}

bool writeGreyPng(const std::filesystem::path& file, ImageView image, std::string& error) {
  const cv::Mat mat(image.height, image.width, CV_8UC1, const_cast<std::uint8_t*>(image.data),
                    static_cast<std::size_t>(image.stride));
  // One write at a time in the process: OpenCV 4.6's imwrite assigns a string its encoders share,
  // so two threads writing at once race (ThreadSanitizer caught it in occmap record, one thread per
  // camera). Encoding a 640 x 480 PNG takes a few milliseconds, so four cameras at 30 fps still
  // fit.
  static std::mutex one_writer;
  const std::lock_guard lock(one_writer);
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
