#pragma once
// Error maps for eyes: per-pixel error images written as colour PNGs with a fixed, stated scale,
// and their inverse (the report reads a kept map back to measure a region the user marks).
//   - FLIP maps in the magma colour map, as the FLIP tool writes them (FLIP value 0..1 -> magma).
//   - Relative-error maps: the per-pixel relative squared error (d - r)^2 / (r^2 + eps), averaged
//     over R, G, B (metrics.md's relMSE before the mean over pixels), on a log10 scale from
//     1e-4 to 1e1, in viridis (a different map, so a FLIP map and a relative-error map are never
//     confused when flipped).
// Colour maps: matplotlib's magma and viridis (CC0), sampled at 17 evenly spaced points and
// interpolated linearly; every map is quantised to 256 colours, so an 8-bit PNG decodes exactly.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/image.hpp"

namespace arena {

struct ColorMap {
  const char* name;
  std::array<std::array<uint8_t, 3>, 17> stops;  // sRGB 8-bit colours at 0, 1/16, ..., 1
};
const ColorMap& magmaColorMap();
const ColorMap& viridisColorMap();

// The map's 256 colours: entry i is the colour of value i / 255.
std::array<std::array<uint8_t, 3>, 256> colorTable(const ColorMap& map);

// A one-channel image of values in [0, 1] (NaN counts as 0, values are clamped) as RGB in [0, 1]
// through the map, quantised to its 256 colours.
Image applyColorMap(const Image& values, const ColorMap& map);

// The inverse for an 8-bit RGB image written through applyColorMap: per pixel the value (i / 255)
// of the table colour nearest to it. `rgb` holds pixels as interleaved R, G, B bytes.
std::vector<float> decodeColorMap(std::span<const uint8_t> rgb, const ColorMap& map);

// The relative-error map's scale: log10 of the per-pixel relative squared error, clamped.
constexpr double kRelErrorMapLog10Min = -4.0, kRelErrorMapLog10Max = 1.0;
// Per-pixel relative squared error averaged over the 3 colour channels of d (test) and r
// (reference).
Image relativeSquaredError(const Image& d, const Image& r);
// The relative-error map's colours for d against r (viridis on the log scale above).
Image relativeErrorMap(const Image& d, const Image& r);
// The same of values relativeSquaredError computed.
Image relativeErrorMap(Image relativeSquaredErrors);
// A decoded relative-error map value (0..1) back to the relative squared error it stands for.
double relativeErrorOfMapValue(double value);

// The run keeps a relative error's values beside its map as the means of blocks of this many
// pixels square (edge blocks smaller): a region's relMSE from whole blocks is exact, at 1/64 of
// the per-pixel file's size. The report's crop tiles are whole blocks.
constexpr int kRelErrorBlock = 8;
// Per block of `block` x `block` pixels of a one-channel image, the mean of its pixels (an image
// ceil(w / block) x ceil(h / block), accumulated in double).
Image blockMeans(const Image& values, int block);

}  // namespace arena
