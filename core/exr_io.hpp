#pragma once
// Multi-channel OpenEXR files with named layers ("diffuse" -> diffuse.R/G/B), planar float in
// memory, half or float on disk per layer, and string attributes for provenance (cache hash,
// frame index) so a foreign or stale file is recognised.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/image.hpp"

namespace arena {

struct LayerSpec {
  std::string name;                   // "diffuse"
  std::vector<std::string> suffixes;  // {"R","G","B"}; empty = a single channel named `name`
  bool half = false;                  // stored as 16-bit half on disk
  bool topLevel = false;              // channels named by suffix only ("R"), for standard viewers
  int channels() const { return suffixes.empty() ? 1 : int(suffixes.size()); }
  std::string channelName(int c) const {
    if (suffixes.empty()) return name;
    return topLevel ? suffixes[size_t(c)] : name + "." + suffixes[size_t(c)];
  }
};

// A set of named layers of equal size.
class LayerSet {
 public:
  void set(const std::string& name, Image image);
  // An owning copy of `image` as layer `name`, into the layer's own storage where it has one: a
  // copy made every frame (a staged or sanitised input) allocates once.
  void copyIn(const std::string& name, const Image& image);
  bool has(const std::string& name) const { return layers_.count(name) != 0; }
  // Throws an error naming the layer (and `context`, e.g. the file) when it is missing.
  const Image& get(const std::string& name, const std::string& context = "") const;
  Image& get(const std::string& name, const std::string& context = "");
  const std::map<std::string, Image>& all() const { return layers_; }
  int width() const;
  int height() const;

 private:
  std::map<std::string, Image> layers_;
};

using ExrAttributes = std::map<std::string, std::string>;

// How writeExr stores pixels: ZIP (lossless; the default), or uncompressed where writing and
// reading time matters more than disk: a reference's means and variances are noise-like floats,
// 14% smaller under ZIP at about seven times the write time (camera_pan_occluder's, 256x144: 3.04
// MB in 65-72 ms against 3.54 MB in 8-10 ms; docs/performance.md, 2026-11-27, eleventh entry); the
// renderer's frames 2.8x smaller at about ten times (2026-11-28, thirteenth). Readers take either.
enum class ExrCompression { Zip, None };

// Whether a file carries a checksum of every channel's pixels (attributes "arena.sum.<channel>"),
// which readExr verifies: the sequence cache's files, whose damaged bytes (uncompressed, nothing
// else would notice) must never be measured. Files others may edit (captures) carry none.
enum class ExrChecksums { None, PerChannel };

// Writes the layers named in `specs` atomically (temporary file + rename).
void writeExr(const std::filesystem::path& path, const LayerSet& layers,
              const std::vector<LayerSpec>& specs, const ExrAttributes& attributes = {},
              ExrCompression compression = ExrCompression::Zip,
              ExrChecksums checksums = ExrChecksums::None);

struct ExrHeader {
  int width = 0, height = 0;
  std::vector<std::string> channels;
};

struct ExrContents {
  LayerSet layers;
  ExrAttributes attributes;
  ExrHeader header;  // the file's size and every channel it holds, read or not
};
// The size a reader expects of a file: checked against its header before any pixel is allocated
// (a header may claim any size).
struct ExrSize {
  int width = 0, height = 0;
};
// Reads the given layers; a missing channel, a size other than `expected`, an unreadable/truncated
// file, or a channel whose pixels do not match the checksum it was written with is an Error naming
// the file and the channel or sizes. A file whose
// pixel data is incomplete is refused before its pixels are allocated.
ExrContents readExr(const std::filesystem::path& path, const std::vector<LayerSpec>& specs,
                    std::optional<ExrSize> expected = std::nullopt);
ExrAttributes readExrAttributes(const std::filesystem::path& path);
// The channel names a file holds ("diffuse.R", "R", ...), and its size, without reading pixels.
ExrHeader readExrHeader(const std::filesystem::path& path);

}  // namespace arena
