#pragma once
// A denoiser that runs as a separate process (any language) and speaks the frame protocol of
// docs/external-denoisers.md over its stdin/stdout: one JSON header line per message, raw
// little-endian float32 planes after it. One process per sequence and signal, started in setup()
// and ended with the instance. The process reports its own compute time per frame
// (reportedMilliseconds) and optionally per pass; the harness's wall clock, which includes the
// transfer, is recorded beside it.
#include <memory>
#include <nlohmann/json.hpp>

#include "denoisers/denoiser.hpp"
#include "denoisers/external/manifest.hpp"
#include "denoisers/external/subprocess.hpp"

namespace arena {

constexpr int kExternalProtocolVersion = 1;
// The longest header line either side of the frame protocol takes (a JSON line, not planes).
constexpr size_t kMaxProtocolHeaderBytes = size_t(1) << 20;

class ExternalProcessDenoiser final : public Denoiser {
 public:
  ExternalProcessDenoiser(std::shared_ptr<const ExternalManifest> manifest, const ParamSet& params,
                          SignalKind kind);
  ~ExternalProcessDenoiser() override;

  std::vector<std::string> requiredChannels() const override { return manifest_->channels; }
  void setup(int width, int height) override;
  void reset() override { pendingReset_ = true; }
  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override;
  std::optional<double> reportedMilliseconds() const override { return computeMs_; }
  // After the sequence's last frame: ends the process's input and waits up to a second for it to
  // exit. When it exits with a non-zero status or is killed by a signal, what to warn of (its
  // results stand: every frame was answered): "the diffuse process exited with status 3 after its
  // last frame; the end of its stderr: ...". One still running after that second is killed, and
  // said too (every pair paid the second). Empty when it exits with 0 or is not running.
  std::string finish();

 private:
  // Fails the run: what went wrong, then how the process ended and the tail of its stderr. The
  // process is killed first (a hang must not outlive the error).
  [[noreturn]] void fail(const std::string& what);
  std::chrono::steady_clock::time_point deadline() const;
  nlohmann::json readHeader(const std::string& expectedType);

  std::shared_ptr<const ExternalManifest> manifest_;
  nlohmann::json params_;
  SignalKind kind_;
  std::unique_ptr<Subprocess> process_;
  int width_ = 0, height_ = 0;
  std::vector<std::string> planeNames_;  // "signal.R", ..., "normal.X", ... in sending order
  bool pendingReset_ = false;
  std::optional<double> computeMs_;
  std::string stage_;  // "setup" or "frame N": what every error of the exchange is prefixed with
};

}  // namespace arena
