#pragma once
// The pinhole camera shared by the tracer (ray generation) and the denoisers (reprojection of
// world points, hit-point reprojection). Pixel (x, y) has its centre at (x + 0.5, y + 0.5); y grows
// downwards. view/proj follow glm's OpenGL conventions (camera looks down -Z).
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace arena {

struct CameraState {
  glm::vec3 eye{0.0f}, forward{0, 0, -1}, right{1, 0, 0}, up{0, 1, 0};
  float tanHalfFovY = 0.414f;
  float aspect = 1.0f;
  int width = 1, height = 1;

  static CameraState lookAt(glm::vec3 eye, glm::vec3 target, glm::vec3 upHint, float fovYDegrees,
                            int width, int height) {
    CameraState c;
    c.eye = eye;
    c.forward = glm::normalize(target - eye);
    glm::vec3 r = glm::cross(c.forward, upHint);
    if (glm::length(r) < 1e-6f) r = glm::cross(c.forward, glm::vec3(0, 0, 1));
    c.right = glm::normalize(r);
    c.up = glm::cross(c.right, c.forward);
    c.tanHalfFovY = std::tan(glm::radians(fovYDegrees) * 0.5f);
    c.width = width;
    c.height = height;
    c.aspect = float(width) / float(height);
    return c;
  }

  // Direction (normalised) of the ray through continuous pixel coordinates (px, py).
  glm::vec3 rayDirection(float px, float py) const {
    float sx = (2.0f * px / float(width) - 1.0f) * tanHalfFovY * aspect;
    float sy = (1.0f - 2.0f * py / float(height)) * tanHalfFovY;
    return glm::normalize(forward + sx * right + sy * up);
  }
  // Linear view depth (distance along the forward axis).
  float viewDepth(glm::vec3 p) const { return glm::dot(p - eye, forward); }
  // The world point at linear view depth `depth` on the ray through pixel coordinates (px, py):
  // viewDepth's inverse (a G-buffer's position from its depth).
  glm::vec3 pointAtDepth(float px, float py, float depth) const {
    const glm::vec3 dir = rayDirection(px, py);
    return eye + dir * (depth / glm::dot(dir, forward));
  }

  // Continuous pixel coordinates of a world point; returns false when it is behind the camera.
  bool project(glm::vec3 p, glm::vec2& pixel) const { return projectDirection(p - eye, pixel); }
  // Same for a direction (a point at infinity, e.g. the sky).
  bool projectDirection(glm::vec3 d, glm::vec2& pixel) const {
    float z = glm::dot(d, forward);
    if (z <= 1e-6f) return false;
    float sx = glm::dot(d, right) / (z * tanHalfFovY * aspect);
    float sy = glm::dot(d, up) / (z * tanHalfFovY);
    pixel = glm::vec2((sx + 1.0f) * 0.5f * float(width), (1.0f - sy) * 0.5f * float(height));
    return true;
  }

  glm::mat4 view() const { return glm::lookAt(eye, eye + forward, up); }
  glm::mat4 projection() const {
    return glm::perspective(2.0f * std::atan(tanHalfFovY), aspect, 0.01f, 1000.0f);
  }
};

}  // namespace arena
