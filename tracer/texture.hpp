#pragma once
// Image textures for asset materials: decoded once (OpenCV), stored as linear RGBA floats, sampled
// bilinearly at a surface's texture coordinates. No mip-maps: the G-buffer and every path vertex
// read the same point sample, so the albedo demodulation stays exact (minified textures alias, in
// the reference as in the frames).
#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <string>
#include <vector>

namespace arena {

enum class TextureWrap { Repeat, Clamp, Mirror };

struct TextureImage {
  std::string file;  // where it came from (a path, or "<asset>#embedded[i]")
  int width = 0, height = 0;
  std::vector<glm::vec4> texels;  // row 0 is the image's top row; linear values
};

// A material's use of an image: the sampler state (glTF samplers; OBJ always repeats).
struct TextureRef {
  std::shared_ptr<const TextureImage> image;
  TextureWrap wrapU = TextureWrap::Repeat, wrapV = TextureWrap::Repeat;
  explicit operator bool() const { return image != nullptr; }
  // Bilinear lookup. uv in the OpenGL convention assimp delivers for every format: (0, 0) is the
  // bottom-left corner of the image, texel centres at half-integers.
  glm::vec4 sample(glm::vec2 uv) const;
};

// Largest texture side accepted (a bigger image is an error naming the file, not an allocation).
constexpr int kMaxTextureSide = 16384;

// Decodes an image file or the bytes of an embedded one (PNG, JPEG, ... whatever OpenCV reads) with
// cv::IMREAD_UNCHANGED: 8- and 16-bit integer images are normalised to [0, 1] and, when `srgb`,
// decoded from the sRGB transfer curve (IEC 61966-2-1) to linear; float images (EXR, HDR) are taken
// as linear. Grey images fill R, G and B; alpha is kept in .a (the tracer ignores it: no cut-outs).
// Throws an Error naming `name` and what is wrong.
std::shared_ptr<const TextureImage> decodeTexture(const std::string& bytes, const std::string& name,
                                                  bool srgb);

float srgbToLinear(float encoded);

}  // namespace arena
