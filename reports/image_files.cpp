#include "reports/image_files.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cstdio>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace arena {

std::string frameName(const char* prefix, int t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s_%04d.png", prefix, t);
  return buf;
}

void writePng(const std::filesystem::path& path, const Image& display) {
  const int w = display.width(), h = display.height();
  cv::Mat mat(h, w, display.channels() == 1 ? CV_8UC1 : CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      auto q = [&](int c) { return uint8_t(std::clamp(display.at(x, y, c), 0.0f, 1.0f) * 255.0f + 0.5f); };
      if (display.channels() == 1) {
        mat.at<uint8_t>(y, x) = q(0);
      } else {  // OpenCV stores BGR
        mat.at<cv::Vec3b>(y, x) = cv::Vec3b(q(2), q(1), q(0));
      }
    }
  // Encoded in memory, written by writeFileBytes: a full disk is reported with the path and errno.
  std::vector<uint8_t> png;
  if (!cv::imencode(".png", mat, png)) throw Error(path.string() + ": cannot encode PNG");
  writeAtomically(path, [&](const std::filesystem::path& tmp) { writeFileBytes(tmp, std::string(png.begin(), png.end())); });
}

}  // namespace arena
