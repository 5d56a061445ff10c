#pragma once
// PNG export of display images (OpenCV), written atomically.
#include <filesystem>

#include "core/image.hpp"

namespace arena {
// `display` holds values in [0, 1] (after core/display.hpp); 1 or 3 channels.
void writePng(const std::filesystem::path& path, const Image& display);
}  // namespace arena
