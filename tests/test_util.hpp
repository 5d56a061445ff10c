#pragma once
// Helpers shared by the tests: temporary directories, tiny renders of shipped scenes,
// deterministic noise and frame contexts.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "denoisers/denoiser.hpp"
#include "metrics/run_results.hpp"
#include "tracer/sequence_cache.hpp"
#include "tracer/scene.hpp"

namespace arena::test {

// Runs a shell command line; its exit status (128 + signal when killed) and stdout + stderr.
struct CommandResult {
  int status = -1;
  std::string output;
};
CommandResult runCommand(const std::string& commandLine);

// The message of the arena::Error `f` throws; "(no error)" when it throws none.
std::string errorOf(const std::function<void()>& f);

// A run document (runMatrix's, or one built by hand) as the typed results its readers take; a
// document out of shape fails the test with fromJson's error.
RunResults typed(const nlohmann::json& run);
// A statistics block built by hand (results.json "statistics"): `parts` (scenes, overall, ...) with
// the run-level fields a run writes beside them (method, confidence, replicates, tileGrid,
// rankedOn) where `parts` does not give them.
nlohmann::json statisticsBlock(const nlohmann::json& parts);

// SELECT COUNT(*) FROM table in the SQLite database db; -1 when it cannot be read.
int countRows(const std::filesystem::path& db, const char* table);
// The first column of the first row `sql` selects from `db`; NaN for no row or NULL.
double queryNumber(const std::filesystem::path& db, const std::string& sql);

// This test process's directory, <temp>/arena_test_<pid>: removed with everything in it when the
// process exits normally (ARENA_KEEP_TEST_DIRS=1 keeps it for a post-mortem).
const std::filesystem::path& processDir();
// A fresh, empty directory under processDir(), unique per test.
std::filesystem::path freshDir(const std::string& name);
Scene shippedScene(const std::string& name);
// Tiny settings: resolution w x h, `frames` frames, `refSpp` fixed-sample references.
RenderSettings tinySettings(int w, int h, int frames, int refSpp);

// Deterministic noise in [0, 1) (a PCG hash of the arguments), identical on every platform.
float hashUniform(uint32_t a, uint32_t b = 0, uint32_t c = 0);

// Frame t of a w x h sequence seen by a still camera at the origin looking down -Z (45 degrees);
// frame 0 resets the history.
FrameContext stillCameraContext(int t, int w, int h);

// Every frame layer of core/sequence.hpp for a flat camera-facing plane at depth 2 (normal +Z,
// mesh 0, zero motion, albedo 1, roughness 0.5, colour 0.5, hit distances 1e6), `spacing` world
// units between neighbouring pixels.
LayerSet planeFrame(int w, int h, float spacing = 0.01f);

// A registered denoiser with `params` overriding its defaults.
std::unique_ptr<Denoiser> createDenoiser(const std::string& name,
                                         const std::map<std::string, std::string>& params = {},
                                         SignalKind kind = SignalKind::Diffuse);

// A ghosting entry's response in frames (metrics.md); a bias that never settled within the window
// (responseFrames null) counts as the window's length from the event, a lower bound of the truth.
int responseOrWindow(const nlohmann::json& ghostingEntry);

// Rewrites a cached EXR through `edit` as the renderer would have written the edited values: its
// attributes kept (the cache still trusts it), its channel checksums made anew.
void rewriteCachedExr(const std::filesystem::path& file, const std::vector<LayerSpec>& specs,
                      const std::function<void(LayerSet&)>& edit);

}  // namespace arena::test
