#include "core/non_finite.hpp"

#include <algorithm>
#include <cmath>

namespace arena {

std::string channelName(const std::vector<LayerSpec>& specs, const std::string& layer, int channel) {
  for (const LayerSpec& spec : specs)
    // A layer written twice (colour as "color.R" and as the viewers' plain "R") is named by its
    // own layer name, never by the top-level copy.
    if (spec.name == layer && !spec.topLevel && channel < spec.channels()) return spec.channelName(channel);
  return layer + "." + std::to_string(channel);
}

long countNonFinite(const LayerSet& layers, const std::vector<LayerSpec>& specs,
                    const std::string& prefix, NonFiniteCounts& counts,
                    const std::vector<std::string>& names) {
  long total = 0;
  for (const auto& [name, image] : layers.all()) {
    if (!names.empty() && std::find(names.begin(), names.end(), name) == names.end()) continue;
    for (int c = 0; c < image.channels(); ++c) {
      long n = 0;
      for (float v : image.planeSpan(c)) n += !std::isfinite(v);
      if (n) counts[prefix + channelName(specs, name, c)] += n;
      total += n;
    }
  }
  return total;
}

long replaceNonFinite(Image& image) {
  long count = 0;
  for (float& v : image.raw())
    if (!std::isfinite(v)) {
      v = 0.0f;
      ++count;
    }
  return count;
}

const Image& finiteInput(const Image& image, Image& scratch) {
  if (nonFiniteValues(image) == 0) return image;
  scratch = image;
  replaceNonFinite(scratch);
  return scratch;
}

long nonFiniteValues(const Image& image) {
  long count = 0;
  for (float v : image.raw()) count += !std::isfinite(v);
  return count;
}

long invalidateNonFinitePixels(Image& samples, int validChannel) {
  float* valid = samples.plane(validChannel);
  long marked = 0;
  for (size_t i = 0; i < samples.pixelCount(); ++i)
    for (int c = 0; c < samples.channels(); ++c)
      if (!std::isfinite(samples.plane(c)[i])) {
        marked += valid[i] != 0.0f;
        valid[i] = 0.0f;
        break;
      }
  return marked;
}

long nonZeroPixels(const Image& image, int channel) {
  const float* plane = image.plane(channel);
  long count = 0;
  for (size_t i = 0; i < image.pixelCount(); ++i) count += plane[i] != 0.0f;
  return count;
}

std::string describeNonFinite(const NonFiniteCounts& counts) {
  std::string out;
  for (const auto& [where, n] : counts) out += (out.empty() ? "" : ", ") + where + " x" + std::to_string(n);
  return out;
}

long totalNonFinite(const NonFiniteCounts& counts) {
  long total = 0;
  for (const auto& [where, n] : counts) total += n;
  return total;
}

}  // namespace arena
