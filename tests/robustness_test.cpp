// Issue 16: no input reaches a crash, a silently wrong value, half-written state or a message
// without a path. One suite per class of failure; CLI cases go through the built `arena`.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <regex>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/non_finite.hpp"
#include "core/sequence.hpp"
#include "harness/denoise_run.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/compare.hpp"
#include "metrics/results.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using CliResult = test::CommandResult;

// Runs `arena ARGS` through the shell (so tests can use redirections and ulimit).
CliResult arenaCli(const std::string& args, const std::string& prefix = "") {
  return test::runCommand(prefix + std::string(ARENA_BINARY) + " " + args);
}

// A small valid scene; tests change one field to make it invalid.
json minimalScene() {
  return json::parse(R"({
    "purpose": "test", "resolution": [16, 8], "frames": 3, "seed": 1,
    "camera": {"keys": [{"frame": 0, "eye": [0, 1, 4], "target": [0, 1, 0], "up": [0, 1, 0], "fov": 40}]},
    "materials": {"white": {"albedo": [0.7, 0.7, 0.7]}, "lamp": {"emission": [4, 4, 4]}},
    "objects": [{"name": "floor", "shape": "quad", "material": "white",
                 "keys": [{"frame": 0, "scale": [4, 1, 4]}]}],
    "lights": [{"name": "light", "shape": "quad", "keys": [{"frame": 0, "translate": [0, 3, 0], "intensity": 5}]}]
  })");
}

