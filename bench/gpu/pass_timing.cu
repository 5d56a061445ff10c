// Times three kinds of pass on a CUDA GPU, at four resolutions, for the cost model's measured set
// (docs/gpu-cost.md, "A measured set"): the SVGF 5x5 à-trous step whose traffic
// tests/gpu_traffic_test.cpp counts by hand, N x N box filters over RGBA16F radiance (the CEDEC
// 2021 experiment's shape), a one-tap copy, and at 1080p a 7x7 box over each storage format (the
// fetch cost per format). Every buffer is read through the texture unit in the
// format docs/gpu-cost.md states for it, and written once per texel in that format, so each
// kernel's traffic is the counted one; `arena bench gpu-measured` prices the same traffic with the
// model and compares.
//
// Standalone (CUDA runtime only; not part of the CMake build, which needs no GPU):
//   nvcc -O3 -std=c++17 -arch=native bench/gpu/pass_timing.cu -o pass_timing
//   ./pass_timing > measured.json
// Output: JSON with the device's name and one row per (kernel, resolution): the median and the
// p5/p95 of 200 single-launch timings (CUDA events around each launch, after 20 warm-up launches)
// and the mean of 200 back-to-back launches.
#include <cuda_fp16.h>
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#define CHECK(call)                                                                        \
  do {                                                                                     \
    cudaError_t e_ = (call);                                                               \
    if (e_ != cudaSuccess) {                                                               \
      std::fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call, cudaGetErrorString(e_)); \
      std::exit(1);                                                                        \
    }                                                                                      \
  } while (0)

namespace {

// A pitched 2D buffer with a texture object over it (point sampling, clamp to edge).
struct Buffer {
  void* data = nullptr;
  size_t pitch = 0;
  cudaTextureObject_t tex = 0;
};

Buffer makeBuffer(int w, int h, cudaChannelFormatDesc desc, size_t bytesPerTexel) {
  Buffer b;
  CHECK(cudaMallocPitch(&b.data, &b.pitch, size_t(w) * bytesPerTexel, size_t(h)));
  cudaResourceDesc res{};
  res.resType = cudaResourceTypePitch2D;
  res.res.pitch2D.devPtr = b.data;
  res.res.pitch2D.desc = desc;
  res.res.pitch2D.width = size_t(w);
  res.res.pitch2D.height = size_t(h);
  res.res.pitch2D.pitchInBytes = b.pitch;
  cudaTextureDesc td{};
  td.addressMode[0] = td.addressMode[1] = cudaAddressModeClamp;
  td.filterMode = cudaFilterModePoint;
  td.readMode = cudaReadModeElementType;
  td.normalizedCoords = 0;
  CHECK(cudaCreateTextureObject(&b.tex, &res, &td, nullptr));
  return b;
}

void freeBuffer(Buffer& b) {
  CHECK(cudaDestroyTextureObject(b.tex));
  CHECK(cudaFree(b.data));
}

__device__ float hash01(unsigned x, unsigned y, unsigned salt) {
  unsigned h = x * 73856093u ^ y * 19349663u ^ salt * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return float(h & 0xffffffu) / float(0x1000000);
}

template <typename T>
__device__ T* row(void* data, size_t pitch, int y) {
  return reinterpret_cast<T*>(static_cast<char*>(data) + size_t(y) * pitch);
}

// Plausible content: radiance noise around 0.5, a depth ramp with noise, normals near +z packed
// 10-10-10-2, a few mesh ids, a variance of 0.01-0.05, small derivatives.
__global__ void fill(int w, int h, Buffer radiance, Buffer depth, Buffer normal, Buffer meshId,
                     Buffer derivatives, Buffer variance, Buffer filteredVariance) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  half2* r = row<half2>(radiance.data, radiance.pitch, y) + 2 * x;
  r[0] = __floats2half2_rn(0.5f + 0.4f * hash01(x, y, 1), 0.5f + 0.4f * hash01(x, y, 2));
  r[1] = __floats2half2_rn(0.5f + 0.4f * hash01(x, y, 3), 1.0f);
  row<float>(depth.data, depth.pitch, y)[x] = 1.0f + 0.01f * float(x + y) + 0.001f * hash01(x, y, 4);
  const unsigned nx = unsigned(511.5f + 100.0f * (hash01(x, y, 5) - 0.5f));
  const unsigned ny = unsigned(511.5f + 100.0f * (hash01(x, y, 6) - 0.5f));
  row<unsigned>(normal.data, normal.pitch, y)[x] = nx | (ny << 10) | (1023u << 20);
  row<unsigned short>(meshId.data, meshId.pitch, y)[x] = (unsigned short)((x / 64 + y / 64) % 4);
  half2* d = row<half2>(derivatives.data, derivatives.pitch, y) + 2 * x;
  d[0] = __floats2half2_rn(0.01f, 0.01f);
  d[1] = __floats2half2_rn(0.0f, 0.0f);
  row<half>(variance.data, variance.pitch, y)[x] = __float2half(0.01f + 0.04f * hash01(x, y, 7));
  row<half>(filteredVariance.data, filteredVariance.pitch, y)[x] = __float2half(0.03f);
}

