#pragma once
// Choosing scenes and checking a render fits before any work: resolution text, memory, warm-up.
#include <string>
#include <vector>

#include "metrics/statistics.hpp"
#include "tracer/render.hpp"
#include "tracer/scene.hpp"

namespace arena {

// "WxH" with both sides in [1, kMaxSceneResolution]; errors name `option` and the text.
std::pair<int, int> parseResolution(const std::string& option, const std::string& text);
// Throws, naming the scene file, resolution and frames, when rendering it (or, with
// `wholeSequence`, running denoisers on it: every frame is held in memory) needs more memory than
// the machine has -- a clear error instead of std::bad_alloc halfway through.
void requireFitsInMemory(const Scene& scene, const RenderSettings& settings, bool wholeSequence);
// Everything checked before `scene` renders under `settings`: requireFitsInMemory, and a
// --max-bounces its bidirectional references can hold (kMaxBidirectionalBounces).
void requireRenderable(const Scene& scene, const RenderSettings& settings, bool wholeSequence);

// One line per scene whose sequence (as `settings` render it) has no frame after the warm-up (every
// summary of its pairs will be absent, metrics.md W). Said before any
// work, so that a --frames or
// --warmup slip costs a second, not a run. Also one per scene rendered smaller than 16 pixels on a
// side (tinyImageWarning): it runs, as a smoke test, but measures little.
std::string tinyImageWarning(const std::string& source, int width, int height);
std::vector<std::string> shortSequenceWarnings(const std::vector<Scene>& scenes,
                                               const RenderSettings& settings, int warmup);
// The line for one sequence (a scene file or a capture) of `frames` frames; empty when more than
// kFewSummarisedFrames are left after the warm-up. With 1 to kFewSummarisedFrames left, the line
// says the intervals hardly cover the frames' variation (statistics.md: frames are resampled in
// blocks; one frame gives no frame-to-frame variation at all, and a trial's sweep resolved more
// differences on 1 frame than on 8). It says what the user can change (a scene's frames; a
// capture's warm-up only; a warm-up of 0 is not to be lowered); the run keeps it with the scene's
// results (scenes.<scene>.warnings, printed after the table, shown by the report).
// shortSequenceWarning: the pre-flight line with the source, only where no frame is left (a slip
// that would cost the run); empty otherwise. (kFewSummarisedFrames: metrics/statistics.hpp, which
// the gate reads too.)
std::string shortSequenceText(int frames, int warmup, bool capture);
std::string shortSequenceWarning(const std::string& source, int frames, int warmup, bool capture);

// The items of a comma-separated list. An empty item ("a,,b", a leading or trailing comma, the
// empty list) is refused, never skipped: an error "<what> '<list>': an empty entry (a comma too
// many); expected <expected>" (`what`: the option, e.g. "--scenes").
std::vector<std::string> splitList(const std::string& list, const std::string& what,
                                   const std::string& expected);

// "all", or comma-separated scene names (looked up in scenesDir) or paths to .json files. `what`
// names the list in errors: the option ("--scenes") or the positional argument ("scenes").
std::vector<Scene> selectScenes(const std::string& list, const std::string& scenesDir,
                                const std::string& what = "--scenes");

}  // namespace arena
