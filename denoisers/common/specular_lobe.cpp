#include "denoisers/common/specular_lobe.hpp"

#include "core/error.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

void computeSpecularLobes(const GBufferView& g, const float* roughness, const CameraState& camera,
                          bool specular, const SpecularLobeSettings& settings, Image& lobes) {
  if (lobes.width() != g.width || lobes.height() != g.height ||
      lobes.channels() != kSpecularLobeChannels)
    throw Error("specular lobes: the lobe image must be 4 channels of the G-buffer's size");
  if (!g.normal[0] || (specular && (!g.position[0] || !roughness)))
    throw Error("specular lobes: need normal (and position, roughness for the specular signal)");
  if (gpu::recording()) {
    using namespace gpu_buffers;
    gpu::dispatch(g.width, g.height);
    gpu::read(kNormal, g.width, g.height, 1);
    if (specular) {
      gpu::read(kPosition, g.width, g.height, 1);
      gpu::read(kRoughness, g.width, g.height, 1);
    }
    gpu::write(kLobes, g.width, g.height);
  }
  const int w = g.width;
  parallelRows(g.height, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      glm::vec3 n(g.normal[0][p], g.normal[1][p], g.normal[2][p]);
      glm::vec3 axis = n;
      float sharpness = settings.diffuseSharpness;
      if (g.isSky(p)) {
        axis = glm::vec3(0.0f);
        sharpness = 0.0f;
      } else if (specular) {
        glm::vec3 toEye =
            camera.eye - glm::vec3(g.position[0][p], g.position[1][p], g.position[2][p]);
        const float length = glm::length(toEye);
        const glm::vec3 v = length > 0.0f ? toEye / length : -camera.forward;
        const float nv = glm::dot(n, v);
        axis = 2.0f * nv * n - v;  // reflect(-v, n)
        const float axisLength = glm::length(axis);
        axis = axisLength > 0.0f ? axis / axisLength : n;
        sharpness = specularLobeSharpness(roughness[p], nv, settings.minRoughness);
      }
      lobes.plane(kLobeAxisX)[p] = axis.x;
      lobes.plane(kLobeAxisY)[p] = axis.y;
      lobes.plane(kLobeAxisZ)[p] = axis.z;
      lobes.plane(kLobeSharpness)[p] = sharpness;
    }
  });
}

}  // namespace arena
