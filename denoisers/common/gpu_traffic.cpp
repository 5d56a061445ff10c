#include "denoisers/common/gpu_traffic.hpp"

#include <algorithm>

namespace arena {

namespace {
thread_local PassTraffic* current = nullptr;

struct FormatInfo {
  const char* name;
  int bytes;
};
FormatInfo info(GpuFormat format) {
  switch (format) {
    case GpuFormat::R8Unorm: return {"R8_UNORM", 1};
    case GpuFormat::R16Float: return {"R16_FLOAT", 2};
    case GpuFormat::R16Uint: return {"R16_UINT", 2};
    case GpuFormat::R32Float: return {"R32_FLOAT", 4};
    case GpuFormat::RG16Float: return {"R16G16_FLOAT", 4};
    case GpuFormat::RGB10A2Unorm: return {"R10G10B10A2_UNORM", 4};
    case GpuFormat::RG32Float: return {"R32G32_FLOAT", 8};
    case GpuFormat::RGBA16Float: return {"R16G16B16A16_FLOAT", 8};
    case GpuFormat::RGBA16Uint: return {"R16G16B16A16_UINT", 8};
    case GpuFormat::RGBA32Float: return {"R32G32B32A32_FLOAT", 16};
  }
  return {"?", 0};
}

BufferTraffic& entry(const GpuBuffer& buffer, bool write, int width, int height) {
  PassTraffic& t = *current;
  if (t.dispatches.empty()) t.dispatches.push_back({width, height});
  const int dispatch = int(t.dispatches.size()) - 1;
  // One entry per buffer, direction and dispatch: a second read of a buffer in the same
  // dispatch adds fetches, not memory traffic (it is in the cache).
  for (BufferTraffic& b : t.buffers)
    if (b.dispatch == dispatch && b.write == write && b.name == buffer.name) return b;
  BufferTraffic b;
  b.name = buffer.name;
  b.format = buffer.format;
  b.history = buffer.history;
  b.write = write;
  b.width = width;
  b.height = height;
  b.dispatch = dispatch;
  b.texels = double(width) * double(height);
  t.buffers.push_back(b);
  return t.buffers.back();
}

double dispatchThreads(const PassTraffic& t) {
  const auto& d = t.dispatches.back();
  return double(d[0]) * double(d[1]);
}
}  // namespace

int gpuFormatBytes(GpuFormat format) { return info(format).bytes; }
const char* gpuFormatName(GpuFormat format) { return info(format).name; }
double gpuFetchCycles(GpuFormat format) { return std::max(1.0, gpuFormatBytes(format) / 4.0); }

double PassTraffic::bytesRead() const {
  double sum = 0;
  for (const BufferTraffic& b : buffers)
    if (!b.write) sum += b.bytes();
  return sum;
}
double PassTraffic::bytesWritten() const {
  double sum = 0;
  for (const BufferTraffic& b : buffers)
    if (b.write) sum += b.bytes();
  return sum;
}
double PassTraffic::fetches() const {
  double sum = 0;
  for (const BufferTraffic& b : buffers)
    if (!b.write) sum += b.fetches;
  return sum;
}
double PassTraffic::fetchCycles() const {
  double sum = 0;
  for (const BufferTraffic& b : buffers)
    if (!b.write) sum += b.fetches * gpuFetchCycles(b.format);
  return sum;
}
double PassTraffic::threads() const {
  double sum = 0;
  for (const auto& d : dispatches) sum += double(d[0]) * double(d[1]);
  return sum;
}

TrafficScope::TrafficScope(PassTraffic* traffic) : previous_(current) { current = traffic; }
TrafficScope::~TrafficScope() { current = previous_; }

namespace gpu {
bool recording() { return current != nullptr; }

void dispatch(int width, int height) {
  if (current) current->dispatches.push_back({width, height});
}

void skippedHere() {
  if (current) ++current->skippedHere;
}

void read(const GpuBuffer& buffer, int width, int height, double fetchesPerThread) {
  if (!current) return;
  BufferTraffic& b = entry(buffer, false, width, height);
  b.fetches += fetchesPerThread * dispatchThreads(*current);
}

void write(const GpuBuffer& buffer, int width, int height) {
  if (!current) return;
  BufferTraffic& b = entry(buffer, true, width, height);
  b.fetches += double(width) * double(height);
}
void read(std::initializer_list<GpuBuffer> buffers, int width, int height,
          double fetchesPerThread) {
  for (const GpuBuffer& b : buffers) read(b, width, height, fetchesPerThread);
}

void write(std::initializer_list<GpuBuffer> buffers, int width, int height) {
  for (const GpuBuffer& b : buffers) write(b, width, height);
}
}  // namespace gpu

}  // namespace arena