__device__ float3 decodeNormal(unsigned packed) {
  const float x = float(packed & 1023u) / 1023.0f * 2.0f - 1.0f;
  const float y = float((packed >> 10) & 1023u) / 1023.0f * 2.0f - 1.0f;
  const float z = sqrtf(fmaxf(0.0f, 1.0f - x * x - y * y));
  return make_float3(x, y, z);
}

__device__ float luminance(float4 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// One SVGF à-trous step (Schied et al. 2017, eqs. 1-5), 5x5 B3 kernel, taps `step` px apart:
// per pixel 25 taps each of radiance (RGBA16F), mesh id (R16_UINT), depth (R32F), normal
// (R10G10B10A2) and variance (R16F), plus the centre's derivatives (RGBA16F) and prefiltered
// variance (R16F): 127 fetches, 30 B read once, 10 B written (radiance and propagated variance).
__global__ void svgfStep(int w, int h, int step, Buffer radiance, Buffer depth, Buffer normal,
                         Buffer meshId, Buffer derivatives, Buffer variance,
                         Buffer filteredVariance, Buffer outRadiance, Buffer outVariance) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  const float fx = float(x) + 0.5f, fy = float(y) + 0.5f;
  const float4 dz = tex2D<float4>(derivatives.tex, fx, fy);
  const float sigmaL = 4.0f * sqrtf(fmaxf(tex2D<float>(filteredVariance.tex, fx, fy), 0.0f)) + 1e-4f;
  float zc = 0.0f, lc = 0.0f;
  float3 nc = make_float3(0.0f, 0.0f, 1.0f);
  unsigned short idc = 0;
  const float k[3] = {3.0f / 8.0f, 1.0f / 4.0f, 1.0f / 16.0f};
  float4 sum = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
  float weights = 0.0f, varianceSum = 0.0f;
  // The centre tap first (it is one of the 25), then the other 24.
  for (int i = 0; i < 25; ++i) {
    const int j = i == 0 ? 12 : i <= 12 ? i - 1 : i;
    const int ox = j % 5 - 2, oy = j / 5 - 2;
    const float tx = fx + float(ox * step), ty = fy + float(oy * step);
    const float4 c = tex2D<float4>(radiance.tex, tx, ty);
    const unsigned short id = tex2D<unsigned short>(meshId.tex, tx, ty);
    const float z = tex2D<float>(depth.tex, tx, ty);
    const float3 n = decodeNormal(tex2D<unsigned>(normal.tex, tx, ty));
    const float v = tex2D<float>(variance.tex, tx, ty);
    const float l = luminance(c);
    if (i == 0) zc = z, nc = n, idc = id, lc = l;
    const float wz = expf(-fabsf(zc - z) / (fabsf(dz.x * float(ox * step) + dz.y * float(oy * step)) + 1e-3f));
    const float wn = powf(fmaxf(0.0f, nc.x * n.x + nc.y * n.y + nc.z * n.z), 128.0f);
    const float wl = expf(-fabsf(lc - l) / sigmaL);
    const float wgt = k[abs(ox)] * k[abs(oy)] * wz * wn * wl * (id == idc ? 1.0f : 0.0f);
    sum.x += wgt * c.x, sum.y += wgt * c.y, sum.z += wgt * c.z;
    weights += wgt;
    varianceSum += wgt * wgt * v;
  }
  const float inv = weights > 0.0f ? 1.0f / weights : 0.0f;
  half2* o = row<half2>(outRadiance.data, outRadiance.pitch, y) + 2 * x;
  o[0] = __floats2half2_rn(sum.x * inv, sum.y * inv);
  o[1] = __floats2half2_rn(sum.z * inv, 1.0f);
  row<half>(outVariance.data, outVariance.pitch, y)[x] = __float2half(varianceSum * inv * inv);
}