// The Error message of parsing `scene`, or "" when it parsed.
std::string sceneError(const json& scene, const std::string& path = "scenes/t.json") {
  try {
    parseScene(scene.dump(), path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

fs::path writeScene(const fs::path& dir, const std::string& name, const json& scene) {
  fs::create_directories(dir);
  fs::path p = dir / (name + ".json");
  writeTextAtomically(p, scene.dump(1));
  return p;
}

// ---- class 3: crashes -------------------------------------------------------------------------

TEST(Class3Crashes, DeeplyNestedJsonIsRejectedBeforeAnyRecursiveWalk) {
  for (const std::string& open : {std::string("["), std::string("{\"a\":")}) {
    std::string text;
    for (int i = 0; i < 100000; ++i) text += open;
    try {
      parseScene(text, "deep.json");
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("deep.json: JSON nested deeper than 64 levels"),
                std::string::npos)
          << e.what();
    }
  }
  // Brackets inside strings are text, not nesting.
  json s = minimalScene();
  s["purpose"] = std::string(1000, '[');
  EXPECT_EQ(sceneError(s), "");
  // Through the CLI: exit 2 with the file named, not a segfault (exit 139).
  fs::path dir = test::freshDir("deep_cli");
  writeTextAtomically(dir / "deep.json", std::string(200000, '['));
  CliResult r = arenaCli("scenes --scenes-dir " + dir.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("deep.json: JSON nested deeper"), std::string::npos) << r.output;
}

TEST(Class3Crashes, UnusableCamerasAreErrorsNamingTheJsonPath) {
  auto withKey = [](const json& key) {
    json s = minimalScene();
    for (auto& [k, v] : key.items()) s["camera"]["keys"][0][k] = v;
    return sceneError(s);
  };
  EXPECT_NE(withKey({{"up", {0, 0, 0}}})
                .find("scenes/t.json: $.camera.keys[0].up: expected a usable camera basis: up "
                      "is the zero vector"),
            std::string::npos)
      << withKey({{"up", {0, 0, 0}}});
  EXPECT_NE(withKey({{"up", {0, 0, -1}}, {"eye", {0, 0, 4}}, {"target", {0, 0, 0}}})
                .find("is parallel to the view"),
            std::string::npos);
  EXPECT_NE(withKey({{"eye", {1e39, 0, 0}}})
                .find("$.camera.keys[0].eye: expected values that fit a float"),
            std::string::npos);
  EXPECT_NE(withKey({{"eye", {1e7, 0, 0}}}).find("$.camera.keys[0].eye: expected values within"),
            std::string::npos);
  EXPECT_NE(withKey({{"target", {0, 1, 4}}}).find("target equals the eye"), std::string::npos);
  // Each key is fine, the interpolation between them is not: up passes through zero at frame 1.
  json s = minimalScene();
  s["camera"]["keys"].push_back({{"frame", 2}, {"up", {0, -1, 0}}});
  EXPECT_NE(
      sceneError(s).find(
          "$.camera.keys: the interpolated camera at frame 1 is unusable: up is the zero vector"),
      std::string::npos)
      << sceneError(s);
}

TEST(Class3Crashes, NegativeWarmupIsRejectedByTheCli) {
  fs::path out = test::freshDir("warmup_cli");
  CliResult r = arenaCli(
      "run --scenes cornell_static --denoisers passthrough --no-baselines --resolution 8x8 "
      "--frames 2 --ref-spp 1 --cache " +
      (out / "cache").string() + " --out " + (out / "run").string() + " --warmup -3");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--warmup"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("-3"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "run" / "results.json"));
}

TEST(Class3Crashes, ResultsOfTheWrongShapeAreErrorsNamingThePath) {
  fs::path run = test::freshDir("shapeless_run");
  json doc = {{"schema", kResultsSchemaVersion},
              {"kind", "arena-run"},
              {"name", "x"},
              {"settings", json::object()},
              {"environment", json::object()},
              {"scenes", json::object()}};
  writeTextAtomically(run / "results.json", doc.dump());
  try {
    loadResults(run);
    ADD_FAILURE() << "accepted a results.json without pairs";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("results.json: $.pairs: expected an array of pairs, got null"),
        std::string::npos)
        << e.what();
  }
  doc["pairs"] = json::array(
      {{{"scene", "a"}, {"denoiser", "d"}, {"label", "d"}, {"status", "ok"}, {"summary", 3}}});
  writeTextAtomically(run / "results.json", doc.dump());
  EXPECT_THROW(loadResults(run), Error);
  doc["kind"] = 7;  // a wrong type where a string is expected
  writeTextAtomically(run / "results.json", doc.dump());
  EXPECT_THROW(loadResults(run), Error);
  // `arena report` on it: exit 2 naming the path, not an out-of-bounds read.
  doc["kind"] = "arena-run";
  doc.erase("pairs");
  writeTextAtomically(run / "results.json", doc.dump());
  CliResult r = arenaCli("report " + run.string() + " --out " + (run / "report").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("$.pairs"), std::string::npos) << r.output;
}

TEST(Class3Crashes, AResolutionBeyondMemoryIsAClearErrorBeforeAllocating) {
  json s = minimalScene();
  s["resolution"] = {16384, 16384};
  fs::path dir = test::freshDir("huge_scene");
  fs::path file = writeScene(dir, "huge", s);
  Scene scene = loadScene(file.string());
  RenderSettings settings = test::tinySettings(16384, 16384, 100000, 1);
  try {
    requireFitsInMemory(scene, settings, true);
    ADD_FAILURE() << "16384x16384 x 100000 frames fits?";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("huge.json: 16384x16384 x 100000 frames needs about"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(requireFitsInMemory(scene, test::tinySettings(64, 32, 10, 1), true));
  CliResult r =
      arenaCli("run --scenes " + file.string() + " --denoisers passthrough --frames 100000 --out " +
               (dir / "run").string() + " --cache " + (dir / "cache").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("GiB of memory"), std::string::npos) << r.output;
}

// ---- class 4: silent wrong values -------------------------------------------------------------

TEST(Class4WrongValues, IntegersBeyondTheirRangeAreErrorsNotWrapped) {
  struct Case {
    const char* pointer;
    json value;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"/frames", 4294967300LL, "$.frames: expected an integer in [1, 100000], got 4294967300"},
      {"/frames", 0, "$.frames: expected an integer in [1, 100000], got 0"},
      {"/seed", 4294967297LL, "$.seed: expected an integer in [0, 2147483647], got 4294967297"},
      {"/seed", -1, "$.seed: expected an integer in [0, 2147483647], got -1"},
      {"/max_bounces", 2147483648LL,
       "$.max_bounces: expected an integer in [1, 64], got 2147483648"},
      {"/resolution", json::array({4294967312LL, 8}), "$.resolution: expected two integers"},
      {"/resolution", json::array({1e39, 8}), "$.resolution: expected two integers"},
      {"/camera/keys/0/frame", 4294967296LL,
       "$.camera.keys[0].frame: expected an integer in [-2147483648"},
      {"/frames", 18446744073709551615ULL, "got 18446744073709551615"},
  };
  for (const Case& c : cases) {
    json s = minimalScene();
    s[json::json_pointer(c.pointer)] = c.value;
    EXPECT_NE(sceneError(s).find(c.message), std::string::npos)
        << c.pointer << ": " << sceneError(s);
  }
  // The CLI's integers are range-checked too (CLI11 rejects what does not fit an int).
  CliResult r = arenaCli("render cornell_static --frames 4294967300 --cache /nonexistent/never");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--frames"), std::string::npos) << r.output;
}

TEST(Class4WrongValues, RadianceAndCoordinatesThatOverflowFloatAreRejected) {
  json s = minimalScene();
  s["materials"]["lamp"]["emission"] = {1e30, 0, 0};
  EXPECT_NE(sceneError(s).find("$.materials.lamp.emission: expected values within"),
            std::string::npos)
      << sceneError(s);
  s = minimalScene();
  s["lights"][0]["keys"][0]["color"] = {1e6, 1, 1};
  s["lights"][0]["keys"][0]["intensity"] = 1e9;
  EXPECT_NE(sceneError(s).find("$.lights[0].keys[0].color: expected intensity * color"),
            std::string::npos);
  s = minimalScene();
  s["objects"][0]["keys"][0]["translate"] = {0, 3e38, 0};
  EXPECT_NE(sceneError(s).find("$.objects[0].keys[0].translate: expected values within"),
            std::string::npos);
}

TEST(Class4WrongValues, TwoSceneFilesWithOneStemCannotShareARun) {
  fs::path dir = test::freshDir("same_stem");
  fs::path a = writeScene(dir / "a", "room", minimalScene()),
           b = writeScene(dir / "b", "room", minimalScene());
  try {
    selectScenes(a.string() + "," + b.string(), dir.string());
    ADD_FAILURE() << "accepted two scenes named room";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("share the name 'room'"), std::string::npos) << e.what();
  }
}

TEST(Class4WrongValues, MeshFilesMustBeBoundedRegularFiles) {
  fs::path dir = test::freshDir("mesh_files");
  auto meshScene = [&](const std::string& file) {
    json s = minimalScene();
    s["objects"].push_back({{"name", "m"},
                            {"shape", "mesh"},
                            {"file", file},
                            {"material", "white"},
                            {"keys", json::array({{{"frame", 0}}})}});
    return sceneError(s, (dir / "t.json").string());
  };
  EXPECT_NE(meshScene("/dev/zero").find("$.objects[1].file: /dev/zero: not a regular file"),
            std::string::npos)
      << meshScene("/dev/zero");
  fs::create_directories(dir / "folder.obj");
  EXPECT_NE(meshScene("folder.obj").find("not a regular file"), std::string::npos);
  {  // a sparse file just over the limit: costs no disk
    FILE* f = std::fopen((dir / "huge.obj").c_str(), "wb");
    ASSERT_TRUE(f);
    std::fclose(f);
    fs::resize_file(dir / "huge.obj", kMaxMeshBytes + 1);
  }
  EXPECT_NE(meshScene("huge.obj").find("-byte limit"), std::string::npos) << meshScene("huge.obj");
}

TEST(Class4WrongValues, ZeroNegativeAndMalformedCliValuesAreRejected) {
  fs::path cache = test::freshDir("cli_values");
  // Each would otherwise fall back to a default or parse a prefix; all must fail at parse time.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--frames 0", "--frames"},
      {"--frames -2", "--frames"},
      {"--ref-spp 0", "--ref-spp"},
      {"--max-bounces 0", "--max-bounces"},
      {"--ref-rel-error -1", "--ref-rel-error"},
      {"--ref-rel-error nan", "--ref-rel-error"},
      {"--resolution 0x8", "--resolution"},
      {"--resolution 8x8junk", "--resolution"},
      {"--resolution 99999999999x8", "--resolution"},
  };
  for (auto& [flags, name] : cases) {
    CliResult r =
        arenaCli("render cornell_static --resolution 8x8 --ref-spp 1 --frames 1 --cache " +
                 cache.string() + " " + flags);
    EXPECT_NE(r.status, 0) << flags << "\n" << r.output;
    EXPECT_NE(r.output.find(name), std::string::npos) << flags << "\n" << r.output;
  }
  EXPECT_TRUE(fs::is_empty(cache)) << "a rejected command rendered something";
}

