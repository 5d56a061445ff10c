#pragma once
// PNG export of display images (OpenCV), written atomically.
#include <filesystem>
#include <string>

#include "core/image.hpp"

namespace arena {
// `display` holds values in [0, 1] (after core/display.hpp); 1 or 3 channels.
void writePng(const std::filesystem::path& path, const Image& display);
// "prefix_0007.png": a kept frame's image, as a run writes it and the report links it.
std::string frameName(const char* prefix, int t);
}  // namespace arena
