#include "tracer/texture.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"

namespace arena {

float srgbToLinear(float c) {
  // IEC 61966-2-1: the linear segment below 0.04045, the 2.4 power above.
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

namespace {

int wrapIndex(int i, int n, TextureWrap mode) {
  switch (mode) {
    case TextureWrap::Clamp:
      return std::clamp(i, 0, n - 1);
    case TextureWrap::Mirror: {
      const int period = 2 * n;
      int m = i % period;
      if (m < 0) m += period;
      return m < n ? m : period - 1 - m;
    }
    case TextureWrap::Repeat:
      break;
  }
  int m = i % n;
  return m < 0 ? m + n : m;
}

}  // namespace

glm::vec4 TextureRef::sample(glm::vec2 uv) const {
  const TextureImage& img = *image;
  // Texel (i, j) covers [i, i+1) x [j, j+1) in pixel units, row j counted from the top.
  const float x = uv.x * float(img.width) - 0.5f;
  const float y = (1.0f - uv.y) * float(img.height) - 0.5f;
  if (!std::isfinite(x) || !std::isfinite(y)) return img.texels[0];
  // Far outside [0, 1] the float -> int conversion would overflow: reduce first (exact for repeat
  // and mirror, whose periods are whole texel counts; clamp only needs the sign).
  auto reduce = [](float p, int n) {
    const float period = 2.0f * float(n);
    return std::abs(p) < 1e6f ? p : p - period * std::floor(p / period);
  };
  const float rx = reduce(x, img.width), ry = reduce(y, img.height);
  const float fx = std::floor(rx), fy = std::floor(ry);
  const float tx = rx - fx, ty = ry - fy;
  const int x0 = wrapIndex(int(fx), img.width, wrapU),
            x1 = wrapIndex(int(fx) + 1, img.width, wrapU);
  const int y0 = wrapIndex(int(fy), img.height, wrapV),
            y1 = wrapIndex(int(fy) + 1, img.height, wrapV);
  auto at = [&](int i, int j) { return img.texels[size_t(j) * size_t(img.width) + size_t(i)]; };
  return (1.0f - ty) * ((1.0f - tx) * at(x0, y0) + tx * at(x1, y0)) +
         ty * ((1.0f - tx) * at(x0, y1) + tx * at(x1, y1));
}

std::shared_ptr<const TextureImage> decodeTexture(const std::string& bytes, const std::string& name,
                                                  bool srgb) {
  cv::Mat raw;
  try {
    raw = cv::imdecode(cv::Mat(1, int(bytes.size()), CV_8U, const_cast<char*>(bytes.data())),
                       cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw Error(name + ": cannot decode the texture image: " + e.what());
  }
  if (raw.empty())
    throw Error(name + ": cannot decode the texture image (not an image format OpenCV reads)");
  if (raw.cols > kMaxTextureSide || raw.rows > kMaxTextureSide)
    throw Error(name + ": texture of " + std::to_string(raw.cols) + "x" + std::to_string(raw.rows) +
                " exceeds the " + std::to_string(kMaxTextureSide) + "-texel side limit");
  const int channels = raw.channels();
  if (channels != 1 && channels != 3 && channels != 4)
    throw Error(name + ": texture with " + std::to_string(channels) +
                " channels (expected 1, 3 or 4)");
  double scale = 1.0;
  bool encoded = srgb;  // integer images carry the transfer curve; float ones are linear
  switch (raw.depth()) {
    case CV_8U:
      scale = 1.0 / 255.0;
      break;
    case CV_16U:
      scale = 1.0 / 65535.0;
      break;
    case CV_32F:
      encoded = false;
      break;
    default:
      throw Error(name + ": texture sample type " + std::to_string(raw.depth()) +
                  " (expected 8- or 16-bit integers or 32-bit floats)");
  }
  cv::Mat values;
  raw.convertTo(values, CV_32F, scale);
  auto out = std::make_shared<TextureImage>();
  out->file = name;
  out->width = values.cols;
  out->height = values.rows;
  out->texels.resize(size_t(values.cols) * size_t(values.rows));
  // sRGB decoding through a table per 8-bit level would be faster; 16-bit images need the curve.
  auto colour = [&](float v) {
    if (!std::isfinite(v)) return 0.0f;
    return encoded ? srgbToLinear(std::clamp(v, 0.0f, 1.0f)) : v;
  };
  for (int y = 0; y < values.rows; ++y) {
    const float* row = values.ptr<float>(y);
    for (int x = 0; x < values.cols; ++x) {
      const float* p = row + size_t(x) * size_t(channels);
      glm::vec4 t;
      if (channels == 1) {  // grey
        t = glm::vec4(glm::vec3(colour(p[0])), 1.0f);
      } else {  // OpenCV orders BGR(A)
        t = glm::vec4(colour(p[2]), colour(p[1]), colour(p[0]), channels == 4 ? p[3] : 1.0f);
      }
      out->texels[size_t(y) * size_t(values.cols) + size_t(x)] = t;
    }
  }
  return out;
}

}  // namespace arena