// An N x N box over RGBA16F radiance: N^2 fetches, 8 B read once, 8 B written.
__global__ void boxFilter(int w, int h, int radius, Buffer radiance, Buffer outRadiance) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  float4 sum = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
  for (int oy = -radius; oy <= radius; ++oy)
    for (int ox = -radius; ox <= radius; ++ox) {
      const float4 c = tex2D<float4>(radiance.tex, float(x + ox) + 0.5f, float(y + oy) + 0.5f);
      sum.x += c.x, sum.y += c.y, sum.z += c.z;
    }
  const float inv = 1.0f / float((2 * radius + 1) * (2 * radius + 1));
  half2* o = row<half2>(outRadiance.data, outRadiance.pitch, y) + 2 * x;
  o[0] = __floats2half2_rn(sum.x * inv, sum.y * inv);
  o[1] = __floats2half2_rn(sum.z * inv, 1.0f);
}

// A 7x7 box over one buffer of texel type T (the format sweep): 49 fetches per pixel of one format;
// writes one R32F value (4 B).
__device__ float total(float v) { return v; }
__device__ float total(unsigned char v) { return float(v); }
__device__ float total(float2 v) { return v.x + v.y; }
__device__ float total(float4 v) { return v.x + v.y + v.z + v.w; }

template <typename T>
__global__ void boxFormat(int w, int h, Buffer in, Buffer out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  float sum = 0.0f;
  for (int oy = -3; oy <= 3; ++oy)
    for (int ox = -3; ox <= 3; ++ox) sum += total(tex2D<T>(in.tex, float(x + ox) + 0.5f, float(y + oy) + 0.5f));
  row<float>(out.data, out.pitch, y)[x] = sum / 49.0f;
}

struct Timing {
  double median = 0, p5 = 0, p95 = 0, backToBack = 0;
};

template <typename Launch>
Timing timeKernel(Launch launch) {
  for (int i = 0; i < 20; ++i) launch();
  CHECK(cudaGetLastError());
  CHECK(cudaDeviceSynchronize());
  const int n = 200;
  std::vector<cudaEvent_t> events(2 * n);
  for (cudaEvent_t& e : events) CHECK(cudaEventCreate(&e));
  for (int i = 0; i < n; ++i) {
    CHECK(cudaEventRecord(events[2 * i]));
    launch();
    CHECK(cudaEventRecord(events[2 * i + 1]));
  }
  CHECK(cudaDeviceSynchronize());
  std::vector<double> ms(n);
  for (int i = 0; i < n; ++i) {
    float t = 0;
    CHECK(cudaEventElapsedTime(&t, events[2 * i], events[2 * i + 1]));
    ms[i] = t;
  }
  cudaEvent_t start = events[0], stop = events[1];
  CHECK(cudaEventRecord(start));
  for (int i = 0; i < n; ++i) launch();
  CHECK(cudaEventRecord(stop));
  CHECK(cudaEventSynchronize(stop));
  float total = 0;
  CHECK(cudaEventElapsedTime(&total, start, stop));
  CHECK(cudaGetLastError());
  for (cudaEvent_t& e : events) CHECK(cudaEventDestroy(e));
  std::sort(ms.begin(), ms.end());
  Timing t;
  t.median = ms[n / 2];
  t.p5 = ms[n * 5 / 100];
  t.p95 = ms[n * 95 / 100];
  t.backToBack = double(total) / n;
  return t;
}

}  // namespace

