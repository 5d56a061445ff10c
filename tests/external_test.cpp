// External denoisers (docs/external-denoisers.md): manifests, the frame protocol end to end with
// the Python and C++ examples, the C plugin ABI with eaw behind it, and every fault of a process
// (exit, crash, wrong size, NaN, hang, error, garbage) as a clear per-pair error.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <thread>

#include "arena_plugin.h"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "denoisers/external/loader.hpp"
#include "denoisers/external/manifest.hpp"
#include "denoisers/external/subprocess.hpp"
#include "harness/benchmarks.hpp"
#include "harness/denoise_run.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "metrics/run_results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

// Set on a command whose plugin faults on purpose: under AddressSanitizer (scripts/sanitize.sh) the
// sanitizer's own SEGV handler, to which arena's chains after its note, would end the process with
// an abort after a report of its own, where the tests check the signal the fault itself ends it
// with. Without the sanitizer the variable is read by nothing.
const std::string kFaultOnPurpose = "ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:handle_segv=0\" ";

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kWidth = 32, kHeight = 18, kFrames = 6;

const fs::path& sequenceCache() {
  static const fs::path cache = test::freshDir("external_cache");
  return cache;
}

// The still-camera Cornell box, 32x18, 6 frames.
const Sequence& tinySequence() {
  static const Sequence sequence = Sequence::open(
      renderSequence(test::shippedScene("cornell_static"),
                     test::tinySettings(kWidth, kHeight, kFrames, 8), sequenceCache(), nullptr));
  return sequence;
}

// "plugin:LIBRARY", appended rather than std::string("plugin:") + LIBRARY, on which GCC 12 warns
// falsely (-Warray-bounds) once inlined into a test's lambda.
std::string pluginSpec(const char* library) {
  std::string spec = "plugin:";
  spec += library;
  return spec;
}

std::vector<DenoisedFrame> denoiseAll(const DenoiserRequest& request, const Sequence& seq) {
  std::vector<LayerSet> frames;
  for (int t = 0; t < seq.info().frames; ++t) frames.push_back(seq.frame(t));
  DenoiseRun run(request, seq);
  std::vector<DenoisedFrame> out;
  run.run([&](int t) -> const LayerSet& { return frames[size_t(t)]; },
          [&](const DenoisedFrame& f) { out.push_back(f); });
  return out;
}

fs::path writeManifest(const std::string& dirName, const json& manifest) {
  const fs::path dir = test::freshDir("manifests/" + dirName);
  std::ofstream(dir / "manifest.json") << manifest.dump(2);
  return dir / "manifest.json";
}

// A manifest running tests/data/external/faulty_denoiser.py in `mode`.
std::string faulty(const std::string& mode, double timeoutSeconds = 10) {
  const json m = {
      {"name", "faulty-" + mode},
      {"command",
       {"/usr/bin/python3", std::string(ARENA_TEST_DATA) + "/external/faulty_denoiser.py", mode}},
      {"signals", "demodulated"},
      {"channels", {"meshId"}},
      {"timeoutSeconds", timeoutSeconds}};
  return DenoiserRegistry::resolve("ext:" + writeManifest("faulty-" + mode, m).string());
}

using test::errorOf;

// A run of `denoisers` on the tiny sequence (no baselines, warm-up 2, no FLIP, no frames kept).
RunConfig tinyRun(const std::string& name, std::vector<DenoiserRequest> denoisers) {
  RunConfig c;
  c.name = name;
  c.out = test::freshDir("run_" + name);
  c.cache = sequenceCache();
  c.render = test::tinySettings(kWidth, kHeight, kFrames, 8);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = std::move(denoisers);
  c.baselines = false;
  c.warmup = 2;
  c.flip = "none";
  c.keepFrames = "none";
  return c;
}

// --- manifests: contract --------------------------------------------------------------------

TEST(ExternalManifest, EveryMistakeNamesTheFileAndTheField) {
  const json good = {{"name", "ok"}, {"command", {"/bin/cat"}}, {"signals", "demodulated"}};
  struct Case {
    const char* what;
    json patch;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {"bad name", {{"name", "a.b"}}, "$.name: name 'a.b' must be non-empty"},
      {"no command", {{"command", nullptr}}, "give exactly one of \"command\""},
      {"both", {{"library", "x.so"}}, "give exactly one of \"command\""},
      {"signals", {{"signals", "rgb"}}, "$.signals: expected \"demodulated\""},
      {"channel",
       {{"channels", {"normal", "normals"}}},
       "$.channels[1]: unknown layer 'normals' ('normal'?)"},
      {"channel list",
       {{"channels", {"normals"}}},
       "are: diffuse specular emission color albedo specAlbedo"},
      {"channel twice",
       {{"channels", {"normal", "depth", "normal"}}},
       "$.channels[2]: 'normal' is already $.channels[0]; name each layer once"},
      {"unknown field",
       {{"timeout", 3}},
       "$.timeout: unknown field (check the spelling; a process's manifest has name description "
       "command signals channels parameters timeoutSeconds; a plugin's has library isolated "
       "instead of command signals channels parameters)"},
      {"param default",
       {{"parameters", {{{"name", "k"}, {"type", "int"}, {"default", 9}, {"min", 0}, {"max", 4}}}}},
       "$.parameters[0].default: must lie in [min, max]"},
      {"param range",
       {{"parameters",
         {{{"name", "k"}, {"type", "float"}, {"default", 0.5}, {"min", 1}, {"max", 0.25}}}}},
       "$.parameters[0].min: must not exceed max (1 > 0.25)"},
      {"int range",  // whole numbers beyond an int: the field named (it blamed the default)
       {{"parameters",
         {{{"name", "k"}, {"type", "int"}, {"default", 0}, {"min", -3e9}, {"max", 3e9}}}}},
       "$.parameters[0].min: an int parameter's min must be a whole number from -2147483648 to "
       "2147483647, got -3e+09"},
      {"int fraction",
       {{"parameters",
         {{{"name", "k"}, {"type", "int"}, {"default", 0.5}, {"min", 0}, {"max", 4}}}}},
       "$.parameters[0].default: an int parameter's default must be a whole number"},
      {"param type",
       {{"parameters", {{{"name", "k"}, {"type", "double"}, {"default", 1}}}}},
       "$.parameters[0].type: expected one of bool, int, float, choice"},
      {"timeout", {{"timeoutSeconds", 0}}, "$.timeoutSeconds: expected a positive number"},
      {"long timeout", {{"timeoutSeconds", 1e10}}, "at most 86400"},
  };
  for (const Case& c : cases) {
    json m = good;
    for (auto it = c.patch.begin(); it != c.patch.end(); ++it) {
      if (it.value().is_null())
        m.erase(it.key());
      else
        m[it.key()] = it.value();
    }
    const fs::path file = writeManifest("bad", m);
    const std::string message = errorOf([&] { readManifest(file); });
    EXPECT_NE(message.find(file.string()), std::string::npos) << c.what << ": " << message;
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.what << ": " << message;
  }
  const fs::path notJson = test::freshDir("manifests/notjson") / "manifest.json";
  std::ofstream(notJson) << "{name: 1";
  EXPECT_NE(errorOf([&] { readManifest(notJson); }).find(notJson.string()), std::string::npos);
  EXPECT_NE(errorOf([] {
              DenoiserRegistry::resolve("ext:/no/such/manifest.json");
            }).find("no manifest there"),
            std::string::npos);
}

// ext: given the denoiser's program instead of its manifest is said as such; a manifest with a
// typo keeps the parser's own message; an unknown name says how external ones are named.
TEST(ExternalManifest, TheProgramGivenForItsManifestIsNamedAsSuch) {
  const fs::path dir = test::freshDir("manifests/script");
  std::ofstream(dir / "mydenoiser.py") << "#!/usr/bin/env python3\nimport sys\n";
  std::ofstream(dir / "typo.json") << "{ \"name\": \"x\",, }";
  const std::string script =
      errorOf([&] { DenoiserRegistry::resolve("ext:" + (dir / "mydenoiser.py").string()); });
  EXPECT_NE(script.find("malformed JSON"), std::string::npos) << script;
  EXPECT_NE(script.find("(ext: names the denoiser's JSON manifest, which names the program to run"),
            std::string::npos)
      << script;
  const std::string typo =
      errorOf([&] { DenoiserRegistry::resolve("ext:" + (dir / "typo.json").string()); });
  EXPECT_NE(typo.find("malformed JSON"), std::string::npos) << typo;
  EXPECT_EQ(typo.find("ext: names"), std::string::npos) << typo;
  const std::string unknown = errorOf([] { DenoiserRegistry::instance().find("mybox"); });
  EXPECT_NE(unknown.find("unknown denoiser 'mybox'; registered: "), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("an external one is named ext:MANIFEST.json or plugin:LIBRARY.so"),
            std::string::npos)
      << unknown;
  const std::string slip = errorOf([] { DenoiserRegistry::instance().find("svfg"); });
  EXPECT_NE(slip.find("unknown denoiser 'svfg' (did you mean 'svgf'?); registered: "),
            std::string::npos)
      << slip;
  const std::string label =
      errorOf([] { DenoiserRegistry::instance().find("reblur[hitDistance=mirror]"); });
  EXPECT_EQ(
      label.rfind("'reblur[hitDistance=mirror]' is a label (a denoiser and its settings, as "
                  "results name them), not a denoiser: run reblur with --param reblur.NAME=VALUE",
                  0),
      0u)
      << label;
}

TEST(ExternalManifest, ParametersUseTheTypedSchemaAndAreRecorded) {
  const std::string name =
      DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_SOURCE_DIR "/external/python_temporal");
  EXPECT_EQ(name, "py-temporal");
  // Loading the same manifest again is a no-op; a different one under a taken name is refused.
  EXPECT_EQ(DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_SOURCE_DIR
                                      "/external/python_temporal/manifest.json"),
            name);
  const json clash = {{"name", "svgf"}, {"command", {"/bin/cat"}}, {"signals", "color"}};
  EXPECT_NE(errorOf([&] {
              DenoiserRegistry::resolve("ext:" + writeManifest("clash", clash).string());
            }).find("already taken by a built-in"),
            std::string::npos);
  const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
  EXPECT_NE(errorOf([&] {
              info.schema.resolve({{"maxHistry", "4"}}, name);
            }).find("unknown parameter 'maxHistry'"),
            std::string::npos);
  EXPECT_NE(errorOf([&] {
              info.schema.resolve({{"alphaMin", "2"}}, name);
            }).find("expected a value in [0, 1]"),
            std::string::npos);
  const json params = info.schema.resolve({{"maxHistory", "8"}}, name).toJson();
  EXPECT_EQ(params["maxHistory"], 8);
  EXPECT_EQ(params["alphaMin"], 0.0);
}

