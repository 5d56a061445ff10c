#pragma once
// An à-trous iteration (Dammertz 2010; common/atrous.hpp) whose edge-stopping product also holds
// the specular-lobe similarity (Tokuyoshi 2016; common/specular_lobe.hpp), the combination the
// CEDEC 2021 talk filters with ("3D座標 + Specular Lobe + ID + 輝度", p. "4.1.4"), and which can
// carry extra images through the same weights (the talk's pre-spatial pass filters the signal
// and its second moment together, p. "4.2.3": "1次モーメントのフィルタカラー / 2次モーメント").
// With the lobe term off it computes what atrousIteration() does (same kernel, same border and
// sky rules); the weights of the extra images are those of the colour.
#include "core/image.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/specular_lobe.hpp"

namespace arena {

struct LobeTerm {
  const Image* lobes = nullptr;  // computeSpecularLobes(); nullptr = term off
  float beta = 1.0f;             // the talk's exponent on the similarity
};

// One iteration (tap spacing 2^iteration) from colorIn (3 channels) to colorOut; `extraIn` (any
// channels, <= 4) is filtered with the same weights into `extraOut` when given.
void lobeAtrousIteration(int iteration, const AtrousSettings& settings, const AtrousGuide& guide,
                         const LobeTerm& lobe, const Image& colorIn, Image& colorOut,
                         const Image* extraIn = nullptr, Image* extraOut = nullptr);

}  // namespace arena