TEST(Class4WrongValues, ShardsParamsAndSweepsAreStrict) {
  EXPECT_EQ(parseShard("3/8"), std::make_pair(3, 8));
  for (const char* bad :
       {"0/1junk", "0/0", "2/2", "-1/2", "0/4294967297", "1/", "/2", "1 /2", "0x1/2"})
    EXPECT_THROW(parseShard(bad), Error) << bad;
  try {
    parseParamAssignments({"svgf.sigmaL=4", "svgf.sigmaL=8"});
    ADD_FAILURE() << "accepted a duplicate --param";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("svgf.sigmaL is already set to '4'"), std::string::npos)
        << e.what();
  }
  fs::path dir = test::freshDir("sweep_cli");
  const std::string common =
      " --scenes cornell_static --resolution 8x8 --frames 2 --ref-spp 1 --no-baselines --cache " +
      (dir / "cache").string() + " --out " + (dir / "run").string();
  CliResult r =
      arenaCli("sweep --denoiser svgf --grid 'sigmaL=[2,4]' --param eaw.sigmaL=3" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("this sweep runs only svgf"), std::string::npos) << r.output;
  r = arenaCli("sweep --denoiser svgf --grid 'sigmaL=[2,4]' --grid 'sigmaL=[8]'" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("already an axis"), std::string::npos) << r.output;
  r = arenaCli("run --denoisers passthrough --shard 0/1junk" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--shard '0/1junk'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "run" / "results.json"));
}

// ---- class 5: half-written or unusable state -------------------------------------------------

RunConfig tinyRun(const std::string& name) {
  RunConfig c;
  c.name = name;
  c.out = test::freshDir("class5_" + name);
  c.cache = test::freshDir("class5_cache_" + name);
  c.render = test::tinySettings(16, 8, 3, 2);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"passthrough", {}, ""}};
  c.baselines = false;
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  return c;
}

using test::countRows;

TEST(Class5State, BadOutputsFailBeforeAnyWorkNamingTheFile) {
  struct Case {
    const char* name;
    std::function<void(const fs::path&)> make;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"garbage_db",
       [](const fs::path& d) { writeTextAtomically(d / "results.db", std::string(5000, 'x')); },
       "results.db: "},
      {"foreign_schema",
       [](const fs::path& d) {
         sqlite3* h = nullptr;
         sqlite3_open((d / "results.db").c_str(), &h);
         sqlite3_exec(h, "CREATE TABLE summaries (x INTEGER); INSERT INTO summaries VALUES (1);",
                      nullptr, nullptr, nullptr);
         sqlite3_close(h);
       },
       "results.db: another schema (table"},
      {"truncated_db",
       [](const fs::path& d) {
         json r = {{"name", "x"},
                   {"environment", json::object()},
                   {"settings", json::object()},
                   {"pairs", json::array()}};
         for (int i = 0; i < 200; ++i)  // enough rows for several pages
           r["pairs"].push_back({{"scene", std::string("s").append(std::to_string(i))},
                                 {"denoiser", std::string(200, 'd')},
                                 {"label", "l"},
                                 {"params", json::object()},
                                 {"status", "failed"},
                                 {"error", "e"}});
         appendToDatabase(d / "results.db", r);
         fs::resize_file(d / "results.db", fs::file_size(d / "results.db") / 2);
       },
       "results.db: "},
      {"foreign_json",
       [](const fs::path& d) { writeTextAtomically(d / "results.json", "{\"mine\": 1}"); },
       "results.json: not an arena results file; refusing to replace it"},
  };
  for (const Case& c : cases) {
    RunConfig cfg = tinyRun(c.name);
    c.make(cfg.out);
    const bool hadJson = fs::exists(cfg.out / "results.json");
    try {
      runMatrix(cfg);
      ADD_FAILURE() << c.name << ": the run went ahead";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos)
          << c.name << ": " << e.what();
    }
    EXPECT_TRUE(fs::is_empty(cfg.cache)) << c.name << ": rendered before checking the outputs";
    EXPECT_EQ(fs::exists(cfg.out / "results.json"), hadJson) << c.name;
  }
}