int main() {
  cudaDeviceProp prop{};
  CHECK(cudaGetDeviceProperties(&prop, 0));
  std::printf("{\"device\": \"%s\", \"multiprocessors\": %d, \"l2Bytes\": %d,\n \"rows\": [\n",
              prop.name, prop.multiProcessorCount, prop.l2CacheSize);
  const int sizes[4][2] = {{1920, 1080}, {960, 540}, {480, 270}, {240, 135}};
  bool first = true;
  for (const auto& size : sizes) {
    const int w = size[0], h = size[1];
    Buffer radiance = makeBuffer(w, h, cudaCreateChannelDescHalf4(), 8);
    Buffer depth = makeBuffer(w, h, cudaCreateChannelDesc<float>(), 4);
    Buffer normal = makeBuffer(w, h, cudaCreateChannelDesc<unsigned>(), 4);
    Buffer meshId = makeBuffer(w, h, cudaCreateChannelDesc<unsigned short>(), 2);
    Buffer derivatives = makeBuffer(w, h, cudaCreateChannelDescHalf4(), 8);
    Buffer variance = makeBuffer(w, h, cudaCreateChannelDescHalf(), 2);
    Buffer filteredVariance = makeBuffer(w, h, cudaCreateChannelDescHalf(), 2);
    Buffer outRadiance = makeBuffer(w, h, cudaCreateChannelDescHalf4(), 8);
    Buffer outVariance = makeBuffer(w, h, cudaCreateChannelDescHalf(), 2);
    const dim3 block(16, 8), grid((w + 15) / 16, (h + 7) / 8);
    fill<<<grid, block>>>(w, h, radiance, depth, normal, meshId, derivatives, variance, filteredVariance);
    CHECK(cudaGetLastError());
    CHECK(cudaDeviceSynchronize());
    struct Row {
      std::string kernel;
      Timing t;
    };
    std::vector<Row> rows;
    for (int step : {1, 8})
      rows.push_back({"svgf-atrous-5x5-step" + std::to_string(step), timeKernel([&] {
                        svgfStep<<<grid, block>>>(w, h, step, radiance, depth, normal, meshId, derivatives,
                                                  variance, filteredVariance, outRadiance, outVariance);
                      })});
    for (int n : {1, 3, 7, 15})
      rows.push_back({n == 1 ? std::string("copy-1x1") : "box-" + std::to_string(n) + "x" + std::to_string(n),
                      timeKernel([&] { boxFilter<<<grid, block>>>(w, h, n / 2, radiance, outRadiance); })});
    if (w == 1920) {  // the format sweep, at 1080p only (contents: whatever the allocation holds)
      Buffer out = makeBuffer(w, h, cudaCreateChannelDesc<float>(), 4);
      struct Format {
        const char* name;
        cudaChannelFormatDesc desc;
        size_t bytes;
      };
      const Format formats[] = {{"R8_UINT", cudaCreateChannelDesc<unsigned char>(), 1},
                                {"R16_FLOAT", cudaCreateChannelDescHalf(), 2},
                                {"R32_FLOAT", cudaCreateChannelDesc<float>(), 4},
                                {"R16G16B16A16_FLOAT", cudaCreateChannelDescHalf4(), 8},
                                {"R32G32_FLOAT", cudaCreateChannelDesc<float2>(), 8},
                                {"R32G32B32A32_FLOAT", cudaCreateChannelDesc<float4>(), 16}};
      for (const Format& f : formats) {
        Buffer in = makeBuffer(w, h, f.desc, f.bytes);
        CHECK(cudaMemset2D(in.data, in.pitch, 0, size_t(w) * f.bytes, size_t(h)));
        Timing t;
        if (f.bytes == 1) t = timeKernel([&] { boxFormat<unsigned char><<<grid, block>>>(w, h, in, out); });
        else if (f.bytes <= 4 || f.desc.f == cudaChannelFormatKindFloat && f.desc.y == 0)
          t = timeKernel([&] { boxFormat<float><<<grid, block>>>(w, h, in, out); });
        else if (f.desc.z == 0) t = timeKernel([&] { boxFormat<float2><<<grid, block>>>(w, h, in, out); });
        else t = timeKernel([&] { boxFormat<float4><<<grid, block>>>(w, h, in, out); });
        rows.push_back({std::string("format-7x7-") + f.name, t});
        freeBuffer(in);
      }
      freeBuffer(out);
    }
    for (const Row& r : rows) {
      std::printf("%s  {\"kernel\": \"%s\", \"width\": %d, \"height\": %d, \"medianMs\": %.5f, \"p5Ms\": %.5f, "
                  "\"p95Ms\": %.5f, \"backToBackMs\": %.5f}",
                  first ? "" : ",\n", r.kernel.c_str(), w, h, r.t.median, r.t.p5, r.t.p95, r.t.backToBack);
      first = false;
    }
    for (Buffer* b : {&radiance, &depth, &normal, &meshId, &derivatives, &variance, &filteredVariance,
                      &outRadiance, &outVariance})
      freeBuffer(*b);
  }
  std::printf("\n]}\n");
  return 0;
}
