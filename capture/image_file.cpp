#include "capture/image_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace occmap {

std::optional<Image> readGreyImage(const std::filesystem::path& file, std::string& error) {
  // Read the bytes ourselves so that "cannot open" and "cannot decode" are told apart.
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    error = "cannot read image " + file.string() + ": " + std::strerror(errno);
    return std::nullopt;
  }
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    decoded.release();
  }
  if (decoded.empty()) {
    error = "cannot decode image " + file.string() +
            ": corrupt, truncated or not an image format OpenCV reads";
    return std::nullopt;
  }
  if (decoded.depth() != CV_8U) {
    error = "image " + file.string() + " has " + std::to_string(decoded.elemSize1() * 8) +
            "-bit samples; occmap needs 8-bit grey or colour images";
    return std::nullopt;
  }
  cv::Mat grey;
  switch (decoded.channels()) {
    case 1:
      grey = decoded;
      break;
    case 3:
      cv::cvtColor(decoded, grey, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(decoded, grey, cv::COLOR_BGRA2GRAY);
      break;
    default:
      error = "image " + file.string() + " has " + std::to_string(decoded.channels()) +
              " channels; occmap needs grey (1), colour (3) or colour with alpha (4)";
      return std::nullopt;
  }
  Image image(grey.cols, grey.rows);
  for (int v = 0; v < grey.rows; ++v) {
    std::memcpy(image.row(v), grey.ptr(v), static_cast<std::size_t>(grey.cols));
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