TEST(Class5State, ResultsJsonAndDatabaseCommitTogether) {
  RunConfig cfg = tinyRun("commit");
  json first = runMatrix(cfg);
  ASSERT_EQ(countRows(cfg.out / "results.db", "runs"), 1);
  const std::string jsonBefore = readText(cfg.out / "results.json");
  const std::string dbBefore = readText(cfg.out / "results.db");
  // A document the database append rejects halfway (a pair whose scene is not a string): neither
  // file may change, and no temporary may be left behind.
  json bad = first;
  bad["pairs"].push_back({{"scene", 17}});
  EXPECT_ANY_THROW(commitResults(cfg.out, bad));
  EXPECT_EQ(readText(cfg.out / "results.json"), jsonBefore);
  EXPECT_EQ(readText(cfg.out / "results.db"), dbBefore);
  for (auto& e : fs::directory_iterator(cfg.out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  // A good second run appends: both files move together.
  runMatrix(cfg);
  EXPECT_EQ(countRows(cfg.out / "results.db", "runs"), 2);
  EXPECT_NE(readText(cfg.out / "results.json"), jsonBefore);
}

TEST(Class5State, TemporariesOfKilledWritesAreCleaned) {
  fs::path dir = test::freshDir("stale_tmp");
  const long deadPid = 999999999;  // above any pid_max: no such process
  auto make = [&](const std::string& name, int ageSeconds) {
    writeTextAtomically(dir / name, "partial");
    fs::last_write_time(dir / name,
                        fs::file_time_type::clock::now() - std::chrono::seconds(ageSeconds));
  };
  const std::string dead = std::to_string(deadPid), self = std::to_string(getpid());
  make("results.tmp" + dead + "_0.json", 3600);     // killed long ago: removed
  make("frame_0003.tmp" + dead + "_12.exr", 3600);  // killed render: removed
  make("results.tmp" + dead + "_1.db-journal",
       3600);                                    // SQLite's journal of a killed append: removed
  make("results.tmp" + dead + "_2.db", 5);       // young: maybe another host's live write, kept
  make("results.tmp" + self + "_3.json", 3600);  // this process: kept
  make("notes.tmp.json", 3600);                  // not our pattern: kept
  EXPECT_EQ(removeStaleTemporaries(dir), 3);
  EXPECT_FALSE(fs::exists(dir / ("results.tmp" + dead + "_0.json")));
  EXPECT_FALSE(fs::exists(dir / ("frame_0003.tmp" + dead + "_12.exr")));
  EXPECT_TRUE(fs::exists(dir / ("results.tmp" + dead + "_2.db")));
  EXPECT_TRUE(fs::exists(dir / ("results.tmp" + self + "_3.json")));
  EXPECT_TRUE(fs::exists(dir / "notes.tmp.json"));
}

// Every entry under `root` (directories included) with its inode, size and mtime: a file written
// in place changes its mtime, an atomic replace its inode, and a temporary created, renamed or
// removed changes its directory's mtime.
std::map<std::string, std::string> treeSnapshot(const fs::path& root) {
  std::map<std::string, std::string> out;
  auto add = [&](const fs::path& p) {
    struct stat st {};
    if (lstat(p.c_str(), &st) != 0) return;
    out[p.string()] = std::to_string(st.st_ino) + " " + std::to_string(st.st_size) + " " +
                      std::to_string(st.st_mtim.tv_sec) + "." + std::to_string(st.st_mtim.tv_nsec);
  };
  add(root);
  for (auto& e : fs::recursive_directory_iterator(root)) add(e.path());
  return out;
}

TEST(Class5State, ACompleteCacheIsReadWithoutWriting) {
  fs::path cache = test::freshDir("readonly_cache");
  Scene scene = test::shippedScene("cornell_static");
  RenderSettings settings = test::tinySettings(16, 8, 2, 2);
  fs::path dir = renderSequence(scene, settings, cache, nullptr);
  // Back-date every entry by an hour, so that a write within the same clock tick still shows
  // (permissions cannot show it: root writes through them).
  const auto past = fs::file_time_type::clock::now() - std::chrono::hours(1);
  fs::last_write_time(cache, past);
  for (auto& e : fs::recursive_directory_iterator(cache)) fs::last_write_time(e.path(), past);
  const auto before = treeSnapshot(cache);
  ASSERT_GT(before.size(), 4u);
  EXPECT_EQ(renderSequence(scene, settings, cache, nullptr), dir);
  EXPECT_NO_THROW(Sequence::open(dir).frame(1));
  EXPECT_EQ(treeSnapshot(cache), before)
      << "the complete cache was written to although nothing changed";
  // A read-only cache directory (enforced for normal users only): rendering and opening still work.
  fs::permissions(dir, fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  EXPECT_NO_THROW(renderSequence(scene, settings, cache, nullptr));
  EXPECT_NO_THROW(Sequence::open(dir).frame(1));
  fs::permissions(dir, fs::perms::owner_write, fs::perm_options::add);
  EXPECT_EQ(treeSnapshot(cache), before);
}

TEST(Class5State, MergeCreatesItsOutputDirectory) {
  RunConfig a = tinyRun("merge_a"), b = tinyRun("merge_b");
  a.denoisers = b.denoisers = {{"passthrough", {}, ""}, {"temporal", {}, ""}};
  b.cache = a.cache;
  a.shardIndex = 0;
  b.shardIndex = 1;
  a.shardCount = b.shardCount = 2;
  runMatrix(a);
  runMatrix(b);
  fs::path out = test::freshDir("merge_out") / "not" / "there";
  json merged = mergeRuns({a.out, b.out}, out);
  EXPECT_EQ(merged["pairs"].size(), 2u);
  EXPECT_TRUE(fs::exists(out / "results.json"));
  EXPECT_EQ(countRows(out / "results.db", "pairs"), 2);
}

// ---- class 6: help ---------------------------------------------------------------------------

TEST(Class6Help, EveryOptionShowsItsDefault) {
  const std::vector<std::string> commands = {
      "scenes",  "render",    "study",        "run",           "sweep", "merge",
      "compare", "denoisers", "bench tracer", "bench denoise", "report"};
  // CLI11 prints "  --name TYPE=default", "  --name TYPE:{a,b}=default", "  --name INT:INT in [1 -
  // 64]=8", "  name TEXT REQUIRED" (positionals); flags have no TYPE and need no default.
  const std::regex valueLine(R"(^  (\S+) ([A-Z]+)\b.*)");
  const std::regex withDefault(
      R"(^  \S+ [A-Z]+(:\{[^}]*\}|:[A-Z]+ in \[[^\]]*\])?( \.\.\.)?(=\S| REQUIRED).*)");
  int valueOptions = 0;
  for (const std::string& c : commands) {
    CliResult r = arenaCli(c + " --help");
    ASSERT_EQ(r.status, 0) << c << ": " << r.output;
    std::istringstream lines(r.output);
    for (std::string line; std::getline(lines, line);) {
      if (!std::regex_match(line, valueLine)) continue;
      ++valueOptions;
      EXPECT_TRUE(std::regex_match(line, withDefault))
          << "arena " << c << ": no default shown in: " << line;
    }
  }
  EXPECT_GT(valueOptions, 30);  // the parser above found the options
}

// ---- class 7: messages -----------------------------------------------------------------------

// Makes writes beyond `bytes` fail with EFBIG (as a full disk fails with ENOSPC) for this scope.
struct FileSizeLimit {
  rlimit saved{};
  explicit FileSizeLimit(rlim_t bytes) {
    signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &saved);
    rlimit l = saved;
    l.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &l);
  }
  ~FileSizeLimit() { setrlimit(RLIMIT_FSIZE, &saved); }
};

TEST(Class7Messages, WriteErrorsNameThePathAndTheReason) {
  fs::path dir = test::freshDir("write_errors");
  // SQLite reports a failed write as its own I/O error (it keeps no errno for it): that is the
  // reason shown.
  auto expectNamed = [&](const std::function<void()>& write, const std::string& path,
                         const std::string& why = std::strerror(EFBIG)) {
    try {
      FileSizeLimit limit(4096);
      write();
      ADD_FAILURE() << path << ": the write succeeded";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  expectNamed([&] { writeTextAtomically(dir / "big.json", std::string(100000, 'x')); },
              (dir / "big.json").string());
  LayerSet layers;
  Image noise(128, 128, 3);
  for (size_t i = 0; i < noise.raw().size(); ++i) noise.raw()[i] = test::hashUniform(uint32_t(i));
  layers.set("color", noise);
  expectNamed(
      [&] {
        writeExr(dir / "big.exr", layers, {{"color", {"R", "G", "B"}}}, {});
      },
      (dir / "big.exr").string());
  json r = {{"name", "x"},
            {"environment", json::object()},
            {"settings", std::string(100000, 's')},
            {"pairs", json::array()}};
  expectNamed([&] { appendToDatabase(dir / "results.db", r); }, (dir / "results.db").string(),
              "SQLite: disk I/O error");
  // Reads: a missing file names the path and the reason.
  try {
    readText(dir / "missing.json");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "missing.json").string() +
                                         ": cannot open file: " + std::strerror(ENOENT)),
              std::string::npos)
        << e.what();
  }
}

