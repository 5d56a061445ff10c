#pragma once
// The colour a split denoiser's two filtered signals make: the tracer demodulates the first
// vertex's diffuse and specular radiance by their albedos (Schied et al. 2017, SVGF: filter the
// untextured illumination), so the final colour puts the albedos back and adds the emission seen
// directly.
#include "core/image.hpp"

namespace arena {

// color = albedo * diffuse + specAlbedo * specular + emission, per pixel and channel (all five
// of one size, three channels); `color` is (re)sized to match.
void remodulate(const Image& albedo, const Image& diffuse, const Image& specAlbedo, const Image& specular,
                const Image& emission, Image& color);

}  // namespace arena
