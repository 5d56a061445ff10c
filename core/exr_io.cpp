#include "core/exr_io.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImfThreading.h>
#include <half.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <utility>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/json_reader.hpp"

namespace arena {

namespace fs = std::filesystem;

void LayerSet::set(const std::string& name, Image image) {
  if (!layers_.empty() && (image.width() != width() || image.height() != height()))
    throw Error("layer '" + name + "': size differs from the other layers");
  layers_[name] = std::move(image);
}

const Image& LayerSet::get(const std::string& name, const std::string& context) const {
  auto it = layers_.find(name);
  if (it == layers_.end())
    throw Error((context.empty() ? "" : context + ": ") + "missing channel '" + name + "'");
  return it->second;
}

void LayerSet::copyIn(const std::string& name, const Image& image) {
  if (const auto it = layers_.find(name); it != layers_.end() && it->second.sameShape(image))
    it->second = image;  // copy-assignment keeps the storage
  else
    set(name, image);
}

Image& LayerSet::get(const std::string& name, const std::string& context) {
  return const_cast<Image&>(static_cast<const LayerSet*>(this)->get(name, context));
}

int LayerSet::width() const { return layers_.empty() ? 0 : layers_.begin()->second.width(); }
int LayerSet::height() const { return layers_.empty() ? 0 : layers_.begin()->second.height(); }

void writeExr(const fs::path& path, const LayerSet& layers, const std::vector<LayerSpec>& specs,
              const ExrAttributes& attributes, ExrCompression compression, ExrChecksums checksums) {
  const int w = layers.width(), h = layers.height();
  if (w <= 0 || h <= 0) throw Error(path.string() + ": nothing to write");
  // Half layers need a converted copy that outlives the write.
  std::vector<std::vector<half>> halfPlanes;
  Imf::Header header(w, h);
  header.compression() =
      compression == ExrCompression::None ? Imf::NO_COMPRESSION : Imf::ZIP_COMPRESSION;
  for (const auto& [k, v] : attributes) header.insert(k, Imf::StringAttribute(v));
  Imf::FrameBuffer fb;
  for (const LayerSpec& spec : specs) {
    const Image& img = layers.get(spec.name, path.string());
    if (img.channels() != spec.channels())
      throw Error(path.string() + ": layer '" + spec.name + "' has " + std::to_string(img.channels()) +
                  " channels, expected " + std::to_string(spec.channels()));
    for (int c = 0; c < spec.channels(); ++c) {
      const std::string name = spec.channelName(c);
      if (checksums == ExrChecksums::PerChannel) {
        // Of the values a reader gets back: a half channel's as widened from its halves (a float
        // channel's are its own, hashed in place).
        uint64_t sum = 0;
        if (spec.half) {
          std::vector<float> stored(img.pixelCount());
          for (size_t i = 0; i < stored.size(); ++i) stored[i] = float(half(img.plane(c)[i]));
          sum = wordChecksum(stored.data(), stored.size());
        } else {
          sum = wordChecksum(img.plane(c), img.pixelCount());
        }
        header.insert("arena.sum." + name, Imf::StringAttribute(checksumHex(sum)));
      }
      if (spec.half) {
        auto& hp = halfPlanes.emplace_back(img.pixelCount());
        const float* src = img.plane(c);
        for (size_t i = 0; i < hp.size(); ++i) hp[i] = half(src[i]);
        header.channels().insert(name, Imf::Channel(Imf::HALF));
        fb.insert(name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(hp.data()), sizeof(half),
                                   sizeof(half) * size_t(w)));
      } else {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        fb.insert(name, Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(img.plane(c))),
                                   sizeof(float), sizeof(float) * size_t(w)));
      }
    }
  }
  writeAtomically(path, [&](const fs::path& tmp) {
    Imf::OutputFile file(tmp.c_str(), header, 1);
    file.setFrameBuffer(fb);
    file.writePixels(h);
  });
}

static ExrAttributes attributesOf(const Imf::Header& header) {
  ExrAttributes out;
  for (auto it = header.begin(); it != header.end(); ++it) {
    if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) out[it.name()] = s->value();
  }
  return out;
}