TEST(Class7Messages, AFullDiskDuringARunNamesTheFileThroughTheCli) {
  fs::path dir = test::freshDir("full_disk_cli");
  // ulimit -f counts 1024-byte blocks; SIGXFSZ ignored so the write fails with EFBIG instead.
  CliResult r =
      arenaCli("render cornell_static --resolution 32x16 --frames 2 --ref-spp 2 --cache " +
                   (dir / "cache").string(),
               "trap '' XFSZ; ulimit -f 4; ");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find((dir / "cache").string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(std::strerror(EFBIG)), std::string::npos) << r.output;
}

// ---- issue 30: no crash, no silent shift -----------------------------------------------------

// A tiny CLI run of cornell_static into dir/NAME (cache dir/cache); extra flags appended.
CliResult tinyCliRun(const fs::path& dir, const std::string& name, const std::string& flags) {
  return arenaCli("run --scenes cornell_static --denoisers passthrough --no-baselines --resolution 8x8 "
                  "--ref-spp 1 --flip none --keep-frames none --cache " +
                  (dir / "cache").string() + " --out " + (dir / name).string() + " " + flags);
}

TEST(Issue30Absent, ARunShorterThanTheWarmupSaysWhyEveryReaderHasNoSummary) {
  fs::path dir = test::freshDir("short_run");
  // 3 frames, the default warm-up of 8: no frame survives it.
  CliResult r = tinyCliRun(dir, "run", "--frames 3");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("warning: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the sequence has 3 frames and the warm-up excludes the first 8"),
            std::string::npos)
      << r.output;
  EXPECT_LT(r.output.find("warning: "), r.output.find("results: ")) << "warned after the work";
  EXPECT_NE(r.output.find("cornell_static: relMse absent in 1 pair(s): no frame after the warm-up"),
            std::string::npos)
      << r.output;
  const std::string run = (dir / "run").string();
  r = arenaCli("compare " + run + " " + run);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("absent"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no frame after the warm-up"), std::string::npos) << r.output;
  r = arenaCli("report " + run + " --baseline " + run + " --out " + (dir / "report").string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("absent: cornell_static: relMse absent in 1 pair(s)"), std::string::npos)
      << r.output;
  r = arenaCli("history " + run + " " + (dir / "run" / "results.db").string() + " --out " +
               (dir / "history").string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("relMse absent in 1 pair(s): no frame after the warm-up"),
            std::string::npos)
      << r.output;
}

