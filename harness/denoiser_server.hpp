#pragma once
// `arena serve DENOISER`: one denoiser -- a C plugin (plugin:LIBRARY) or a built-in -- behind the
// frame protocol of docs/external-denoisers.md, on this process's stdin and stdout: the other end
// of ExternalProcessDenoiser. A plugin whose manifest says "isolated": true runs this way, in a
// process of its own, so that a crash or a hang fails its own pair instead of ending the run.
//
// The frames reach the denoiser as they would in the harness: the same FrameContext (reset() is
// called on a cut, as DenoiseRun does), the signal and the layers it declares, its output marked
// before each call and checked after it (markUnwritten, outputFault). Its time is the wall clock
// around its denoise() call, taken here exactly as DenoiseRun takes a built-in's, and sent as the
// result's computeMs with its passes.
#include <string>

namespace arena {

// Serves `entry` (a --denoisers entry) until its input ends. Protocol messages are read from
// `inFd` and written to `outFd`; what the denoiser itself prints to standard output is sent to
// standard error, where the harness keeps it, so that it cannot corrupt the answers. A fault (a
// setup or frame the protocol does not allow, a denoiser's error, an output it left unwritten) is
// answered with {"type": "error", "message": ...}. Returns the exit status: 0 when the input ended
// after whole frames, 1 after an error (a denoiser the protocol cannot feed, one reading gradient
// samples or the low-resolution buffer, is refused at the setup), 2 when `entry` cannot be loaded
// (said on stderr).
int serveDenoiser(const std::string& entry, int inFd, int outFd);

// `arena serve --describe ENTRY`: one JSON line on `outFd` saying what the denoiser is, as a
// manifest would (name, description, signals, channels, parameters): how arena learns an isolated
// plugin's schema without loading the library itself. Returns 0, or 2 when it cannot be loaded
// (said on stderr).
int describeDenoiser(const std::string& entry, int outFd);

}  // namespace arena