TEST(ExternalManifest, NamesAreFoundOnTheSearchPath) {
  const fs::path dir = test::freshDir("search_path");
  fs::create_directories(dir / "viaFolder");
  std::ofstream(dir / "viaFolder" / "manifest.json")
      << json({{"name", "via-folder"}, {"command", {"/bin/cat"}}, {"signals", "color"}}).dump();
  setenv("ARENA_DENOISER_PATH", ("/nonexistent:" + dir.string()).c_str(), 1);
  EXPECT_EQ(DenoiserRegistry::resolve("ext:viaFolder"), "via-folder");
  EXPECT_EQ(manifestsOnSearchPath().size(), 1u);
  EXPECT_NE(errorOf([] {
              DenoiserRegistry::resolve("ext:missing");
            }).find("searched ARENA_DENOISER_PATH"),
            std::string::npos);
  // A folder of that name without a manifest, here, does not hide the one on the path.
  const fs::path here = fs::current_path(), work = test::freshDir("search_path_cwd");
  fs::create_directories(work / "viaFolder");
  fs::current_path(work);
  const std::string found = errorOf([] { DenoiserRegistry::resolve("ext:viaFolder"); });
  fs::current_path(here);
  EXPECT_EQ(found, "(no error)");
  // arena denoisers lists what the path holds; a file there that is no manifest, or a second
  // manifest of a name an earlier one took, is a warning naming it, not the end of the listing.
  std::ofstream(dir / "notes.json") << "{\"mine\": 1}";
  const fs::path second = test::freshDir("search_path_second");
  fs::create_directories(second / "again");
  std::ofstream(second / "again" / "manifest.json")
      << json({{"name", "via-folder"}, {"command", {"/bin/cat"}}, {"signals", "color"}}).dump();
  const test::CommandResult listed =
      test::runCommand("ARENA_DENOISER_PATH='" + dir.string() + ":" + second.string() + "' " +
                       ARENA_BINARY + " denoisers");
  EXPECT_EQ(listed.status, 0) << listed.output;
  EXPECT_NE(listed.output.find("via-folder"), std::string::npos) << listed.output;
  // With the manifest it came from (no description: no dangling ": ").
  EXPECT_NE(listed.output.find("via-folder [external process " +
                               (dir / "viaFolder" / "manifest.json").string() + "]"),
            std::string::npos)
      << listed.output;
  EXPECT_NE(listed.output.find("notes.json"), std::string::npos) << listed.output;
  EXPECT_NE(listed.output.find("already taken"), std::string::npos) << listed.output;
  EXPECT_NE(listed.output.find("svgf"), std::string::npos) << listed.output;
  unsetenv("ARENA_DENOISER_PATH");
}

// --- the protocol end to end ----------------------------------------------------------------

TEST(ExternalProcess, PythonTemporalReproducesTheBuiltInOnAStillCamera) {
  const std::string name =
      DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_SOURCE_DIR "/external/python_temporal");
  const Sequence& seq = tinySequence();
  const auto builtin = denoiseAll({"temporal", {{"maxHistory", "4"}}, ""}, seq);
  const auto external = denoiseAll({name, {{"maxHistory", "4"}}, ""}, seq);
  ASSERT_EQ(external.size(), builtin.size());
  double worst = 0;
  auto compare = [&](const Image& theirs, const Image& mine) {
    ASSERT_TRUE(mine.sameShape(theirs));
    for (size_t i = 0; i < theirs.raw().size(); ++i)
      worst = std::max(worst, std::abs(double(mine.raw()[i]) - theirs.raw()[i]) /
                                  (std::abs(double(theirs.raw()[i])) + 1e-3));
  };
  for (size_t t = 0; t < builtin.size(); ++t) {
    compare(builtin[t].diffuse, external[t].diffuse);
    compare(builtin[t].specular, external[t].specular);
    compare(builtin[t].color, external[t].color);
    // The process timed itself; the harness's wall clock includes the transfer.
    EXPECT_TRUE(external[t].selfTimed);
    EXPECT_GE(external[t].wallMilliseconds, external[t].milliseconds);
    ASSERT_EQ(external[t].passes.size(), 2u);
    EXPECT_EQ(external[t].passes[0].name, "diffuse/reproject+accumulate");
  }
  // Float rounding only: the two sum the same taps in different orders.
  EXPECT_LT(worst, 1e-4);
  // And the accumulation did something: frame 5 differs from the noisy input.
  EXPECT_FALSE(samePixels(external.back().diffuse, seq.frame(kFrames - 1).get("diffuse")));
}

TEST(ExternalProcess, CppBoxFiltersTheFullColour) {
  const std::string name = DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_BINARY_DIR "/cpp_box");
  EXPECT_EQ(DenoiserRegistry::instance().find(name).signals, SignalMode::Color);
  const Sequence& seq = tinySequence();
  const LayerSet frame = seq.frame(2);
  const Image& color = frame.get("color");
  const Image& id = frame.get("meshId");
  // radius 0 passes the colour through bit for bit: nothing remodulated on the way.
  const auto identity = denoiseAll({name, {{"radius", "0"}}, ""}, seq);
  EXPECT_TRUE(samePixels(identity[2].color, color));
  EXPECT_TRUE(identity[2].diffuse.empty());
  const auto blurred = denoiseAll({name, {{"radius", "1"}}, ""}, seq);
  for (auto [x, y] :
       std::initializer_list<std::pair<int, int>>{{5, 5}, {16, 9}, {0, 0}, {31, 17}}) {
    if (id.at(x, y) < 0) continue;
    for (int c = 0; c < 3; ++c) {
      double sum = 0;
      int n = 0;
      for (int qy = std::max(0, y - 1); qy <= std::min(kHeight - 1, y + 1); ++qy)
        for (int qx = std::max(0, x - 1); qx <= std::min(kWidth - 1, x + 1); ++qx)
          if (id.at(qx, qy) == id.at(x, y)) {
            sum += color.at(qx, qy, c);
            ++n;
          }
      EXPECT_NEAR(blurred[2].color.at(x, y, c), sum / n, 1e-5 * (1 + sum / n))
          << x << "," << y << " c" << c;
    }
  }
}

TEST(ExternalProcess, ARunRecordsTheExternalPairBesideAFailingOne) {
  const std::string good = DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_BINARY_DIR "/cpp_box");
  const std::string bad = faulty("crash");
  const json r = runMatrix(tinyRun("external", {{good, {{"radius", "2"}}, ""}, {bad, {}, ""}}));
  ASSERT_EQ(r["pairs"].size(), 2u);
  const json& ok = r["pairs"][0];
  ASSERT_EQ(ok["status"], "ok") << ok.dump();
  EXPECT_EQ(ok["params"]["radius"], 2);
  EXPECT_EQ(ok["signals"], "color");
  EXPECT_NE(ok["origin"].get<std::string>().find("cpp_box/manifest.json"), std::string::npos);
  EXPECT_EQ(contenderKind(ok["origin"]), "external");  // what the report's tables say
  EXPECT_EQ(ok["timing"]["msSource"], "reported by the process");
  EXPECT_EQ(ok["timing"]["clock"], "process");  // its own clock, maybe a GPU's: not "cpu"
  EXPECT_GE(ok["timing"]["msWallMedian"].get<double>(), ok["timing"]["msMedian"].get<double>());
  EXPECT_GT(ok["summary"]["relMse"]["mean"].get<double>(), 0.0);
  EXPECT_GT(ok["timing"]["tapsPerPixel"].get<double>(), 0.0);  // its passes report them
  const json& failed = r["pairs"][1];
  EXPECT_EQ(failed["status"], "failed");
  EXPECT_NE(failed["error"].get<std::string>().find("killed by signal 11"), std::string::npos)
      << failed["error"];
}

// A process that answered every frame and then exits badly (a crash at shutdown): its results
// stand, and the pair says how it ended, with its stderr (it was silently "ok").
TEST(ExternalProcess, AProcessEndingBadlyAfterItsFramesIsWarnedOf) {
  const json r = runMatrix(tinyRun("exit_at_end", {{faulty("exit-at-end"), {}, ""}}));
  const json& pair = r["pairs"][0];
  ASSERT_EQ(pair["status"], "ok") << pair.dump().substr(0, 300);
  ASSERT_EQ(pair["processEnds"].size(), 2u) << pair["processEnds"];  // diffuse and specular
  std::string warnings;
  for (const json& w : pair["warnings"]) warnings += w.get<std::string>() + "\n";
  EXPECT_NE(warnings.find("the diffuse process ("), std::string::npos) << warnings;
  EXPECT_NE(warnings.find(") exited with status 3 after its last frame; the end of its stderr:\n"
                          "faulty: could not free the device buffers (every frame was answered: "
                          "its results stand)"),
            std::string::npos)
      << warnings;
  // A process that ends well says nothing.
  const json quiet = runMatrix(tinyRun("exit_well", {{faulty("quiet"), {}, ""}}));
  EXPECT_FALSE(quiet["pairs"][0].contains("processEnds"));
}

// What a plugin author's trial found passing silently: a header giving computeMs twice (the last
// was read), a time of 0 on every frame (a timer not read: the process looked free), and a print
// to stdout after the last answer (between frames it would have failed the pair).
TEST(ExternalProcess, ATimeOfZeroAKeyTwiceAndOutputAfterTheLastAnswerAreSaid) {
  const json r = runMatrix(tinyRun("time_and_end", {{faulty("zero-time"), {}, ""},
                                                    {faulty("duplicate-key"), {}, ""},
                                                    {faulty("goodbye"), {}, ""},
                                                    {faulty("huge"), {}, ""}}));
  ASSERT_EQ(r["pairs"].size(), 4u);
  // A number beyond the double range is named where it is, as in any JSON file.
  const json& huge = r["pairs"][3];
  ASSERT_EQ(huge["status"], "failed");
  EXPECT_NE(huge["error"].get<std::string>().find(
                "its 'result' header: $.computeMs: 1e999 is too large to be stored as a number"),
            std::string::npos)
      << huge["error"];
  const json& zero = r["pairs"][0];
  ASSERT_EQ(zero["status"], "ok") << zero.dump().substr(0, 300);
  EXPECT_TRUE(zero["timing"].value("reportedZeroEveryFrame", false)) << zero["timing"];
  EXPECT_EQ(zero["warnings"][0].get<std::string>().rfind(
                "reported a time of 0 ms on all 6 frames (the harness's wall clock around its "
                "calls: median ",
                0),
            0u)
      << zero["warnings"];
  const json& twice = r["pairs"][1];
  ASSERT_EQ(twice["status"], "failed");
  EXPECT_NE(twice["error"].get<std::string>().find(
                "its 'result' header: $: key \"computeMs\" is given twice"),
            std::string::npos)
      << twice["error"];
  const json& goodbye = r["pairs"][2];
  ASSERT_EQ(goodbye["status"], "ok") << goodbye.dump().substr(0, 300);
  ASSERT_EQ(goodbye["processEnds"].size(), 2u) << goodbye;
  EXPECT_NE(
      goodbye["processEnds"][0].get<std::string>().find(
          ") wrote 18 byte(s) to its output after its last answer (\"all done, goodbye\\n\"): "),
      std::string::npos)
      << goodbye["processEnds"];
  // The other processes of this file report a time and end quietly: none of this is said.
  const json quiet = runMatrix(tinyRun("time_quiet", {{faulty("quiet"), {}, ""}}));
  EXPECT_FALSE(quiet["pairs"][0]["timing"].contains("reportedZeroEveryFrame"));
  EXPECT_FALSE(quiet["pairs"][0].contains("processEnds"));
}

// Taps a process does not report are unknown, not 0 (a column of zeros read as passthrough's): a
// pass without them, or no passes at all, leaves tapsPerPixel out of the pair's timing.
TEST(ExternalProcess, TapsItDoesNotReportAreLeftOutNotZero) {
  const json r = runMatrix(
      tinyRun("unknown_taps", {{faulty("pass-without-taps"), {}, ""}, {faulty("quiet"), {}, ""}}));
  ASSERT_EQ(r["pairs"].size(), 2u);
  for (const json& pair : r["pairs"]) {
    ASSERT_EQ(pair["status"], "ok") << pair.dump().substr(0, 300);
    EXPECT_FALSE(pair["timing"].contains("tapsPerPixel")) << pair["timing"];
  }
  const json& passes = r["pairs"][0]["timing"]["passes"];
  ASSERT_FALSE(passes.empty());
  EXPECT_FALSE(passes.back().contains("tapsPerPixel")) << passes;
  EXPECT_TRUE(passes.back().contains("msMedian"));
  EXPECT_TRUE(r["pairs"][1]["timing"]["passes"].empty());
}

