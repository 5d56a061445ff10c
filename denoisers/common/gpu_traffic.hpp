#pragma once
// What a GPU implementation of a pass would move: the buffers it reads and writes, in the storage
// format such an implementation would give them, the texture fetches it issues and the compute
// dispatches it launches (docs/gpu-cost.md). Counted, not estimated: the shared blocks of
// denoisers/common report each buffer as they read or write it, with the tap counts they use, into
// the pass that Denoiser::ScopedPass is timing (a thread-local recorder; nothing is recorded
// outside a pass, and recording costs one branch per block call, never per pixel).
//
// Conventions of the count (what a GPU would pay, not what the CPU code does):
// - A buffer's memory traffic is its texels once per dispatch (neighbour taps hit the cache);
//   its fetches are the taps per thread times the dispatch's threads.
// - CPU-side glue a shader would fuse (a squared copy, a scratch luminance plane, a ping-pong
//   copy into history) moves nothing: it is not recorded.
#include <array>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

namespace arena {

// Storage formats (DXGI names). Chosen once per kind of buffer below, never per call.
enum class GpuFormat : uint8_t {
  R8Unorm,      // 1 B: masks, roughness
  R16Float,     // 2 B: history length, variance, hit distance
  R16Uint,      // 2 B: mesh id
  R32Float,     // 4 B: linear depth
  RG16Float,    // 4 B: motion, gradients
  RGB10A2Unorm, // 4 B: octahedral normal (NRD's NormalEncoding::R10_G10_B10_A2_UNORM)
  RG32Float,    // 8 B: luminance moments (Falcor SVGF)
  RGBA16Float,  // 8 B: radiance (3 + 1 spare; NRD, Falcor), derivatives, lobes
  RGBA16Uint,   // 8 B: a reprojection record (tap x0, y0, 2x2 mask, packed weights)
  RGBA32Float,  // 16 B: world position
};
int gpuFormatBytes(GpuFormat format);
const char* gpuFormatName(GpuFormat format);
// Cost of one fetch in the texture unit's cycles: one 32-bit texel a cycle, wider formats take
// bytes / 4 cycles (the fill-rate figure of a spec sheet counts 32-bit bilinear texels).
double gpuFetchCycles(GpuFormat format);

// A kind of buffer: its name in every table, its format, and whether it survives the frame.
struct GpuBuffer {
  const char* name;
  GpuFormat format;
  bool history = false;  // persistent: read next frame (NRD's permanent pool)
};

// The buffers the built-ins use. The G-buffer guides and the noisy signal are inputs the engine
// owns (NRD counts them outside its pools); everything else belongs to the denoiser.
namespace gpu_buffers {
inline constexpr GpuBuffer kSignal{"signal (input)", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kDepth{"depth (input)", GpuFormat::R32Float};
inline constexpr GpuBuffer kNormal{"normal (input)", GpuFormat::RGB10A2Unorm};
inline constexpr GpuBuffer kMeshId{"meshId (input)", GpuFormat::R16Uint};
inline constexpr GpuBuffer kMotion{"motion (input)", GpuFormat::RG16Float};
inline constexpr GpuBuffer kPosition{"position (input)", GpuFormat::RGBA32Float};
inline constexpr GpuBuffer kRoughness{"roughness (input)", GpuFormat::R8Unorm};
inline constexpr GpuBuffer kHitDistance{"hit distance (input)", GpuFormat::R16Float};
inline constexpr GpuBuffer kGradients{"gradient samples (input)", GpuFormat::RG16Float};
inline constexpr GpuBuffer kLowres{"low-res radiance (input)", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kColor{"color (input)", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kLowresDirection{"low-res direction (input)", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kUpscaled{"upscaled radiance", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kRadiance{"radiance", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kRadianceHistory{"radiance history", GpuFormat::RGBA16Float, true};
inline constexpr GpuBuffer kFastHistory{"fast history", GpuFormat::RGBA16Float, true};
inline constexpr GpuBuffer kFastRadiance{"fast radiance", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kAlpha{"adaptive alpha", GpuFormat::R16Float};
inline constexpr GpuBuffer kMoments{"moments", GpuFormat::RG32Float};
inline constexpr GpuBuffer kMomentsHistory{"moments history", GpuFormat::RG32Float, true};
inline constexpr GpuBuffer kHistoryLength{"history length", GpuFormat::R16Float};
inline constexpr GpuBuffer kHistoryLengthHistory{"history length history", GpuFormat::R16Float, true};
inline constexpr GpuBuffer kExtraChannels{"radiance, channels 5-8", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kConfidence{"confidence", GpuFormat::R8Unorm};
inline constexpr GpuBuffer kSecondMoments{"second moments", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kVariance{"variance", GpuFormat::R16Float};
inline constexpr GpuBuffer kFilteredVariance{"prefiltered variance", GpuFormat::R16Float};
inline constexpr GpuBuffer kMask{"disocclusion mask", GpuFormat::R8Unorm};
inline constexpr GpuBuffer kBlurredMask{"blurred mask", GpuFormat::R8Unorm};
inline constexpr GpuBuffer kNoise{"relative noise", GpuFormat::R16Float};
inline constexpr GpuBuffer kPreWide{"pre-spatial wide", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kOneFrameHistory{"one-frame history", GpuFormat::RGBA16Float, true};
inline constexpr GpuBuffer kStabilizerHistory{"stabiliser history", GpuFormat::RGBA16Float, true};
inline constexpr GpuBuffer kDerivatives{"depth/normal derivatives", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kLobes{"specular lobes", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kRecord{"reprojection record", GpuFormat::RGBA16Uint};
inline constexpr GpuBuffer kVirtualRecord{"virtual reprojection record", GpuFormat::RGBA16Uint};
inline constexpr GpuBuffer kPreviousDepth{"previous depth", GpuFormat::R32Float, true};
inline constexpr GpuBuffer kPreviousNormal{"previous normal", GpuFormat::RGB10A2Unorm, true};
inline constexpr GpuBuffer kPreviousMeshId{"previous meshId", GpuFormat::R16Uint, true};
inline constexpr GpuBuffer kMip{"mip chain", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kMipExtra{"mip chain, channels 5-8", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kMipGuide{"mip guides (depth, normal)", GpuFormat::RGBA16Float};
inline constexpr GpuBuffer kGradientImage{"gradient image", GpuFormat::RGBA16Float};
}  // namespace gpu_buffers

// One buffer's traffic in one pass (reads and writes of a buffer are separate entries).
struct BufferTraffic {
  std::string name;
  GpuFormat format = GpuFormat::R8Unorm;
  bool history = false;
  bool write = false;
  double texels = 0;   // moved to or from memory
  double fetches = 0;  // texture fetches (reads) or stores (writes) issued
  double bytes() const { return texels * gpuFormatBytes(format); }
  int width = 0, height = 0;  // the buffer's size
  int dispatch = 0;           // index into PassTraffic::dispatches
};

// Everything one pass would move on a GPU.
struct PassTraffic {
  std::vector<BufferTraffic> buffers;
  std::vector<std::array<int, 2>> dispatches;  // width x height threads of each dispatch
  // Dispatches the footprint policy skipped at this resolution that a 1920x1080 frame runs (an
  // à-trous iteration scaled below half a pixel here): not run, but their traffic is above, as
  // that frame's iteration would move it per pixel, so that the 1080p prediction has them.
  int skippedHere = 0;

  bool empty() const { return dispatches.empty() && buffers.empty(); }
  double bytesRead() const;
  double bytesWritten() const;
  double fetches() const;      // reads only
  double fetchCycles() const;  // reads: fetches x gpuFetchCycles(format)
  double threads() const;
};

// Recording: while a TrafficScope lives on this thread, the calls below add to its PassTraffic;
// outside one they do nothing. Call them from the calling thread, outside parallel loops.
class TrafficScope {
 public:
  explicit TrafficScope(PassTraffic* traffic);
  ~TrafficScope();
  TrafficScope(const TrafficScope&) = delete;
  TrafficScope& operator=(const TrafficScope&) = delete;

 private:
  PassTraffic* previous_;
};

namespace gpu {
bool recording();
// A compute dispatch of width x height threads; the reads and writes after it belong to it.
void dispatch(int width, int height);
// `buffer` (width x height texels) read with `fetchesPerThread` taps by every thread of the
// current dispatch (a dispatch of the buffer's size is opened when none is).
void read(const GpuBuffer& buffer, int width, int height, double fetchesPerThread = 1.0);
// `buffer` (width x height texels) written once per texel.
void write(const GpuBuffer& buffer, int width, int height);
// The same for several buffers of one size.
void read(std::initializer_list<GpuBuffer> buffers, int width, int height,
          double fetchesPerThread = 1.0);
void write(std::initializer_list<GpuBuffer> buffers, int width, int height);
// Counts a dispatch skipped at this resolution that a 1080p frame makes (PassTraffic::skippedHere);
// the caller records its traffic as that frame's.
void skippedHere();
}  // namespace gpu

}  // namespace arena
