// Issue 16: no input reaches a crash, a silently wrong value, half-written state or a message
// without a path. One suite per class of failure; CLI cases go through the built `arena`.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <regex>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "harness/denoise_run.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
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
    cli::requireFitsInMemory(scene, settings, true);
    ADD_FAILURE() << "16384x16384 x 100000 frames fits?";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("huge.json: 16384x16384 x 100000 frames needs about"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(cli::requireFitsInMemory(scene, test::tinySettings(64, 32, 10, 1), true));
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
    cli::selectScenes(a.string() + "," + b.string(), dir.string());
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

}  // namespace
}  // namespace arena