// The bench times each denoiser on frames with their cameras, each frame after its neighbour (the
// input frames run forward and back): reprojection (hit points, depth) does its real work there.
TEST(ExternalProcess, TheDenoiseBenchGivesEachFrameItsCameras) {
  DenoiseBench b;
  b.sceneFile = std::string(ARENA_SOURCE_DIR) + "/scenes/camera_pan_occluder.json";
  b.denoisers = {faulty("expects-cameras")};
  b.width = kWidth, b.height = kHeight, b.frames = 6, b.warmup = 1, b.inputs = 3;
  EXPECT_EQ(errorOf([&] { benchDenoise(b, [](const std::string&) {}); }), "(no error)");
}

// A contender that fails before its first frame (a process that never says it is ready) is
// reported failed, and the others are timed: the bench ended there.
TEST(ExternalProcess, TheDenoiseBenchGoesOnPastAContenderThatFailsInSetup) {
  DenoiseBench b;
  b.sceneFile = std::string(ARENA_SOURCE_DIR) + "/scenes/cornell_static.json";
  b.denoisers = {"eaw", faulty("no-ready", 0.5)};
  b.width = kWidth, b.height = kHeight, b.frames = 2, b.warmup = 0, b.inputs = 1;
  const json out = benchDenoise(b, [](const std::string&) {});
  ASSERT_EQ(out["denoisers"].size(), 2u);
  EXPECT_EQ(out["denoisers"][0]["status"], "ok");
  EXPECT_EQ(out["denoisers"][1]["status"], "failed");
  EXPECT_NE(out["denoisers"][1]["error"].get<std::string>().find("setup: "), std::string::npos)
      << out["denoisers"][1];
}

// The interval of a median of paired ratios (the benches' "x0.8 of eaw [95% CI ...]"):
// distribution-free, from 6 pairs on; below that even the whole range covers less than 95%, so
// there is none (never a zero-width one from one pair).
TEST(ExternalProcess, ABenchRatioHasNoIntervalUnderSixPairs) {
  const PairedRatio one = pairedRatio({2.0}, {1.0});
  EXPECT_DOUBLE_EQ(one.median, 2.0);
  EXPECT_TRUE(std::isnan(one.lo) && std::isnan(one.hi));
  EXPECT_EQ(one.ciText(), "no 95% CI from 1 pair(s); 6 are needed");
  const PairedRatio eight = pairedRatio({1, 2, 3, 4, 5, 6, 7, 8}, {1, 1, 1, 1, 1, 1, 1, 1});
  EXPECT_DOUBLE_EQ(eight.lo, 2.0);  // order statistics floor(4 - 2.77) and ceil(4 + 2.77) - 1
  EXPECT_DOUBLE_EQ(eight.hi, 7.0);
  EXPECT_EQ(eight.ciText("%.1f"), "95% CI 2.0, 7.0");
}

// What would time nothing, a contender against itself, or less work than it does is refused before
// anything renders.
TEST(ExternalProcess, TheDenoiseBenchRefusesWhatItCannotTimeFairly) {
  DenoiseBench b;
  b.sceneFile = std::string(ARENA_SOURCE_DIR) + "/scenes/cornell_static.json";
  b.width = kWidth, b.height = kHeight, b.frames = 2, b.warmup = 0, b.inputs = 2;
  auto errorWith = [&](std::vector<std::string> denoisers, int inputs = 2,
                       std::map<std::string, std::map<std::string, std::string>> params = {}) {
    DenoiseBench c = b;
    c.denoisers = std::move(denoisers);
    c.inputs = inputs;
    c.params = std::move(params);
    return errorOf([&] { benchDenoise(c, [](const std::string&) {}); });
  };
  EXPECT_NE(errorWith({}).find("--denoisers names no denoiser"), std::string::npos);
  EXPECT_NE(errorWith({"eaw", "eaw"}).find("--denoisers names eaw twice"), std::string::npos);
  EXPECT_NE(errorWith({"eaw"}, 2, {{"svgf", {{"sigmaL", "3"}}}})
                .find("--param svgf.sigmaL: svgf is not among"),
            std::string::npos);
  EXPECT_NE(errorWith({"asvgf"}, 1)
                .find("asvgf reads gradient samples, which need a frame before them: "
                      "expected --inputs >= 2"),
            std::string::npos)
      << errorWith({"asvgf"}, 1);
  // A denoiser that cannot run without the low-resolution buffer, with none to be rendered.
  DenoiseBench noLowres = b;
  noLowres.denoisers = {"reengine"};
  noLowres.params = {{"reengine", {{"disocclusionRays", "on"}}}};
  noLowres.lowresFactor = 0;
  EXPECT_NE(errorOf([&] {
              benchDenoise(noLowres, [](const std::string&) {});
            }).find("--lowres-factor 0: reengine needs the sequence's low-resolution buffer"),
            std::string::npos)
      << errorOf([&] { benchDenoise(noLowres, [](const std::string&) {}); });
  // More distinct inputs than the scene has frames would repeat its last pose.
  EXPECT_NE(errorWith({"eaw"}, 1000).find("--inputs 1000: " + b.sceneFile + " has "),
            std::string::npos)
      << errorWith({"eaw"}, 1000);
}

// arena bench denoise says which clock timed each contender: a process's own report of its compute
// time sits beside built-ins timed by the wall clock, so it is labelled, with its wall time.
TEST(ExternalProcess, TheDenoiseBenchNamesTheClockOfEachContender) {
  DenoiseBench b;
  b.sceneFile = std::string(ARENA_SOURCE_DIR) + "/scenes/cornell_static.json";
  b.denoisers = {"eaw", DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_BINARY_DIR "/cpp_box")};
  b.width = kWidth, b.height = kHeight, b.frames = 4, b.warmup = 1, b.inputs = 1;
  std::vector<std::string> lines;
  const json out = benchDenoise(b, [&](const std::string& line) { lines.push_back(line); });
  ASSERT_EQ(out["denoisers"].size(), 2u);
  const json &builtIn = out["denoisers"][0], &process = out["denoisers"][1];
  EXPECT_EQ(builtIn["msSource"], "harness wall clock");
  EXPECT_FALSE(builtIn.contains("msWallMedian"));
  EXPECT_EQ(process["msSource"], "reported by the process");
  // Bilateral units are this CPU's: a process's own clock has none.
  EXPECT_GT(builtIn["bu"].get<double>(), 0.0);
  EXPECT_FALSE(process.contains("bu")) << process;
  EXPECT_GE(process["msWallMedian"].get<double>(), process["msMedian"].get<double>());
  bool labelled = false;
  for (const std::string& l : lines)
    labelled |= l.find("[reported by the process, no BU; wall clock") != std::string::npos;
  EXPECT_TRUE(labelled);
  // Its ratio to the built-in is taken on one clock, the wall clock around both: a process's own
  // report (a GPU's time, perhaps) divided by a CPU wall clock is no ratio.
  EXPECT_EQ(process["ratioTo"]["clock"], "harness wall clock, both");
  bool onWall = false;
  for (const std::string& l : lines)
    onWall |= l.find("of eaw on the wall clock") != std::string::npos;
  EXPECT_TRUE(onWall);
}

// --- faults: each a clear error; the harness neither hangs nor dies ---------------------------

