#include "denoisers/common/remodulation.hpp"

#include "core/error.hpp"

namespace arena {

void remodulate(const Image& albedo, const Image& diffuse, const Image& specAlbedo, const Image& specular,
                const Image& emission, Image& color) {
  for (const Image* layer : {&diffuse, &specAlbedo, &specular, &emission})
    if (layer->width() != albedo.width() || layer->height() != albedo.height() ||
        layer->channels() != albedo.channels())
      throw Error("remodulation: the albedo, the two filtered signals and the emission differ in size");
  if (color.width() != albedo.width() || color.height() != albedo.height() || color.channels() != albedo.channels())
    color = Image(albedo.width(), albedo.height(), albedo.channels());
  const size_t n = albedo.raw().size();
  const float *a = albedo.raw().data(), *d = diffuse.raw().data(), *sa = specAlbedo.raw().data(),
              *s = specular.raw().data(), *e = emission.raw().data();
  float* c = color.raw().data();
  for (size_t i = 0; i < n; ++i) c[i] = a[i] * d[i] + sa[i] * s[i] + e[i];
}

}  // namespace arena