// The first header's attributes checked against the file before OpenEXR reads them: each is
// "name\0type\0" + int32 size + size bytes, the list ends with an empty name. OpenEXR 3.1 allocates
// (and, for a type it does not know, zero-fills) an attribute's declared size before reading it,
// so a damaged size of up to 2 GiB in a file of a few hundred bytes costs seconds and gigabytes
// before the read fails; here it is an error naming the file, the attribute and both sizes.
static void checkExrAttributeSizes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open (" + std::strerror(errno) + ")");
  in.seekg(0, std::ios::end);
  const std::streamoff fileSize = in.tellg();
  // Not an OpenEXR file at all (random bytes, a PNG renamed): said so, before a header of garbage
  // is read as attributes with names of control bytes (a bad-input trial).
  unsigned char magic[4] = {0, 0, 0, 0};
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(magic), 4) || magic[0] != 0x76 || magic[1] != 0x2f ||
      magic[2] != 0x31 || magic[3] != 0x01) {
    char found[32];
    std::snprintf(found, sizeof found, "%02x %02x %02x %02x", magic[0], magic[1], magic[2],
                  magic[3]);
    throw Error(path.string() + ": not an OpenEXR file (its first bytes are " +
                (fileSize < 4 ? "fewer than 4: " + std::to_string(fileSize) + " byte(s)"
                              : std::string(found)) +
                "; an OpenEXR file starts 76 2f 31 01)");
  }
  // After the magic number: the version field, whose bit 12 marks a multi-part file.
  uint32_t version = 0;
  if (!in.read(reinterpret_cast<char*>(&version), 4)) return;  // OpenEXR will say what is wrong
  const bool multiPart = (version & 0x1000u) != 0;
  auto readName = [&](std::string& out) {
    out.clear();
    for (char c; in.get(c);) {
      if (c == '\0') return true;
      if (out.size() >= 255) return false;  // longer than any name OpenEXR accepts: let it say so
      out.push_back(c);
    }
    return false;
  };
  std::string name, type;
  int parts = 0;
  for (;;) {  // one header, or a multi-part file's headers up to the empty one
    if (multiPart && (in.peek() == '\0' || in.peek() == std::char_traits<char>::eof())) break;
    bool ended = false;  // the header's attribute list ended on its empty name
    while (readName(name)) {
      if (name.empty()) {
        ended = true;
        break;
      }
      if (!readName(type)) return;
      int32_t size = 0;
      if (!in.read(reinterpret_cast<char*>(&size), 4)) return;
      const std::streamoff at = in.tellg();
      if (size < 0 || std::streamoff(size) > fileSize - at)
        throw Error(path.string() + ": header attribute " + quotedText(name) + " (" +
                    quotedText(type) + ") declares " + std::to_string(size) + " bytes, but " +
                    std::to_string(fileSize - at) + " remain in the file (a damaged header)");
      in.seekg(size, std::ios::cur);
    }
    if (!ended) return;  // truncated or damaged: OpenEXR says what is wrong
    ++parts;
    if (!multiPart) break;
  }
  // Only the first part of a multi-part file would be read: a layer in another part would be
  // reported missing although the file holds it.
  if (parts > 1)
    throw Error(
        path.string() + ": a multi-part OpenEXR file (" + std::to_string(parts) +
        " parts); expected a single-part file holding every layer's channels (only the first part "
        "would be read)");
}

// The image size a data window declares, refused (naming the file and the size) beyond what any
// frame this project reads can be: 65536 pixels a side and 2^28 pixels in all (a damaged header
// would otherwise ask for exabytes, or overflow the int arithmetic of the size).
static std::pair<int, int> checkedSize(const fs::path& path, const Imath::Box2i& dw) {
  const int64_t w = int64_t(dw.max.x) - int64_t(dw.min.x) + 1, h = int64_t(dw.max.y) - int64_t(dw.min.y) + 1;
  constexpr int64_t kMaxSide = 65536, kMaxPixels = int64_t(1) << 28;
  if (w <= 0 || h <= 0 || w > kMaxSide || h > kMaxSide || w * h > kMaxPixels)
    throw Error(path.string() + ": data window of " + std::to_string(w) + "x" + std::to_string(h) +
                " pixels (expected 1 to 65536 a side and at most 2^28 pixels; the header is damaged)");
  return {int(w), int(h)};
}