TEST(ExternalFaults, ExitEarlyGivesTheStatusAndTheStderrTail) {
  const std::string e = errorOf([] { denoiseAll({faulty("exit"), {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("exited with status 3"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot find model weights weights.bin"), std::string::npos) << e;
  EXPECT_NE(e.find("diffuse process"), std::string::npos) << e;
  EXPECT_NE(e.find("): frame 1: "), std::string::npos) << e;  // every fault names its frame
}

TEST(ExternalFaults, ACrashNamesTheSignal) {
  const std::string e = errorOf([] { denoiseAll({faulty("crash"), {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("killed by signal 11"), std::string::npos) << e;
  EXPECT_NE(e.find("about to dereference a null pointer"), std::string::npos) << e;
}

TEST(ExternalFaults, AWrongSizeIsRefused) {
  const std::string e = errorOf([] { denoiseAll({faulty("wrong-size"), {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("frame 1: sent a 31x18x3 result; expected 32x18x3"), std::string::npos) << e;
  const std::string s = errorOf([] { denoiseAll({faulty("short"), {}, ""}, tinySequence()); });
  EXPECT_NE(s.find("expected 3 planes of 2304 bytes"), std::string::npos) << s;
}

// Like every other fault of a process, with its manifest and the end of its stderr (where its own
// prints say why).
TEST(ExternalFaults, ANaNFailsThePair) {
  const std::string e = errorOf([] { denoiseAll({faulty("nan"), {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("faulty-nan (diffuse process, "), std::string::npos) << e;
  EXPECT_NE(e.find("frame 1: sent 1 non-finite value(s) in its result (the first nan at x 0, y 0 "
                   "of its R plane)"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("faulty: the exposure went to zero"), std::string::npos) << e;
}

// Bytes beyond an answer's planes land before the next header: the error falls on that frame,
// and says what probably happened.
TEST(ExternalFaults, BytesBeyondThePlanesAreSaidToBeStray) {
  const std::string e = errorOf([] {
    denoiseAll({faulty("extra-bytes"), {}, ""}, tinySequence());
  });
  EXPECT_NE(e.find("frame 2: expected a JSON 'result' header line"), std::string::npos) << e;
  EXPECT_NE(e.find("(12 stray byte(s) before the header: did the answer before send more than its "
                   "3 planes"),
            std::string::npos)
      << e;
}

TEST(ExternalFaults, AHangIsKilledAfterTheTimeout) {
  const auto start = std::chrono::steady_clock::now();
  const std::string e = errorOf([] { denoiseAll({faulty("hang", 0.5), {}, ""}, tinySequence()); });
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(e.find("frame 1: no result header within timeoutSeconds = 0.5"), std::string::npos)
      << e;
  EXPECT_NE(e.find("killed by the harness"), std::string::npos) << e;
  EXPECT_LT(seconds, 8.0);  // 0.5 s for the hang; the rest is the sequence and Python starting
  const std::string setup = errorOf([] {
    denoiseAll({faulty("no-ready", 0.5), {}, ""}, tinySequence());
  });
  EXPECT_NE(setup.find("setup: no ready header within timeoutSeconds"), std::string::npos) << setup;
}

// Arena ended by a signal (SIGTERM here; Ctrl-C's SIGINT alike, where a shell's background job
// does not ignore it) ends its external processes and what they started: each runs in a group of
// its own, which a terminal's Ctrl-C does not reach, and a hung one outlived arena (a bad-input
// trial).
TEST(ExternalFaults, ASignalThatEndsArenaEndsItsProcesses) {
  const fs::path dir = test::freshDir("external_signalled");
  const fs::path pidFile = dir / "sleep.pid", arenaPid = dir / "arena.pid";
  const json m = {{"name", "wrapped-hang"},
                  {"command",
                   {"/bin/sh", "-c",
                    "sleep 300 & echo $! > '" + pidFile.string() + "'; exec /usr/bin/python3 '" +
                        std::string(ARENA_TEST_DATA) + "/external/faulty_denoiser.py' hang"}},
                  {"signals", "demodulated"},
                  {"channels", {"meshId"}},
                  {"timeoutSeconds", 120}};
  const fs::path manifest = writeManifest("signalled-hang", m);
  std::thread arena([&] {
    test::runCommand("sh -c '" + std::string(ARENA_BINARY) +
                     " run --scenes cornell_static --no-baselines --resolution 8x8 --frames 3 "
                     "--ref-spp 4 --cache " +
                     (dir / "cache").string() + " --out " + (dir / "run").string() +
                     " --denoisers ext:" + manifest.string() + " & echo $! > " + arenaPid.string() +
                     "; wait'");
  });
  int sleeper = 0, pid = 0;
  for (int wait = 0; wait < 600 && sleeper == 0; ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::ifstream(pidFile) >> sleeper;
  }
  std::ifstream(arenaPid) >> pid;
  EXPECT_GT(pid, 0);
  EXPECT_GT(sleeper, 0) << "the process never started";
  // Ended in every case, so the thread joins (a failed assertion would leave it joinable, and
  // its destructor would end the whole suite).
  if (pid > 0) ::kill(pid, SIGTERM);
  arena.join();
  if (sleeper <= 0) return;
  char state = 'X';
  for (int wait = 0; wait < 100; ++wait) {
    std::string stat;
    std::getline(std::ifstream("/proc/" + std::to_string(sleeper) + "/stat"), stat);
    const size_t close = stat.rfind(')');
    state = close != std::string::npos && close + 2 < stat.size() ? stat[close + 2] : 'X';
    if (state == 'X' || state == 'Z') break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_TRUE(state == 'X' || state == 'Z') << "the process's background job outlived arena";
  if (state != 'X' && state != 'Z') ::kill(sleeper, SIGKILL);
}

// A wrapper script's background job shares the process's output: when the process exits, the job
// is ended with it (it neither outlives the pair nor holds the output open until the timeout).
TEST(ExternalFaults, NothingTheProcessStartedOutlivesIt) {
  const fs::path dir = test::freshDir("external_leftovers");
  for (const std::string mode : {"exit", "passthrough", "hang"}) {
    const fs::path pidFile = dir / (mode + ".pid");
    const json m = {{"name", "wrapped-" + mode},
                    {"command",
                     {"/bin/sh", "-c",
                      "sleep 300 & echo $! > '" + pidFile.string() + "'; exec /usr/bin/python3 '" +
                          std::string(ARENA_TEST_DATA) + "/external/faulty_denoiser.py' " + mode}},
                    {"signals", "demodulated"},
                    {"channels", {"meshId"}},
                    {"timeoutSeconds", mode == "hang" ? 0.5 : 20.0}};
    const std::string name =
        DenoiserRegistry::resolve("ext:" + writeManifest("wrapped-" + mode, m).string());
    const auto start = std::chrono::steady_clock::now();
    const std::string e = errorOf([&] { denoiseAll({name, {}, ""}, tinySequence()); });
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (mode == "exit") {
      EXPECT_NE(e.find("exited with status 3"), std::string::npos) << e;
      EXPECT_LT(seconds, 15.0) << "an exit waited for the timeout";  // 20 s timeout
    } else if (mode == "passthrough") {
      EXPECT_EQ(e, "(no error)") << e;
    }
    int pid = 0;
    std::ifstream(pidFile) >> pid;
    ASSERT_GT(pid, 0) << mode;
    // Gone, or a zombie waiting for its new parent (init) to reap it: not running. A SIGKILL takes
    // effect when the process is next scheduled, so it is given a moment.
    std::string stat;
    char state = 'X';
    for (int wait = 0; wait < 100; ++wait) {
      stat.clear();
      std::getline(std::ifstream("/proc/" + std::to_string(pid) + "/stat"), stat);
      const size_t close = stat.rfind(')');
      state = close != std::string::npos && close + 2 < stat.size() ? stat[close + 2] : 'X';
      if (state == 'X' || state == 'Z') break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(state == 'X' || state == 'Z')
        << mode << ": the background job is still running (" << stat << ")";
    if (state != 'X' && state != 'Z') ::kill(pid, SIGKILL);
  }
}

TEST(ExternalFaults, ReportedErrorsAndGarbageAreQuoted) {
  const std::string e = errorOf([] { denoiseAll({faulty("error"), {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("it reported an error: out of GPU memory"), std::string::npos) << e;
  const std::string g = errorOf([] { denoiseAll({faulty("garbage"), {}, ""}, tinySequence()); });
  EXPECT_NE(
      g.find("frame 1: expected a JSON 'result' header line, got: hello from print debugging"),
      std::string::npos)
      << g;
  // A NUL byte ended the message where it was (what() is a C string): the rest of the line, how
  // the process ended and its stderr were lost. It is shown as U+FFFD, like any byte that is not
  // text.
  const std::string n = errorOf([] { denoiseAll({faulty("nul"), {}, ""}, tinySequence()); });
  EXPECT_NE(n.find("got: junk\xEF\xBF\xBDtail"), std::string::npos) << n;
  EXPECT_NE(n.find("before\xEF\xBF\xBD"
                   "after the NUL"),
            std::string::npos)
      << n;
}

// Whatever bytes a process writes, the message is valid text (results.json is UTF-8: one stray
// byte lost the whole run before), and a malformed error or pass report is named.
TEST(ExternalFaults, BadBytesAndMalformedReportsFailThePairOnly) {
  const std::string e = errorOf([] { denoiseAll({faulty("bad-bytes"), {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("exited with status 4"), std::string::npos) << e;
  EXPECT_NE(e.find("\xEF\xBF\xBD\xEF\xBF\xBD weights"), std::string::npos)
      << e;  // 0xff 0x80: U+FFFD twice
  EXPECT_NO_THROW(static_cast<void>(json(e).dump()));
  const std::string code = errorOf([] {
    denoiseAll({faulty("error-code"), {}, ""}, tinySequence());
  });
  EXPECT_NE(code.find("it reported an error: (no message string; the header was {\"type\": "
                      "\"error\", \"message\": 42}"),
            std::string::npos)
      << code;
  const std::string pass = errorOf([] {
    denoiseAll({faulty("bad-pass"), {}, ""}, tinySequence());
  });
  EXPECT_NE(pass.find("a number \"ms\" >= 0"), std::string::npos) << pass;
  // A process that floods its output instead of reading its input: stopped long before its
  // timeout, the flood held to a bound (a header line's 1 MiB here; 64 MiB while a frame too large
  // for the socket's buffer is being sent, below).
  const auto start = std::chrono::steady_clock::now();
  const std::string flood = errorOf([] {
    denoiseAll({faulty("flood", 60), {}, ""}, tinySequence());
  });
  EXPECT_NE(flood.find("longer than 1048576 bytes"), std::string::npos) << flood.substr(0, 300);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 30.0);
  {
    Subprocess yes({"/usr/bin/yes"}, fs::temp_directory_path());
    const std::vector<char> frame(size_t(8) << 20, 'f');
    const std::string unread = errorOf([&] {
      yes.write(frame.data(), frame.size(), Subprocess::Clock::now() + std::chrono::seconds(60));
    });
    EXPECT_NE(unread.find("wrote more than 64 MiB to its output while it was being sent a frame"),
              std::string::npos)
        << unread;
  }
  // And in a run, the run is written with the other pair's result.
  const RunConfig cfg =
      tinyRun("bad_bytes", {{faulty("bad-bytes"), {}, ""}, {"passthrough", {}, ""}});
  const json r = runMatrix(cfg);
  ASSERT_EQ(r["pairs"].size(), 2u);
  EXPECT_TRUE(fs::exists(cfg.out / "results.json"));
  int ok = 0;
  for (const json& p : r["pairs"]) ok += p["status"] == "ok";
  EXPECT_EQ(ok, 1);
}

// A time beyond any frame's (1e308 ms) fails its pair alone, naming the denoiser, frame and value:
// summed into the mean it made results.json's time inf, and the whole run stopped (a bad-input
// trial).
TEST(ExternalFaults, ATimeBeyondAnyFramesFailsItsPairOnly) {
  const json r =
      runMatrix(tinyRun("absurd_time", {{faulty("absurd-time"), {}, ""}, {"passthrough", {}, ""}}));
  ASSERT_EQ(r["pairs"].size(), 2u);
  EXPECT_EQ(r["pairs"][0]["status"], "failed");
  EXPECT_NE(r["pairs"][0]["error"].get<std::string>().find(
                "reported a time of 1e+308 ms on the diffuse signal at frame 1 (computeMs)"),
            std::string::npos)
      << r["pairs"][0]["error"];
  EXPECT_EQ(r["pairs"][1]["status"], "ok");
  // Taps per pixel alike (summed over the two signals, 1e308 made the run's record inf).
  const json taps = runMatrix(tinyRun("huge_taps", {{faulty("huge-taps"), {}, ""}}));
  EXPECT_NE(taps["pairs"][0]
                .value("error", "")
                .find("reported its pass 'blur' at 1e+308 taps per "
                      "pixel"),
            std::string::npos)
      << taps["pairs"][0].dump().substr(0, 300);
  // And the bench, which timed it as inf ms/frame with status ok.
  const fs::path manifest = writeManifest(
      "bench-absurd-time",
      {{"name", "absurd"},
       {"command",
        {"/usr/bin/python3", std::string(ARENA_TEST_DATA) + "/external/faulty_denoiser.py",
         "absurd-time"}},
       {"signals", "demodulated"},
       {"channels", {"meshId"}}});
  const contract::CliResult bench =
      contract::arenaCli("bench denoise --denoisers eaw,ext:" + manifest.string() +
                         " --resolution 16x8 --frames 3 --warmup 1 --inputs 1");
  EXPECT_NE(bench.output.find("reported a time of 1e+308 ms"), std::string::npos) << bench.output;
  EXPECT_EQ(bench.status, 1) << bench.output;
}

// A process's reported time longer than the exchange that carried it is warned of, in the results
// and the run's printout; a pair that fails leaves no images behind (the report copied a failed
// pair's first frames), and a reused --out keeps no other run's.
TEST(ExternalFaults, ImplausibleTimesAreWarnedOfAndFailedPairsLeaveNoImages) {
  RunConfig cfg =
      tinyRun("implausible", {{faulty("slow-report"), {}, ""}, {faulty("exit"), {}, ""}});
  cfg.keepFrames = "all";
  std::vector<std::string> printed;
  cfg.progress = [&](const std::string& line) { printed.push_back(line); };
  // An earlier run into the same --out, with a contender this run does not have; and a folder of
  // the user's that no run recorded (left alone, and said).
  RunConfig earlier = tinyRun("implausible", {{"passthrough", {}, ""}});
  earlier.keepFrames = "all";
  runMatrix(earlier);
  ASSERT_TRUE(fs::exists(cfg.out / "images" / "cornell_static" / "passthrough" / "frame_0000.exr"));
  fs::create_directories(cfg.out / "images" / "cornell_static" / "my-notes");
  std::ofstream(cfg.out / "images" / "cornell_static" / "my-notes" / "notes.txt") << "mine";
  const json r = runMatrix(cfg);
  ASSERT_EQ(r["pairs"].size(), 2u);
  const json& slow = r["pairs"][0];
  ASSERT_EQ(slow["status"], "ok");
  EXPECT_EQ(slow["timing"]["implausibleFrames"], kFrames - 1);  // it misreports from frame 1 on
  const std::string warning = slow["warnings"][0];
  EXPECT_NE(warning.find("on 5 of 6 frames (frame 1, diffuse: computeMs 2e+05 ms in a call of"),
            std::string::npos)
      << warning;
  bool said = false;
  for (const std::string& line : printed) said |= line == "  warning: " + warning;
  EXPECT_TRUE(said);
  EXPECT_EQ(r["pairs"][1]["status"], "failed");
  const fs::path sceneImages = cfg.out / "images" / "cornell_static";
  EXPECT_TRUE(fs::exists(cfg.out / slow["images"]["dir"].get<std::string>() / "frame_0000.exr"));
  std::vector<std::string> folders;
  for (const fs::directory_entry& e : fs::directory_iterator(sceneImages))
    if (e.is_directory())
      folders.push_back(e.path().filename().string());  // beside the scene's own images
  std::sort(folders.begin(), folders.end());
  EXPECT_EQ(folders, (std::vector<std::string>{
                         fs::path(slow["images"]["dir"].get<std::string>()).filename().string(),
                         "my-notes"}));
  // ... and said, as folders a run stopped before its commit leaves are (nothing records them).
  bool stray = false;
  for (const std::string& line : printed)
    stray |=
        line.find("holds 1 image folder(s) no run recorded (images/cornell_static/my-notes)") !=
        std::string::npos;
  EXPECT_TRUE(stray);
}

TEST(ExternalFaults, AMissingProgramIsNamed) {
  const json m = {
      {"name", "nobody"}, {"command", {"./no-such-program"}}, {"signals", "demodulated"}};
  const std::string name = DenoiserRegistry::resolve("ext:" + writeManifest("nobody", m).string());
  const std::string e = errorOf([&] { denoiseAll({name, {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("cannot start './no-such-program'"), std::string::npos) << e;
}

// --- the C plugin ABI -------------------------------------------------------------------------

TEST(Plugin, EawThroughTheAbiIsIdenticalToTheBuiltIn) {
  const std::string name = DenoiserRegistry::resolve(pluginSpec(ARENA_EAW_PLUGIN));
  EXPECT_EQ(name, "eaw-plugin");
  // The schema came through the ABI: the same names, defaults and ranges as the built-in's.
  const DenoiserInfo& plugin = DenoiserRegistry::instance().find(name);
  const DenoiserInfo& builtin = DenoiserRegistry::instance().find("eaw");
  ASSERT_EQ(plugin.schema.specs().size(), builtin.schema.specs().size());
  for (size_t i = 0; i < plugin.schema.specs().size(); ++i)
    EXPECT_EQ(plugin.schema.specs()[i].describe(), builtin.schema.specs()[i].describe());
  const std::map<std::string, std::string> params = {
      {"iterations", "3"}, {"sigmaColor", "1.5"}, {"kernel", "3x3"}};
  const Sequence& seq = tinySequence();
  const auto a = denoiseAll({"eaw", params, ""}, seq);
  const auto b = denoiseAll({name, params, ""}, seq);
  for (size_t t = 0; t < a.size(); ++t) {
    EXPECT_TRUE(samePixels(a[t].color, b[t].color)) << "frame " << t;
    EXPECT_FALSE(b[t].selfTimed);  // timed by the harness, like a built-in
    ASSERT_EQ(b[t].passes.size(), a[t].passes.size());
    EXPECT_EQ(b[t].passes[2].name, "diffuse/atrous 3");
  }
  // The manifest form loads the same library.
  EXPECT_EQ(DenoiserRegistry::resolve("ext:" ARENA_EXAMPLES_BINARY_DIR "/eaw_plugin"), name);
}

// The adapter hands the harness's planes to the built-in in place (Image::borrow) when they are
// laid out like an Image's, and otherwise copies the inputs in and the output back: both give the
// same output.
TEST(Plugin, ScatteredPlanesGiveTheSameOutputAsContiguousOnes) {
  void* library = dlopen(ARENA_EAW_PLUGIN, RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(library, nullptr) << dlerror();
  using Entry = const ArenaPlugin* (*)();
  const ArenaPlugin* plugin = reinterpret_cast<Entry>(dlsym(library, "arena_plugin"))();
  const LayerSet& frame = tinySequence().frame(0);
  const char* names[] = {"normal", "position", "meshId"};
  std::vector<std::vector<float>> scatteredPlanes;  // every plane in an allocation of its own
  auto view = [&](const Image& image, bool scattered) {
    ArenaImage v{image.width(), image.height(), image.channels(), {}};
    for (int c = 0; c < image.channels(); ++c) {
      if (scattered) {
        scatteredPlanes.emplace_back(image.planeSpan(c).begin(), image.planeSpan(c).end());
        v.planes[c] = scatteredPlanes.back().data();
      } else {
        v.planes[c] = image.plane(c);
      }
    }
    return v;
  };
  std::vector<float> outputs[2];
  for (int scattered = 0; scattered < 2; ++scattered) {
    char error[256] = "";
    void* instance = plugin->create(nullptr, 0, ARENA_SIGNAL_DIFFUSE, error, sizeof error);
    ASSERT_NE(instance, nullptr) << error;
    ASSERT_EQ(plugin->setup(instance, kWidth, kHeight, error, sizeof error), 0) << error;
    scatteredPlanes.clear();
    scatteredPlanes.reserve(16);
    std::vector<ArenaLayer> layers;
    for (const char* name : names) layers.push_back({name, view(frame.get(name), scattered)});
    const ArenaInputs inputs{view(frame.get("diffuse"), scattered), layers.data(), 3};
    Image out(kWidth, kHeight, 3, -1.0f);
    std::vector<float> outPlanes[3];  // scattered: the output's planes apart too
    ArenaMutableImage output{kWidth, kHeight, 3, {out.plane(0), out.plane(1), out.plane(2)}};
    if (scattered)
      for (int c = 0; c < 3; ++c) {
        outPlanes[c].assign(size_t(kWidth) * kHeight, -1.0f);
        output.planes[c] = outPlanes[c].data();
      }
    ArenaFrameContext ctx{};
    ctx.width = kWidth;
    ctx.height = kHeight;
    ctx.reset = 1;
    ASSERT_EQ(plugin->denoise(instance, &ctx, &inputs, &output, nullptr, error, sizeof error), 0)
        << error;
    plugin->destroy(instance);
    for (int c = 0; c < 3; ++c)
      outputs[scattered].insert(outputs[scattered].end(), output.planes[c],
                                output.planes[c] + size_t(kWidth) * kHeight);
  }
  EXPECT_EQ(outputs[0], outputs[1]);
  EXPECT_NE(outputs[0], std::vector<float>(outputs[0].size(), -1.0f));  // it wrote the output
  dlclose(library);
}

// A plugin runs inside arena's process: a fault in it ends the run (nothing can be trusted after
// it), but never silently. The note names the plugin, its call and frame, the pair, and what is
// lost; the process dies of the same signal (exit 139 from the shell); no results are written.
TEST(Plugin, AFaultInAPluginIsNamedBeforeTheProcessDies) {
  const fs::path dir = test::freshDir("plugin_segfault");
  // A tiny run of passthrough beside `plugin` into dir/OUT, with `environment` set.
  auto runWith = [&](const std::string& plugin, const std::string& out,
                     const std::string& environment) {
    return contract::arenaCli(
        "run --plugin " + plugin +
            " --scenes cornell_static --denoisers passthrough --no-baselines --resolution 8x8 "
            "--frames 3 --warmup 1 --ref-spp 1 --flip none --keep-frames none --cache " +
            (dir / "cache").string() + " --out " + (dir / out).string(),
        environment);
  };
  const contract::CliResult r =
      runWith(ARENA_FAULTY_PLUGIN, "run", kFaultOnPurpose + "ARENA_FAULTY_PLUGIN=segfault ");
  EXPECT_EQ(r.status, 128 + SIGSEGV) << r.output;
  EXPECT_NE(
      r.output.find(
          "arena: fatal: signal 11 (Segmentation fault) in plugin faulty's denoise of frame 0 (" +
          fs::absolute(ARENA_FAULTY_PLUGIN).lexically_normal().string() +
          ") while faulty ran on cornell_static; arena stops here and writes no results"),
      std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir / "run" / "results.json"));
  // A plugin that calls exit() ends arena with its status, said as a crash is.
  const contract::CliResult exited =
      runWith(ARENA_FAULTY_PLUGIN, "exited", "ARENA_FAULTY_PLUGIN=exit ");
  EXPECT_EQ(exited.status, 3) << exited.output;
  EXPECT_NE(exited.output.find("arena: fatal: exit() was called in plugin faulty's denoise of "
                               "frame 0"),
            std::string::npos)
      << exited.output;
  // Loading runs the library's code in arena, isolated or not: a crash there is named too.
  const contract::CliResult loading = runWith(ARENA_FAULTY_PARAMS_PLUGIN, "loading",
                                              kFaultOnPurpose + "ARENA_FAULTY_DESCRIPTOR=crash ");
  EXPECT_EQ(loading.status, 128 + SIGSEGV) << loading.output;
  EXPECT_NE(
      loading.output.find("arena: fatal: signal 11 (Segmentation fault) while loading plugin "
                          "library " +
                          fs::absolute(ARENA_FAULTY_PARAMS_PLUGIN).lexically_normal().string()),
      std::string::npos)
      << loading.output;
  EXPECT_FALSE(fs::exists(dir / "loading"));
  // A relative path that names nothing says where it looked.
  const std::string missing =
      errorOf([] { DenoiserRegistry::resolve("plugin:no/such/libplug.so"); });
  EXPECT_NE(missing.find("no/such/libplug.so: no such plugin library (looked for " +
                         fs::absolute("no/such/libplug.so").lexically_normal().string() +
                         ": a relative path is taken from the current directory)"),
            std::string::npos)
      << missing;
}

// A run that dies before its commit in a directory holding an earlier run (a crash, a kill) leaves
// that run's results.json with images partly its own: the directory is marked, the report refuses
// it, compare warns (the numbers are whole), and the next complete run clears the mark.
TEST(Plugin, ARunThatDiesBeforeItsCommitLeavesItsDirectoryMarked) {
  const fs::path dir = test::freshDir("unfinished_run");
  const std::string common =
      "run --scenes cornell_static --no-baselines --resolution 8x8 "
      "--frames 3 --warmup 1 --ref-spp 1 --flip none --cache " +
      (dir / "cache").string();
  const std::string run = common + " --out " + (dir / "run").string();
  const contract::CliResult first = contract::arenaCli(run + " --denoisers passthrough");
  ASSERT_EQ(first.status, 0) << first.output;
  EXPECT_FALSE(fs::exists(dir / "run" / ".arena.unfinished"));
  const std::string earlier = readText(dir / "run" / "results.json");
  // A run refused before it touched anything (its cache is a file) leaves no mark.
  std::ofstream(dir / "a_file") << "x";
  const contract::CliResult refused = contract::arenaCli(
      "run --scenes cornell_static --denoisers passthrough --no-baselines --resolution 8x8 "
      "--frames 3 --warmup 1 --ref-spp 1 --flip none --cache " +
      (dir / "a_file").string() + " --out " + (dir / "run").string());
  EXPECT_EQ(refused.status, 2) << refused.output;
  EXPECT_FALSE(fs::exists(dir / "run" / ".arena.unfinished"));
  const contract::CliResult second = contract::arenaCli(
      common + " --denoisers passthrough --input-seed 1 --out " + (dir / "other").string());
  ASSERT_EQ(second.status, 0) << second.output;
  const contract::CliResult crashed =
      contract::arenaCli(run + " --denoisers passthrough --plugin " + ARENA_FAULTY_PLUGIN,
                         kFaultOnPurpose + "ARENA_FAULTY_PLUGIN=segfault ");
  ASSERT_EQ(crashed.status, 128 + SIGSEGV) << crashed.output;
  EXPECT_EQ(readText(dir / "run" / "results.json"), earlier);
  ASSERT_TRUE(fs::exists(dir / "run" / ".arena.unfinished"));
  const contract::CliResult report =
      contract::arenaCli("report " + (dir / "run").string() + " --out " + (dir / "page").string());
  EXPECT_EQ(report.status, 2) << report.output;
  EXPECT_NE(report.output.find((dir / "run").string() +
                               ": a run into this directory stopped before its commit (started "),
            std::string::npos)
      << report.output;
  EXPECT_NE(report.output.find("a report would show those images beside numbers they do not "
                               "belong to"),
            std::string::npos)
      << report.output;
  EXPECT_FALSE(fs::exists(dir / "page" / "index.html"));
  const contract::CliResult compared =
      contract::arenaCli("compare " + (dir / "other").string() + " " + (dir / "run").string());
  EXPECT_NE(compared.output.find("compared on the earlier run's numbers, which are whole"),
            std::string::npos)
      << compared.output;
  // Nor is it merged: the merged report would show the mixed images as the shard's.
  const contract::CliResult merged =
      contract::arenaCli("merge " + (dir / "run").string() + " --out " + (dir / "merged").string());
  EXPECT_EQ(merged.status, 2) << merged.output;
  EXPECT_NE(merged.output.find("run that shard again to completion before merging it"),
            std::string::npos)
      << merged.output;
  const contract::CliResult again = contract::arenaCli(run + " --denoisers passthrough");
  ASSERT_EQ(again.status, 0) << again.output;
  EXPECT_FALSE(fs::exists(dir / "run" / ".arena.unfinished"));
  EXPECT_EQ(
      contract::arenaCli("report " + (dir / "run").string() + " --out " + (dir / "page").string())
          .status,
      0);
  // The stopped run's own image folders (the plugin's pair, which no results file records) went
  // with it: what lies under images/ is what results.json records.
  const auto folders = [](const fs::path& out) {
    std::set<std::string> found;
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(out / "images"))
      if (e.is_directory()) found.insert(fs::relative(e.path(), out).string());
    return found;
  };
  {
    const json results = json::parse(readText(dir / "run" / "results.json"));
    std::set<std::string> recorded = {"images/cornell_static"};
    for (const json& p : results["pairs"]) recorded.insert(p["images"]["dir"].get<std::string>());
    EXPECT_EQ(folders(dir / "run"), recorded);
  }
  // Stopped in a new directory: marked too, naming the folders it may have written; the next run
  // there removes those it does not record itself (the plugin's pair, its images here made by
  // hand), and nothing else: a folder of the user's under images/ stays, and is said.
  const std::string fresh = common + " --out " + (dir / "fresh").string();
  ASSERT_EQ(contract::arenaCli(fresh + " --denoisers passthrough --plugin " + ARENA_FAULTY_PLUGIN,
                               kFaultOnPurpose + "ARENA_FAULTY_PLUGIN=segfault ")
                .status,
            128 + SIGSEGV);
  ASSERT_TRUE(fs::exists(dir / "fresh" / ".arena.unfinished"));
  EXPECT_FALSE(fs::exists(dir / "fresh" / "results.json"));
  const contract::CliResult freshReport = contract::arenaCli("report " + (dir / "fresh").string() +
                                                             " --out " + (dir / "page2").string());
  EXPECT_EQ(freshReport.status, 2) << freshReport.output;
  EXPECT_NE(freshReport.output.find("it left no results (run it again)"), std::string::npos)
      << freshReport.output;
  // compare says so too, rather than "not a run".
  const contract::CliResult freshCompare =
      contract::arenaCli("compare " + (dir / "run").string() + " " + (dir / "fresh").string());
  EXPECT_EQ(freshCompare.status, 2) << freshCompare.output;
  EXPECT_NE(freshCompare.output.find("fresh: a run into this directory stopped before its commit"),
            std::string::npos)
      << freshCompare.output;
  std::string pluginFolder;
  for (const fs::path& f : unfinishedRunFolders(dir / "fresh"))
    if (f.parent_path().filename() == "cornell_static" && f.filename() != "passthrough")
      pluginFolder = fs::relative(f, dir / "fresh").string();
  ASSERT_FALSE(pluginFolder.empty()) << readText(dir / "fresh" / ".arena.unfinished");
  fs::create_directories(dir / "fresh" / pluginFolder);
  std::ofstream(dir / "fresh" / pluginFolder / "frame_0000.png") << "x";
  fs::create_directories(dir / "fresh" / "images" / "screenshots" / "2024");
  std::ofstream(dir / "fresh" / "images" / "screenshots" / "2024" / "keep.png") << "mine";
  const contract::CliResult rerun = contract::arenaCli(fresh + " --denoisers passthrough");
  ASSERT_EQ(rerun.status, 0) << rerun.output;
  EXPECT_FALSE(fs::exists(dir / "fresh" / ".arena.unfinished"));
  EXPECT_FALSE(fs::exists(dir / "fresh" / pluginFolder));
  EXPECT_TRUE(fs::exists(dir / "fresh" / "images" / "screenshots" / "2024" / "keep.png"));
  EXPECT_NE(rerun.output.find("image folder(s) no run recorded (images/screenshots)"),
            std::string::npos)
      << rerun.output;
  const json results = json::parse(readText(dir / "fresh" / "results.json"));
  ASSERT_EQ(results["pairs"].size(), 1u);
  EXPECT_EQ(folders(dir / "fresh"),
            (std::set<std::string>{"images/cornell_static", results["pairs"][0]["images"]["dir"],
                                   "images/screenshots", "images/screenshots/2024"}));
}

// A demodulated plugin that returns the signals it was given is warned of, as a colour denoiser
// returning its input is: its remodulated colour differs from the frame's by rounding only, which
// a comparison of the colours missed (a plugin author's trial).
TEST(Plugin, ADemodulatedPluginReturningItsInputsIsSaidToFilterNothing) {
  const std::string name = DenoiserRegistry::resolve(pluginSpec(ARENA_FAULTY_PLUGIN));
  ::setenv("ARENA_FAULTY_PLUGIN", "echo", 1);
  const json echoed = runMatrix(tinyRun("echo_plugin", {{name, {}, ""}}));
  ::setenv("ARENA_FAULTY_PLUGIN", "", 1);  // zeros: filtered into nothing, but not its input
  const json zeros = runMatrix(tinyRun("zeros_plugin", {{name, {}, ""}}));
  ::unsetenv("ARENA_FAULTY_PLUGIN");
  const json& pair = echoed["pairs"][0];
  ASSERT_EQ(pair["status"], "ok") << pair.dump().substr(0, 300);
  EXPECT_TRUE(pair.value("equalsInputEveryFrame", false));
  bool warned = false;
  for (const json& w : pair["warnings"])
    warned |= w.get<std::string>().find(
                  "the output is its input value for value on all 6 frames "
                  "(the diffuse and specular signals it was given): ") == 0;
  EXPECT_TRUE(warned) << pair["warnings"].dump();
  EXPECT_FALSE(zeros["pairs"][0].contains("equalsInputEveryFrame"));
}

// A denoiser that returns an image of another size (one that replaces the output it was given) is
// named with both sizes where the harness meets it, not by the remodulation's later "differ in
// size" that named neither.
TEST(DenoiseRun, AnOutputOfAnotherSizeIsAFaultNamingBothSizes) {
  const Image signal(8, 6, 3, 0.5f), half(4, 3, 3, 0.5f), grey(8, 6, 1, 0.5f);
  EXPECT_EQ(
      outputFault(half, signal, "halfsize", SignalKind::Diffuse, 2),
      "halfsize returned a 4x3x3 output on the diffuse signal at frame 2; expected 8x6x3, the "
      "signal's size (write into the output image given, or one of its size)");
  EXPECT_NE(
      outputFault(grey, signal, "grey", SignalKind::Specular, 0).find("returned a 8x6x1 output"),
      std::string::npos);
  EXPECT_EQ(outputFault(signal, signal, "fine", SignalKind::Diffuse, 0), "");
}

// A plugin's error buffer is read only within its size and as valid text; a pass report it makes
// with a NaN time fails the pair; an int parameter it declares as 2.5 is refused at load.
TEST(Plugin, FaultsOfAPluginFailItsPairNamingThem) {
  const std::string name = DenoiserRegistry::resolve(pluginSpec(ARENA_FAULTY_PLUGIN));
  ::setenv("ARENA_FAULTY_PLUGIN", "unterminated", 1);
  const std::string e = errorOf([&] { denoiseAll({name, {}, ""}, tinySequence()); });
  EXPECT_NE(e.find("denoise (frame 0) failed: eeee"), std::string::npos) << e.substr(0, 200);
  EXPECT_LT(e.size(), 1024u + 300u) << "read past the error buffer";
  EXPECT_NO_THROW(static_cast<void>(json(e).dump()));
  ::setenv("ARENA_FAULTY_PLUGIN", "bad-pass", 1);
  const std::string pass = errorOf([&] { denoiseAll({name, {}, ""}, tinySequence()); });
  EXPECT_NE(pass.find("reportPass 'blur': milliseconds nan"), std::string::npos) << pass;
  // Success without writing the output: scored before on what the buffer held from the frame
  // before; now the harness marks the buffer before each call and fails the pair.
  ::setenv("ARENA_FAULTY_PLUGIN", "unwritten", 1);
  const std::string unwritten = errorOf([&] { denoiseAll({name, {}, ""}, tinySequence()); });
  EXPECT_NE(
      unwritten.find("left 1728 of the 1728 values of its diffuse output unwritten at frame 0"),
      std::string::npos)
      << unwritten;
  EXPECT_NE(unwritten.find(name + " (plugin /"), std::string::npos) << unwritten;
  ::setenv("ARENA_FAULTY_PLUGIN", "partial", 1);
  const std::string partial = errorOf([&] { denoiseAll({name, {}, ""}, tinySequence()); });
  EXPECT_NE(partial.find("left 1152 of the 1728 values"), std::string::npos) << partial;
  // The denoise bench marks its output too: a call that writes part of it is not timed as a call
  // that did the work.
  DenoiseBench bench;
  bench.sceneFile = std::string(ARENA_SOURCE_DIR) + "/scenes/cornell_static.json";
  bench.denoisers = {name};
  bench.width = kWidth, bench.height = kHeight, bench.frames = 2, bench.warmup = 0,
  bench.inputs = 2;
  const std::string benched = errorOf([&] { benchDenoise(bench, [](const std::string&) {}); });
  EXPECT_NE(benched.find("bench denoise: every contender failed, nothing was timed: " + name +
                         " (plugin "),
            std::string::npos)
      << benched;
  EXPECT_NE(
      benched.find(") left 1152 of the 1728 values of its diffuse output unwritten at frame 0"),
      std::string::npos)
      << benched;
  // Beside a contender that works, the failing one is reported failed with its error and the
  // other timed, as a run fails only the failed pair.
  bench.denoisers = {"eaw", name};
  std::vector<std::string> lines;
  const json both = benchDenoise(bench, [&](const std::string& l) { lines.push_back(l); });
  ASSERT_EQ(both["denoisers"].size(), 2u);
  EXPECT_EQ(both["denoisers"][0]["status"], "ok");
  EXPECT_GT(both["denoisers"][0]["msMedian"].get<double>(), 0.0);
  EXPECT_EQ(both["denoisers"][1]["status"], "failed");
  EXPECT_FALSE(both["denoisers"][1].contains("msMedian"));
  EXPECT_NE(both["denoisers"][1]["error"].get<std::string>().find("left 1152 of the 1728 values"),
            std::string::npos)
      << both["denoisers"][1];
  bool said = false;
  for (const std::string& l : lines)
    said |= l.find(name + " failed at frame 0") != std::string::npos;
  EXPECT_TRUE(said);
  ::setenv("ARENA_FAULTY_PLUGIN", "", 1);
  EXPECT_EQ(denoiseAll({name, {}, ""}, tinySequence()).size(), size_t(kFrames));
  // A pass reported longer than the call that ran it: the pair is measured, its times are warned
  // of.
  ::setenv("ARENA_FAULTY_PLUGIN", "slow-pass", 1);
  const json slow = runMatrix(tinyRun("slow_pass", {{name, {}, ""}}));
  // The denoise bench says so too: its ms would otherwise be copied into a comparison unwarned.
  bench.denoisers = {name};
  std::vector<std::string> benchLines;
  const json slowBench =
      benchDenoise(bench, [&](const std::string& l) { benchLines.push_back(l); });
  ::unsetenv("ARENA_FAULTY_PLUGIN");
  EXPECT_EQ(slowBench["denoisers"][0]["implausibleFrames"], bench.frames);
  EXPECT_NE(slowBench["denoisers"][0]
                .value("implausibleFirst", "")
                .find("frame 0, diffuse: passes of 1e+09 ms in all in a call of"),
            std::string::npos)
      << slowBench["denoisers"][0];
  bool warned = false;
  for (const std::string& l : benchLines)
    warned |= l.find("warning: reported times longer than the call that carried them on 2 of 2") !=
              std::string::npos;
  EXPECT_TRUE(warned);
  ASSERT_EQ(slow["pairs"][0]["status"], "ok") << slow["pairs"][0].dump().substr(0, 300);
  EXPECT_EQ(slow["pairs"][0]["timing"]["implausibleFrames"], kFrames);
  const std::string warning = slow["pairs"][0]["warnings"][0];
  EXPECT_NE(warning.find("reported times longer than the call that carried them on 6 of 6 frames "
                         "(frame 0, diffuse: passes of 1e+09 ms in all in a call of"),
            std::string::npos)
      << warning;
  // A descriptor's negative count is refused (it loaded as if it declared nothing).
  ::setenv("ARENA_FAULTY_DESCRIPTOR", "negative-count", 1);
  const std::string negative =
      errorOf([] { DenoiserRegistry::resolve(pluginSpec(ARENA_FAULTY_PARAMS_PLUGIN)); });
  ::unsetenv("ARENA_FAULTY_DESCRIPTOR");
  EXPECT_NE(negative.find("paramCount -2 (expected a count >= 0)"), std::string::npos) << negative;
  // A missing entry point is named, and a layer required twice is refused as a manifest's is.
  const auto loadWith = [](const char* descriptor) {
    ::setenv("ARENA_FAULTY_DESCRIPTOR", descriptor, 1);
    const std::string refused =
        errorOf([] { DenoiserRegistry::resolve(pluginSpec(ARENA_FAULTY_PARAMS_PLUGIN)); });
    ::unsetenv("ARENA_FAULTY_DESCRIPTOR");
    return refused;
  };
  const std::string noReset = loadWith("null-reset");
  EXPECT_NE(noReset.find(": its ArenaPlugin's reset is NULL (a name and the entry points"),
            std::string::npos)
      << noReset;
  const std::string twice = loadWith("duplicate-channel");
  EXPECT_NE(twice.find(": requiredChannels[2]: 'depth' is already requiredChannels[0]; name each "
                       "layer once"),
            std::string::npos)
      << twice;
  const std::string params =
      errorOf([] { DenoiserRegistry::resolve(pluginSpec(ARENA_FAULTY_PARAMS_PLUGIN)); });
  EXPECT_NE(params.find("an int parameter's default, min and max must be whole numbers"),
            std::string::npos)
      << params;
}

TEST(Plugin, AnotherAbiVersionIsRefused) {
  const std::string e =
      errorOf([] { DenoiserRegistry::resolve(pluginSpec(ARENA_WRONG_ABI_PLUGIN)); });
  EXPECT_NE(e.find("built against plugin ABI version 999, but this arena speaks version 1"),
            std::string::npos)
      << e;
  const std::string missing =
      errorOf([] { DenoiserRegistry::resolve("plugin:/no/such/libfoo.so"); });
  EXPECT_NE(missing.find("no such plugin library"), std::string::npos) << missing;
  // Named by a manifest: the manifest is named too (the library path alone did not say which).
  const fs::path manifest = writeManifest("ghost", {{"name", "ghost"}, {"library", "libghost.so"}});
  const std::string viaManifest =
      errorOf([&] { DenoiserRegistry::resolve("ext:" + manifest.string()); });
  EXPECT_NE(viaManifest.find(manifest.string() + ": $.library: "), std::string::npos)
      << viaManifest;
  EXPECT_NE(viaManifest.find("libghost.so: no such plugin library"), std::string::npos)
      << viaManifest;
  const std::string notPlugin =
      errorOf([] { DenoiserRegistry::resolve(pluginSpec(ARENA_BINARY)); });
  EXPECT_NE(notPlugin.find("cannot load the plugin"), std::string::npos) << notPlugin;
}

// --- isolated plugins and `arena serve`
// -----------------------------------------------------------

// The camera-cut room, 32x18, 10 frames: the cut at frame 8 resets every denoiser.
const Sequence& cutSequence() {
  static const Sequence sequence = Sequence::open(
      renderSequence(test::shippedScene("camera_cut"), test::tinySettings(kWidth, kHeight, 10, 2),
                     sequenceCache(), nullptr));
  return sequence;
}

// A built-in served by `arena serve` over the frame protocol gives, frame by frame, the pixels it
// gives inside arena: the planes mapped back to its layers, the parameters to its schema, the
// reset at the cut called as DenoiseRun calls it. Its time is the wall clock the server took
// around its call, reported as computeMs.
TEST(Serve, ABuiltInServedGivesTheSamePixelsAsInsideArena) {
  const auto svgf = DenoiserRegistry::instance().find("svgf").create(
      DenoiserRegistry::instance().find("svgf").schema.resolve({}, "svgf"), SignalKind::Diffuse);
  const json m = {
      {"name", "svgf-served"},
      {"command", {ARENA_BINARY, "serve", "svgf"}},
      {"signals", "demodulated"},
      {"channels", svgf->requiredChannels()},
      {"parameters",
       {{{"name", "sigmaL"}, {"type", "float"}, {"default", 4}, {"min", 0}, {"max", 1e6}}}}};
  const std::string name =
      DenoiserRegistry::resolve("ext:" + writeManifest("svgf-served", m).string());
  const Sequence& seq = cutSequence();
  ASSERT_TRUE(std::any_of(seq.info().events.begin(), seq.info().events.end(),
                          [](const SequenceEvent& e) { return e.kind == EventKind::CameraCut; }));
  for (const char* sigmaL : {"4", "0.75"}) {
    const auto inside = denoiseAll({"svgf", {{"sigmaL", sigmaL}}, ""}, seq);
    const auto served = denoiseAll({name, {{"sigmaL", sigmaL}}, ""}, seq);
    ASSERT_EQ(served.size(), inside.size());
    for (size_t t = 0; t < inside.size(); ++t) {
      EXPECT_TRUE(samePixels(inside[t].color, served[t].color))
          << "sigmaL " << sigmaL << " frame " << t;
      EXPECT_TRUE(served[t].selfTimed);
      EXPECT_GT(served[t].milliseconds, 0.0);
      EXPECT_LE(served[t].milliseconds, served[t].wallMilliseconds);
      ASSERT_EQ(served[t].passes.size(), inside[t].passes.size());
      EXPECT_EQ(served[t].passes[0].name, inside[t].passes[0].name);
      EXPECT_EQ(served[t].passes[0].tapsPerPixel, inside[t].passes[0].tapsPerPixel);
    }
  }
  // The two settings differ: the parameter went over the wire.
  EXPECT_FALSE(samePixels(denoiseAll({name, {{"sigmaL", "4"}}, ""}, seq)[3].color,
                          denoiseAll({name, {{"sigmaL", "0.75"}}, ""}, seq)[3].color));
  // reset() is called at the cut and nowhere else, served as inside arena: the faulty plugin's
  // reset-check fails a frame where it was called without a cut, or not called at one.
  const std::string inside = DenoiserRegistry::resolve(pluginSpec(ARENA_FAULTY_PLUGIN));
  const std::string served = DenoiserRegistry::resolve(
      "ext:" + writeManifest("faulty-served",
                             {{"name", "faulty-served"},
                              {"command", {ARENA_BINARY, "serve", pluginSpec(ARENA_FAULTY_PLUGIN)}},
                              {"signals", "demodulated"}})
                   .string());
  ::setenv("ARENA_FAULTY_PLUGIN", "reset-check", 1);
  EXPECT_EQ(errorOf([&] { denoiseAll({inside, {}, ""}, seq); }), "(no error)");
  EXPECT_EQ(errorOf([&] { denoiseAll({served, {}, ""}, seq); }), "(no error)");
  ::unsetenv("ARENA_FAULTY_PLUGIN");
}

// What `arena serve --describe` prints of a schema reads back as the same schema: every parameter
// of every built-in, through a manifest's "parameters" and back.
TEST(Serve, ASchemaDescribedReadsBackTheSame) {
  for (const std::string& name : DenoiserRegistry::instance().names()) {
    const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
    if (!info.origin.empty()) continue;
    json d = {{"name", "described"}, {"command", {"x"}}, {"signals", "demodulated"}};
    for (const ParamSpec& spec : info.schema.specs())
      d["parameters"].push_back(paramSpecJson(spec));
    const ExternalManifest m = manifestFromJson(d, "described.json", "described");
    ASSERT_EQ(m.schema.specs().size(), info.schema.specs().size()) << name;
    for (size_t i = 0; i < m.schema.specs().size(); ++i)
      EXPECT_EQ(m.schema.specs()[i].describe(), info.schema.specs()[i].describe()) << name;
  }
}

// `arena serve` refuses what the protocol does not allow, answering an error message the harness
// quotes (exit 1), and a denoiser it cannot serve before reading anything (exit 2).
TEST(Serve, EveryMistakeIsAnsweredWithAnError) {
  const fs::path dir = test::freshDir("serve_contract");
  // svgf's layers, plane by plane, as the harness would announce them.
  json svgfPlanes = {"signal.R", "signal.G", "signal.B"};
  const auto svgf = DenoiserRegistry::instance().find("svgf").create(
      DenoiserRegistry::instance().find("svgf").schema.resolve({}, "svgf"), SignalKind::Diffuse);
  for (const std::string& layer : svgf->requiredChannels()) {
    const LayerSpec& spec = frameLayerSpec(layer, "svgf");
    for (int c = 0; c < spec.channels(); ++c) svgfPlanes.push_back(spec.channelName(c));
  }
  const size_t frameBytes = svgfPlanes.size() * 2 * sizeof(float);
  const json setup = {
      {"type", "setup"}, {"protocol", 1}, {"denoiser", "svgf"},   {"signal", "diffuse"},
      {"width", 2},      {"height", 1},   {"planes", svgfPlanes}, {"params", json::object()}};
  auto serve = [&](const std::string& entry, const std::string& input) {
    std::ofstream(dir / "in", std::ios::binary) << input;
    return test::runCommand(std::string(ARENA_BINARY) + " serve " + entry + " < " +
                            (dir / "in").string());
  };
  auto patched = [&](const json& patch) {
    json s = setup;
    if (!patch.is_null()) s.merge_patch(patch);
    return s.dump() + "\n";
  };
  const auto unknown = serve("nosuch", "");
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.output.find("arena serve: unknown denoiser 'nosuch'; serve takes "
                                "plugin:LIBRARY or a built-in: passthrough, "),
            std::string::npos)
      << unknown.output;
  const auto nothing = serve("svgf", "");
  EXPECT_EQ(nothing.status, 1);
  EXPECT_NE(nothing.output.find("the input ended before the setup line"), std::string::npos)
      << nothing.output;
  struct Case {
    const char* entry;
    std::string input;
    std::string expected;
  };
  CameraState camera = cutSequence().info().cameras[0];
  camera.width = 2, camera.height = 1;  // the frames' size
  const json frame = {{"type", "frame"},
                      {"frame", 0},
                      {"reset", true},
                      {"bytes", frameBytes},
                      {"camera", cameraToJson(camera)},
                      {"previousCamera", cameraToJson(camera)}};
  const std::string frameHeader = frame.dump() + "\n";
  auto frameWith = [&](const json& patch) {
    json f = frame;
    f.merge_patch(patch);
    return f.dump() + "\n";
  };
  const std::string zeros(frameBytes, '\0');
  std::string nanPlanes = zeros;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nanPlanes.data() + 2 * sizeof(float), &nan, sizeof nan);  // signal.G, pixel 0
  const std::vector<Case> cases = {
      {"svgf", patched({{"protocol", 2}}), "setup: protocol 2; this arena speaks version 1"},
      {"svgf", "hello\n", "expected a JSON 'setup' line, got: hello"},
      {"svgf", patched({{"width", 0}}), "integer \\\"width\\\" in [1, 32768], got: 0"},
      {"svgf", patched({{"signal", "color"}}),
       "setup: signal 'color', but svgf filters the demodulated diffuse and specular signals"},
      {"svgf", patched({{"planes", {"signal.R", "signal.G", "signal.B", "depth"}}}),
       "svgf reads the layer 'depth', but \\\"planes\\\" has no 'depth.Z'"},
      {"svgf", patched({{"planes", {"diffuse.R"}}}),
       "\\\"planes\\\" must begin with signal.R, signal.G, signal.B; got 'diffuse.R' at index 0"},
      {"svgf", patched({{"params", {{"sigmaQ", 1}}}}), "sigmaQ"},
      {"asvgf", patched({{"denoiser", "asvgf"}}),
       "asvgf reads A-SVGF's gradient samples, which the frame protocol does not carry"},
      {"svgf",
       patched({}) + json{{"type", "frame"}, {"frame", 0}, {"reset", true}, {"bytes", 8}}.dump() +
           "\n",
       "frame 0: \\\"bytes\\\" must be"},
      {"svgf", patched({}) + frameHeader + std::string(20, '\0'),
       "frame 0: plane 'signal.B' (3 of " + std::to_string(svgfPlanes.size()) +
           "): the input ended after 4 of its 8 bytes"},
  };
  const std::vector<Case> frames = {
      {"svgf", patched({}) + frameWith({{"camera", {{"width", 32}}}}) + zeros,
       "frame 0: \\\"camera\\\" is 32x1; the frames are 2x1"},
      {"svgf", patched({}) + frameWith({{"previousCamera", {{"eye", {1, 2}}}}}) + zeros,
       "frame 0: \\\"previousCamera\\\": camera.eye: expected 3 numbers, got [1,2]"},
      {"svgf", patched({}) + frameWith({{"camera", nullptr}}) + zeros,
       "frame 0: \\\"camera\\\": a camera must be an object"},
      {"svgf", patched({}) + frameHeader + nanPlanes,
       "frame 0: its input plane 'signal.G' holds 1 non-finite value(s)"},
      {"svgf", patched({{"planes", {"signal.R", "signal.G", "signal.B", "meshId", "meshId"}}}),
       "setup: \\\"planes\\\" names 'meshId' twice"},
  };
  for (const Case& c : frames) {
    const auto r = serve(c.entry, c.input);
    EXPECT_EQ(r.status, 1) << c.expected << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.expected << "\n" << r.output;
  }
  // A manifest names a program that speaks the protocol itself: not served again.
  const auto manifest = serve("ext:" ARENA_EXAMPLES_BINARY_DIR "/cpp_box", "");
  EXPECT_EQ(manifest.status, 2) << manifest.output;
  EXPECT_NE(manifest.output.find("serve takes plugin:LIBRARY or a built-in's name"),
            std::string::npos)
      << manifest.output;
  for (const Case& c : cases) {
    const auto r = serve(c.entry, c.input);
    EXPECT_EQ(r.status, 1) << c.expected << "\n" << r.output;
    EXPECT_NE(r.output.find("{\"message\":"), std::string::npos) << r.output;  // the answer
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.expected << "\n" << r.output;
  }
  // Whole frames, then the end of the input: ready, one result, exit 0.
  const auto good = serve("svgf", patched({}) + frameHeader + zeros);
  EXPECT_EQ(good.status, 0) << good.output;
  EXPECT_NE(good.output.find("{\"type\":\"ready\"}"), std::string::npos) << good.output;
  EXPECT_NE(good.output.find("\"type\":\"result\""), std::string::npos) << good.output;
}

// A plugin whose manifest says "isolated": true runs in `arena serve`, a process of its own per
// sequence and signal: the same pixels as inside arena, timed by the server around its call; a
// crash or a hang fails its own pair, and the run's other pairs and results stand.
TEST(Plugin, AnIsolatedPluginsCrashOrHangFailsOnlyItsPair) {
  const fs::path dir = test::freshDir("isolated_plugins");
  const json eaw = {{"name", "eaw-plugin"}, {"library", ARENA_EAW_PLUGIN}, {"isolated", true}};
  // 2 s: a process's start and its ready answer fit in it on a busy machine (the suite runs two
  // tests at a time); a hang on frame 0 is found after it.
  const json faulty = {{"name", "faulty"},
                       {"library", ARENA_FAULTY_PLUGIN},
                       {"isolated", true},
                       {"timeoutSeconds", 2}};
  fs::create_directories(dir / "eaw");
  fs::create_directories(dir / "faulty");
  std::ofstream(dir / "eaw" / "manifest.json") << eaw.dump();
  std::ofstream(dir / "faulty" / "manifest.json") << faulty.dump();
  auto run = [&](const std::string& mode, const std::string& name) {
    return contract::arenaCli(
        "run --scenes cornell_static --denoisers eaw,ext:" + (dir / "eaw").string() +
            ",ext:" + (dir / "faulty").string() +
            " --no-baselines --resolution 16x8 --frames 3 --warmup 1 --ref-spp 1 --flip none "
            "--keep-frames none --cache " +
            (dir / "cache").string() + " --out " + (dir / name).string(),
        kFaultOnPurpose + "ARENA_FAULTY_PLUGIN=" + mode + " ");
  };
  const contract::CliResult crashed = run("segfault", "crash");
  ASSERT_TRUE(fs::exists(dir / "crash" / "results.json")) << crashed.output;
  const json results = json::parse(std::ifstream(dir / "crash" / "results.json"));
  std::map<std::string, json> pairs;
  for (const json& p : results["pairs"]) pairs[p["denoiser"].get<std::string>()] = p;
  ASSERT_EQ(pairs.size(), 3u) << crashed.output;
  EXPECT_EQ(pairs["eaw"]["status"], "ok");
  EXPECT_EQ(pairs["eaw-plugin"]["status"], "ok") << pairs["eaw-plugin"].dump().substr(0, 400);
  EXPECT_EQ(pairs["eaw-plugin"]["outputChecksum"], pairs["eaw"]["outputChecksum"]);
  EXPECT_EQ(pairs["eaw-plugin"]["timing"]["msSource"], "reported by the process");
  EXPECT_NE(pairs["eaw-plugin"]["origin"].get<std::string>().find("isolated plugin /"),
            std::string::npos);
  // The report's tables say "isolated plugin" (they said "stored output", a capture's word).
  EXPECT_EQ(contenderKind(pairs["eaw-plugin"]["origin"]), "isolated plugin");
  EXPECT_EQ(pairs["faulty"]["status"], "failed");
  const std::string crash = pairs["faulty"]["error"];
  for (const char* said :
       {"faulty (diffuse process, ", "frame 0: ", "the process was killed by signal 11",
        "arena: fatal: signal 11 (Segmentation fault) in plugin faulty's denoise of frame 0",
        "this process (arena serve, the plugin's isolated host) ends here; the harness fails this "
        "pair alone"})
    EXPECT_NE(crash.find(said), std::string::npos) << said << "\n" << crash;
  const contract::CliResult hung = run("hang", "hang");
  const json hangResults = json::parse(std::ifstream(dir / "hang" / "results.json"));
  bool timedOut = false;
  for (const json& p : hangResults["pairs"])
    if (p["denoiser"] == "faulty") {
      EXPECT_EQ(p["status"], "failed");
      timedOut = p["error"].get<std::string>().find(
                     "frame 0: no result header within timeoutSeconds = 2 s (a hang?); the "
                     "process was killed by the harness") != std::string::npos;
      EXPECT_TRUE(timedOut) << p["error"];
    } else {
      EXPECT_EQ(p["status"], "ok") << p["denoiser"];
    }
  EXPECT_TRUE(timedOut) << hung.output;
  // Isolated, the library is loaded only in a process of its own (arena serve --describe): a
  // crash or a hang while it loads, or a descriptor it gets wrong, refuses the manifest before
  // anything runs, naming how that process ended, and arena itself exits 2.
  const json params = {{"name", "faulty-params"},
                       {"library", ARENA_FAULTY_PARAMS_PLUGIN},
                       {"isolated", true},
                       {"timeoutSeconds", 0.5}};
  fs::create_directories(dir / "params");
  std::ofstream(dir / "params" / "manifest.json") << params.dump();
  auto describeWith = [&](const std::string& environment) {
    return contract::arenaCli("denoisers",
                              environment + "ARENA_DENOISER_PATH=" + dir.string() + " ");
  };
  auto loadWith = [&](const std::string& environment) {
    return contract::arenaCli(
        "run --scenes cornell_static --denoisers ext:" + (dir / "params").string() +
            " --no-baselines --resolution 16x8 --frames 3 --warmup 1 "
            "--ref-spp 1 --flip none --keep-frames none --cache " +
            (dir / "cache").string() + " --out " + (dir / "load").string(),
        environment);
  };
  const contract::CliResult loadCrash =
      loadWith(kFaultOnPurpose + "ARENA_FAULTY_DESCRIPTOR=crash ");
  EXPECT_EQ(loadCrash.status, 2) << loadCrash.output;
  for (const char* said :
       {"$.library: ", "loading it in its isolated process (arena serve --describe) failed",
        "the process was killed by signal 11",
        "arena: fatal: signal 11 (Segmentation fault) while loading plugin library ",
        "this process (arena serve --describe, the plugin's isolated host) ends here, and arena "
        "refuses the manifest before anything runs"})
    EXPECT_NE(loadCrash.output.find(said), std::string::npos) << said << "\n" << loadCrash.output;
  const contract::CliResult loadHang = loadWith("ARENA_FAULTY_DESCRIPTOR=hang ");
  EXPECT_EQ(loadHang.status, 2) << loadHang.output;
  EXPECT_NE(loadHang.output.find("gave no description within 10 s (timeoutSeconds, at least 10 s "
                                 "for loading: a hang while loading?); the process was killed"),
            std::string::npos)
      << loadHang.output;
  const contract::CliResult badSchema = loadWith("");
  EXPECT_EQ(badSchema.status, 2) << badSchema.output;
  EXPECT_NE(badSchema.output.find("an int parameter's default, min and max must be whole numbers"),
            std::string::npos)
      << badSchema.output;
  EXPECT_FALSE(fs::exists(dir / "load"));
  // `arena denoisers` lists what it can and warns of the rest: its own process goes on.
  const contract::CliResult listed =
      describeWith(kFaultOnPurpose + "ARENA_FAULTY_DESCRIPTOR=crash ");
  EXPECT_EQ(listed.status, 0) << listed.output;
  EXPECT_NE(listed.output.find("eaw-plugin: "), std::string::npos) << listed.output;
  EXPECT_NE(listed.output.find("(not listed)"), std::string::npos) << listed.output;
  // Its manifest's mistakes are named: a timeout without isolation, isolation of a command.
  const std::string timeout = errorOf([&] {
    readManifest(writeManifest("timeout_inside",
                               {{"name", "faulty"}, {"library", "x.so"}, {"timeoutSeconds", 3}}));
  });
  EXPECT_NE(timeout.find("$.timeoutSeconds: a plugin inside arena's process has no timeout"),
            std::string::npos)
      << timeout;
  const std::string command = errorOf([&] {
    readManifest(writeManifest(
        "isolated_command",
        {{"name", "c"}, {"command", {"/bin/cat"}}, {"signals", "color"}, {"isolated", true}}));
  });
  EXPECT_NE(command.find("$.isolated: applies to a \"library\""), std::string::npos) << command;
}

}  // namespace
}  // namespace arena
