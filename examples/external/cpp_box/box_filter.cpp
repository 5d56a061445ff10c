// A complete external denoiser in C++ (docs/external-denoisers.md): a box blur of the full colour
// over the (2r+1)^2 neighbours on the same mesh (sky pixels pass through). It links nothing of
// Denoise Arena: it only speaks the frame protocol on stdin/stdout (JSON header lines, raw
// little-endian float32 planes), so any build system and language can do the same.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace {

using nlohmann::json;

bool readExact(void* data, size_t bytes) {
  return std::fread(data, 1, bytes, stdin) == bytes;
}

bool readLine(std::string& line) {
  line.clear();
  for (int c; (c = std::fgetc(stdin)) != EOF;) {
    if (c == '\n') return true;
    line.push_back(char(c));
  }
  return false;
}

void send(const json& header, const std::vector<float>& planes = {}) {
  const std::string line = header.dump() + "\n";
  std::fwrite(line.data(), 1, line.size(), stdout);
  if (!planes.empty()) std::fwrite(planes.data(), sizeof(float), planes.size(), stdout);
  std::fflush(stdout);
}

// out(p) = mean of in(q) over the box around p with meshId(q) == meshId(p); sky (id < 0) copied.
void boxFilter(const float* in, const float* meshId, int w, int h, int radius, float* out) {
  const size_t n = size_t(w) * size_t(h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      if (meshId[p] < 0) {
        for (int c = 0; c < 3; ++c) out[c * n + p] = in[c * n + p];
        continue;
      }
      float sum[3] = {0, 0, 0};
      int count = 0;
      for (int qy = std::max(0, y - radius); qy <= std::min(h - 1, y + radius); ++qy)
        for (int qx = std::max(0, x - radius); qx <= std::min(w - 1, x + radius); ++qx) {
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          if (meshId[q] != meshId[p]) continue;
          for (int c = 0; c < 3; ++c) sum[c] += in[c * n + q];
          ++count;
        }
      for (int c = 0; c < 3; ++c) out[c * n + p] = sum[c] / float(count);
    }
}

}  // namespace

int main() {
  std::string line;
  if (!readLine(line)) return 1;
  const json setup = json::parse(line);
  if (setup.at("protocol") != 1) {
    send({{"type", "error"}, {"message", "speaks protocol 1"}});
    return 1;
  }
  const int w = setup.at("width"), h = setup.at("height");
  const int radius = setup.at("params").at("radius");
  const std::vector<std::string> names = setup.at("planes");
  const auto plane = [&](const std::string& name) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      std::cerr << "box_filter: no plane " << name << " in the setup\n";
      std::exit(1);
    }
    return size_t(it - names.begin());
  };
  const size_t n = size_t(w) * size_t(h), signal = plane("signal.R"), mesh = plane("meshId");
  std::vector<float> input(names.size() * n), output(3 * n);
  send({{"type", "ready"}});
  while (readLine(line)) {
    const json frame = json::parse(line);
    if (frame.at("bytes") != input.size() * sizeof(float) ||
        !readExact(input.data(), frame.at("bytes"))) {
      std::cerr << "box_filter: frame " << frame.at("frame") << " is not " << input.size() * 4
                << " bytes\n";
      return 1;
    }
    const auto start = std::chrono::steady_clock::now();
    boxFilter(&input[signal * n], &input[mesh * n], w, h, radius, output.data());
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const int taps = (2 * radius + 1) * (2 * radius + 1);
    send({{"type", "result"},
          {"frame", frame.at("frame")},
          {"width", w},
          {"height", h},
          {"channels", 3},
          {"computeMs", ms},
          {"passes", json::array({{{"name", "box"}, {"ms", ms}, {"tapsPerPixel", taps}}})}},
         output);
  }
  return 0;
}