// The Error message of parsing the scene text `text`, or "" when it parsed.
std::string sceneTextError(const std::string& text) {
  try {
    parseScene(text, "scenes/t.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Issue30Names, CollidingNamesAndDuplicateKeysAreErrorsNamingBothPlaces) {
  json s = minimalScene();
  s["objects"].push_back(s["objects"][0]);
  EXPECT_NE(sceneError(s).find("$.objects[1].name: 'floor' is already the name of $.objects[0]"),
            std::string::npos)
      << sceneError(s);
  s = minimalScene();
  s["lights"].push_back(s["lights"][0]);
  EXPECT_NE(sceneError(s).find("$.lights[1].name: 'light' is already the name of $.lights[0]"),
            std::string::npos)
      << sceneError(s);
  s = minimalScene();
  s["lights"][0]["name"] = "floor";
  EXPECT_NE(sceneError(s).find("$.lights[0].name: 'floor' is already the name of $.objects[0]"),
            std::string::npos)
      << sceneError(s);
  // Keys given twice: nlohmann would keep one of them silently. Each case inserts a member
  // right after `after` in the scene's text; the error names the object's path and both members.
  struct Case {
    std::string after, member, message;
  };
  const std::vector<Case> cases = {
      {"{", "\"frames\": 7,", "scenes/t.json: $: key \"frames\" is given twice (members 1 and "},
      {"\"materials\":{", "\"white\":{\"albedo\":[0.1,0.1,0.1]},",
       "$.materials: key \"white\" is given twice"},
      {"\"keys\":[{", "\"fov\":30,", "$.camera.keys[0]: key \"fov\" is given twice"},
  };
  for (const Case& c : cases) {
    std::string text = minimalScene().dump();
    text.insert(text.find(c.after) + c.after.size(), c.member);
    EXPECT_NE(sceneTextError(text).find(c.message), std::string::npos) << sceneTextError(text);
  }
  EXPECT_EQ(sceneTextError(minimalScene().dump()), "");
}

TEST(Issue30Geometry, UnusableVerticesAndOverbrightAssetsAreErrorsNamingFileAndElement) {
  fs::path dir = test::freshDir("vanishing_geometry");
  auto meshError = [&](const std::string& obj) {
    writeTextAtomically(dir / "m.obj", obj);
    json s = minimalScene();
    s["objects"].push_back({{"name", "m"},
                            {"shape", "mesh"},
                            {"file", "m.obj"},
                            {"material", "white"},
                            {"keys", json::array({{{"frame", 0}}})}});
    return sceneError(s, (dir / "t.json").string());
  };
  EXPECT_EQ(meshError("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "");
  std::string e = meshError("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(e.find("$.objects[1].file"), std::string::npos) << e;
  EXPECT_NE(e.find("m.obj:2: vertex 2: coordinate 2 is 'nan'"), std::string::npos) << e;
  e = meshError("# a comment\nv 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n");
  EXPECT_NE(e.find("m.obj:4: vertex 3: coordinate 2 is '1e39'"), std::string::npos) << e;
  // Assets: a vertex whose triangle's cross product overflows, an emitter beyond kMaxRadiance.
  auto assetError = [&](const std::string& obj, const std::string& mtl) {
    writeTextAtomically(dir / "a.obj", "mtllib a.mtl\n" + obj);
    writeTextAtomically(dir / "a.mtl", mtl);
    json s = minimalScene();
    s["objects"].push_back({{"name", "thing"},
                            {"asset", {{"file", "a.obj"}, {"unitMeters", 1.0}, {"upAxis", "y"}}},
                            {"keys", json::array({{{"frame", 0}}})}});
    return sceneError(s, (dir / "t.json").string());
  };
  const std::string tri = "usemtl lamp\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_EQ(assetError(tri, "newmtl lamp\nKe 4 4 4\n"), "");
  e = assetError(tri, "newmtl lamp\nKe 1e20 1e20 1e20\n");
  EXPECT_NE(e.find("material 'lamp' emits"), std::string::npos) << e;
  EXPECT_NE(e.find("a.obj"), std::string::npos) << e;
  e = assetError("usemtl lamp\nv 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n", "newmtl lamp\nKd 1 1 1\n");
  EXPECT_NE(e.find("has a non-finite position or one beyond +-1e18"), std::string::npos) << e;
}

TEST(Issue30Messages, AWrongTypeInResultsNamesTheFileAndThePath) {
  fs::path dir = test::freshDir("typed_results");
  RunConfig cfg = tinyRun("typed");
  json r = runMatrix(cfg);
  ASSERT_TRUE(r["pairs"][0]["summary"]["relMse"].contains("mean"));
  r["pairs"][0]["summary"]["relMse"]["mean"] = "0.5";
  writeTextAtomically(cfg.out / "results.json", r.dump());
  try {
    loadResults(cfg.out);
    ADD_FAILURE() << "accepted a string mean";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("results.json: $.pairs[0].summary.relMse.mean: expected a "
                                         "number (or null), got a string"),
              std::string::npos)
        << e.what();
  }
  CliResult c = arenaCli("compare " + cfg.out.string() + " " + cfg.out.string());
  EXPECT_EQ(c.status, 2) << c.output;
  EXPECT_NE(c.output.find("$.pairs[0].summary.relMse.mean"), std::string::npos) << c.output;
}

TEST(Issue30Messages, UsageErrorsExitTwoAndOptionsAreStrict) {
  fs::path dir = test::freshDir("usage_errors");
  // CLI11's own codes (105 for a failed check, 106 for a missing option, 109 for an extra
  // argument) are the documented usage-error code.
  for (const std::string& args :
       {std::string("run --out x --warmup abc"), std::string("run"), std::string("scenes extra"),
        std::string("nosuchcommand"), std::string("run --out x --flip sometimes")}) {
    CliResult r = arenaCli(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
  }
  EXPECT_EQ(arenaCli("run --help").status, 0);
  // An empty denoiser list is not "only the baselines".
  for (const std::string& list : {std::string("''"), std::string("svgf,"), std::string(",")}) {
    CliResult r = arenaCli("run --scenes cornell_static --resolution 8x8 --frames 2 --ref-spp 1 --cache " +
                           (dir / "cache").string() + " --out " + (dir / "empty").string() + " --denoisers " + list);
    EXPECT_EQ(r.status, 2) << list << "\n" << r.output;
    EXPECT_NE(r.output.find("an empty name"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(dir / "empty" / "results.json"));
  // A baseline that runs takes its --param; one that does not run is named as not running.
  CliResult r = arenaCli("run --scenes cornell_static --denoisers passthrough --resolution 8x8 --ref-spp 1 "
                         "--flip none --keep-frames none --frames 2 --warmup 1 --param temporal.maxHistory=4 "
                         "--cache " + (dir / "cache").string() + " --out " + (dir / "baseline").string());
  ASSERT_EQ(r.status, 0) << r.output;
  json results = loadResults(dir / "baseline");
  bool found = false;
  for (const json& p : results["pairs"])
    if (p["denoiser"] == "temporal") {
      found = true;
      EXPECT_EQ(p["params"]["maxHistory"], 4) << p["params"].dump();
    }
  EXPECT_TRUE(found);
  r = tinyCliRun(dir, "nobaseline", "--frames 2 --param temporal.maxHistory=4");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("temporal is not among the denoisers of this run (passthrough)"),
            std::string::npos)
      << r.output;
  // Hexadecimal, padded or infinite values are not decimal numbers.
  const ParamSchema& svgf = DenoiserRegistry::instance().find("svgf").schema;
  for (const char* bad : {"0x10", " 8", "inf", "8 ", "1e", "+"}) {
    try {
      svgf.resolve({{"sigmaL", bad}}, "svgf");
      ADD_FAILURE() << "accepted sigmaL=" << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("svgf.sigmaL=") + bad +
                                           ": expected a number in decimal notation"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_NO_THROW(svgf.resolve({{"sigmaL", "1e1"}}, "svgf"));
  EXPECT_NO_THROW(svgf.resolve({{"sigmaL", "8."}}, "svgf"));
}

TEST(Issue30Compare, RunsOfOtherSettingsAreRefusedUnlessAllowed) {
  RunConfig a = tinyRun("settings_a"), b = tinyRun("settings_b");
  b.cache = a.cache;
  b.warmup = 2;
  runMatrix(a);
  runMatrix(b);
  const json ra = loadResults(a.out), rb = loadResults(b.out);
  EXPECT_TRUE(settingsDifferences(ra, ra).empty());
  const std::vector<std::string> differ = settingsDifferences(ra, rb);
  ASSERT_EQ(differ.size(), 1u);
  EXPECT_EQ(differ[0], "settings.warmup: 1 vs 2");
  CliResult r = arenaCli("compare " + a.out.string() + " " + b.out.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("were run with different settings"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("settings.warmup: 1 vs 2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--allow-settings-mismatch"), std::string::npos) << r.output;
  r = arenaCli("compare " + a.out.string() + " " + b.out.string() + " --allow-settings-mismatch");
  EXPECT_NE(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("warning: comparing runs with different settings"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("verdict"), std::string::npos) << r.output;
  // Another resolution shows per scene.
  RunConfig c = tinyRun("settings_c");
  c.render = test::tinySettings(8, 8, 3, 2);
  runMatrix(c);
  const std::vector<std::string> resolution = settingsDifferences(ra, loadResults(c.out));
  EXPECT_NE(std::find(resolution.begin(), resolution.end(), "scenes.cornell_static.width: 16 vs 8"),
            resolution.end());
}

TEST(Issue30Leftovers, ADeadWritersTemporaryOnThisMachineIsCleanedAtAnyAge) {
  fs::path dir = test::freshDir("stale_tmp_host");
  const std::string own = temporaryPathFor(dir / "x.json").filename().string();
  const size_t at = own.find('@'), underscore = own.find('_', at);
  ASSERT_NE(at, std::string::npos) << own;
  const std::string host = own.substr(at + 1, underscore - at - 1);
  const std::string dead = "999999999";
  writeTextAtomically(dir / ("frame_0003.tmp" + dead + "@" + host + "_4.exr"), "partial");
  writeTextAtomically(dir / ("frame_0004.tmp" + dead + "@otherhost_5.exr"), "partial");
  EXPECT_EQ(removeStaleTemporaries(dir), 1);
  EXPECT_FALSE(fs::exists(dir / ("frame_0003.tmp" + dead + "@" + host + "_4.exr")));
  EXPECT_TRUE(fs::exists(dir / ("frame_0004.tmp" + dead + "@otherhost_5.exr")))
      << "a young temporary of another machine may be a live write";
  // A render killed mid-write and rerun at once: the rerun leaves no temporary behind.
  fs::path cache = test::freshDir("stale_tmp_cache");
  Scene scene = test::shippedScene("cornell_static");
  RenderSettings settings = test::tinySettings(8, 8, 2, 1);
  fs::path seq = renderSequence(scene, settings, cache, nullptr);
  fs::path frame;
  for (auto& e : fs::directory_iterator(seq))
    if (e.path().filename().string().rfind("frame_", 0) == 0 && e.path().extension() == ".exr")
      frame = e.path();
  ASSERT_FALSE(frame.empty());
  const fs::path leftover = seq / (frame.stem().string() + ".tmp" + dead + "@" + host + "_7.exr");
  fs::copy_file(frame, leftover);
  fs::remove(seq / "sequence.json");  // the kill came before the sequence was complete
  renderSequence(scene, settings, cache, nullptr);
  EXPECT_FALSE(fs::exists(leftover));
  EXPECT_NO_THROW(Sequence::open(seq).frame(1));
}


// Rewrites `layer` channel `channel` of a cached EXR (keeping its attributes, so the cache still
// trusts it) with NaN at the first `count` pixels.
void poisonLayer(const fs::path& file, const std::vector<LayerSpec>& specs, const std::string& layer, int channel,
                 int count) {
  ExrContents c = readExr(file, specs);
  Image& image = c.layers.get(layer);
  for (int i = 0; i < count; ++i) image.plane(channel)[size_t(i)] = std::numeric_limits<float>::quiet_NaN();
  writeExr(file, c.layers, specs, c.attributes);
}

TEST(Issue30NonFinite, GuideAndGradientNaNsAreSanitisedCountedAndNamedInAWarning) {
  // The rule itself: NaN/Inf -> 0, and a gradient sample with any non-finite field is invalid.
  LayerSet samples;
  Image gradient(2, 1, 5, 1.0f);
  gradient.plane(2)[0] = std::numeric_limits<float>::infinity();  // lumNew of sample 0
  samples.set("gradient", gradient);
  NonFiniteCounts counts;
  EXPECT_EQ(sanitizeGradientSamples(samples, counts), 1);
  EXPECT_EQ(counts, (NonFiniteCounts{{"gradients: gradient.lumNew", 1}}));
  EXPECT_EQ(samples.get("gradient").plane(2)[0], 0.0f);
  EXPECT_EQ(samples.get("gradient").plane(4)[0], 0.0f) << "the sample is not marked invalid";
  EXPECT_EQ(samples.get("gradient").plane(4)[1], 1.0f) << "a clean sample was touched";

  // A-SVGF reads the guides and the gradient samples: NaNs in normal.Y of frame 2 and in lumNew of
  // frame 2's gradient samples are replaced, counted per channel and named in the pair's warning.
  RunConfig c;
  c.name = "nonfinite";
  c.cache = test::freshDir("nonfinite_cache");
  c.render = test::tinySettings(24, 16, 4, 4);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"asvgf", {}, ""}};
  c.baselines = false;
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  c.out = test::freshDir("nonfinite_clean");
  const fs::path dir = sequenceDir(c.scenes[0], c.render, c.cache);
  json r = runMatrix(c);
  ASSERT_EQ(r["pairs"].size(), 1u);
  ASSERT_EQ(r["pairs"][0]["status"], "ok") << r["pairs"][0].dump();
  EXPECT_EQ(r["pairs"][0]["sanitizedInputs"]["total"], 0);
  EXPECT_TRUE(r["pairs"][0]["sanitizedInputs"]["channels"].empty());
  for (const json& w : r["pairs"][0]["warnings"]) EXPECT_EQ(w.get<std::string>().find("non-finite"), std::string::npos) << w;

  poisonLayer(Sequence::framePath(dir, 2), channels::frameLayers(), "normal", 1, 30);
  poisonLayer(Sequence::gradientPath(dir, 2), channels::gradientLayers(), "gradient", 2, 30);
  c.out = test::freshDir("nonfinite_poisoned");
  r = runMatrix(c);
  ASSERT_EQ(r["pairs"].size(), 1u);
  const json& pair = r["pairs"][0];
  // status ok: the harness checked every output value was finite.
  ASSERT_EQ(pair["status"], "ok") << pair.dump();
  EXPECT_TRUE(std::isfinite(pair["summary"]["relMse"]["mean"].get<double>()));
  EXPECT_EQ(pair["sanitizedInputs"]["total"], 60);
  EXPECT_EQ(pair["sanitizedInputs"]["channels"],
            json({{"normal.Y", 30}, {"gradients: gradient.lumNew", 30}}));
  ASSERT_FALSE(pair["warnings"].empty());
  EXPECT_EQ(pair["warnings"][0],
            "60 non-finite input values (gradients: gradient.lumNew x30, normal.Y x30) were replaced by 0 "
            "before the denoiser ran; its results may differ from those on clean inputs");
  // The scene says what its cache holds, per file and channel.
  EXPECT_EQ(r["scenes"]["cornell_static"]["nonFiniteInputs"]["frame 2: normal.Y"], 30);
  EXPECT_EQ(r["scenes"]["cornell_static"]["nonFiniteInputs"]["gradients 2: gradient.lumNew"], 30);
}

}  // namespace
}  // namespace arena