// The size (checked) and channel names of an open file's header.
static ExrHeader headerOf(const fs::path& path, const Imf::Header& header) {
  const auto [w, h] = checkedSize(path, header.dataWindow());
  ExrHeader out{w, h, {}};
  for (auto it = header.channels().begin(); it != header.channels().end(); ++it)
    out.channels.push_back(it.name());
  return out;
}

// `read(file)` on the file opened by OpenEXR once its header's attribute sizes are checked; an
// OpenEXR exception becomes an error naming the file, this project's own errors pass unchanged.
template <class Read>
static auto withExrFile(const fs::path& path, Read read) {
  if (!fs::exists(path)) throw Error(path.string() + ": file does not exist");
  checkExrAttributeSizes(path);
  try {
    Imf::InputFile file(path.c_str(), 1);
    return read(file);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path.string() + ": not a readable OpenEXR file (" + e.what() + ")");
  }
}

ExrContents readExr(const fs::path& path, const std::vector<LayerSpec>& specs,
                    std::optional<ExrSize> expected) {
  return withExrFile(path, [&](Imf::InputFile& file) {
    ExrContents out;
    const Imath::Box2i dw = file.header().dataWindow();
    out.header = headerOf(path, file.header());
    const int w = out.header.width, h = out.header.height;
    // The image is the display window; pixels stored elsewhere (a data window cropped or shifted
    // inside it, as a border render writes) would land at the wrong place, so they are refused.
    if (const Imath::Box2i& display = file.header().displayWindow(); display != dw) {
      auto box = [](const Imath::Box2i& b) {
        return "(" + std::to_string(b.min.x) + ", " + std::to_string(b.min.y) + ")-(" +
               std::to_string(b.max.x) + ", " + std::to_string(b.max.y) + ")";
      };
      throw Error(path.string() + ": data window " + box(dw) + " differs from the display window " +
                  box(display) +
                  ": expected the pixels of the whole image, exactly the display window (save it "
                  "uncropped)");
    }
    if (expected && (w != expected->width || h != expected->height))
      throw Error(path.string() + ": " + std::to_string(w) + "x" + std::to_string(h) +
                  ", expected " + std::to_string(expected->width) + "x" +
                  std::to_string(expected->height));
    // Before any allocation: a header claiming a size its data does not hold asks for any memory.
    if (!file.isComplete())
      throw Error(path.string() + ": file is truncated (incomplete pixel data)");
    out.attributes = attributesOf(file.header());
    Imf::FrameBuffer fb;
    for (const LayerSpec& spec : specs) {
      if (spec.topLevel) continue;  // a viewer-facing copy of a named layer
      Image img(w, h, spec.channels());
      for (int c = 0; c < spec.channels(); ++c) {
        const std::string name = spec.channelName(c);
        if (!file.header().channels().findChannel(name))
          throw Error(path.string() + ": missing channel '" + name + "'");
        // Origin shifted so a data window that does not start at 0 still lands at (0,0).
        char* base = reinterpret_cast<char*>(img.plane(c)) -
                     (ptrdiff_t(dw.min.x) + ptrdiff_t(dw.min.y) * w) * ptrdiff_t(sizeof(float));
        fb.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * size_t(w)));
      }
      out.layers.set(spec.name, std::move(img));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    for (const LayerSpec& spec : specs) {
      if (spec.topLevel) continue;
      const Image& img = out.layers.get(spec.name);
      for (int c = 0; c < spec.channels(); ++c) {
        const auto sum = out.attributes.find("arena.sum." + spec.channelName(c));
        if (sum == out.attributes.end()) continue;
        if (checksumHex(wordChecksum(img.plane(c), img.pixelCount())) != sum->second)
          throw Error(path.string() + ": channel '" + spec.channelName(c) +
                      "': its pixels do not match the checksum they were written with (the file is "
                      "damaged); delete it and run again, which renders it anew");
      }
    }
    return out;
  });
}

ExrAttributes readExrAttributes(const fs::path& path) {
  return withExrFile(path, [](Imf::InputFile& file) { return attributesOf(file.header()); });
}

ExrHeader readExrHeader(const fs::path& path) {
  return withExrFile(path, [&](Imf::InputFile& file) { return headerOf(path, file.header()); });
}

}  // namespace arena
