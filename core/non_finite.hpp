#pragma once
// NaN/Inf in layer sets: counted per channel, under the channel's EXR name ("normal.Y",
// "gradient.lumNew"), and replaced where a consumer must not see them. One documented rule for
// every input a denoiser reads (docs/metrics.md, "Non-finite inputs"): a non-finite value becomes 0,
// and the results say how many, in which layer and channel.
#include <map>
#include <string>
#include <vector>

#include "core/exr_io.hpp"

namespace arena {

// "where: layer.channel" -> how many NaN/Inf values.
using NonFiniteCounts = std::map<std::string, long>;

// The channel's name as the EXR file writes it ("normal.Y", "roughness"), from `specs`; a layer
// `specs` does not list is named by index ("extra.2").
std::string channelName(const std::vector<LayerSpec>& specs, const std::string& layer, int channel);

// Adds the NaN/Inf count of every channel of the layers named in `names` (every layer when
// `names` is empty) to `counts`, keyed `prefix + channelName(...)`; returns the total added.
long countNonFinite(const LayerSet& layers, const std::vector<LayerSpec>& specs,
                    const std::string& prefix, NonFiniteCounts& counts,
                    const std::vector<std::string>& names = {});

// Replaces NaN/Inf by 0 in place in `image`; returns how many were replaced.
long replaceNonFinite(Image& image);
// How many of `image`'s values (every channel) are NaN/Inf.
long nonFiniteValues(const Image& image);
// `image` as a denoiser reads it: `image` itself when every value is finite, else `scratch`
// holding a copy with NaN/Inf replaced by 0. What is measured of an input (its error, its noise)
// is measured on this, as the denoisers see it, not left NaN by one bad pixel.
const Image& finiteInput(const Image& image, Image& scratch);
// Sets channel `validChannel` to 0 at every pixel where any channel is NaN/Inf (a sample that a
// consumer must then skip); returns how many pixels it marked.
long invalidateNonFinitePixels(Image& samples, int validChannel);
// How many pixels hold a non-zero value in channel `channel`.
long nonZeroPixels(const Image& image, int channel);

// "normal.Y x30, gradients: gradient.lumNew x2", in key order.
std::string describeNonFinite(const NonFiniteCounts& counts);

// The sum of the counts.
long totalNonFinite(const NonFiniteCounts& counts);

}  // namespace arena
