// cli/: every command refuses bad options, values and states with a message that names them, and
// exits with the documented code; the readers of a run (printout, compare, report, history) say why
// a summary is absent. Through the built `arena`.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "cli/printout.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/text.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(CliContract, NegativeWarmupIsRejectedByTheCli) {
  fs::path out = test::freshDir("warmup_cli");
  contract::CliResult r = contract::arenaCli(
      "run --scenes cornell_static --denoisers passthrough --no-baselines --resolution 8x8 "
      "--frames 2 --ref-spp 1 --cache " +
      (out / "cache").string() + " --out " + (out / "run").string() + " --warmup -3");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--warmup"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("-3"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "run" / "results.json"));
}

TEST(CliContract, AResolutionBeyondMemoryIsAClearErrorBeforeAllocating) {
  json s = contract::minimalScene();
  s["resolution"] = {16384, 16384};
  fs::path dir = test::freshDir("huge_scene");
  fs::path file = contract::writeScene(dir, "huge", s);
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
  contract::CliResult r =
      contract::arenaCli("run --scenes " + file.string() + " --denoisers passthrough --frames 100000 --out " +
               (dir / "run").string() + " --cache " + (dir / "cache").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("GiB of memory"), std::string::npos) << r.output;
}

TEST(CliContract, ZeroNegativeAndMalformedCliValuesAreRejected) {
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
    contract::CliResult r =
        contract::arenaCli("render cornell_static --resolution 8x8 --ref-spp 1 --frames 1 --cache " +
                 cache.string() + " " + flags);
    EXPECT_NE(r.status, 0) << flags << "\n" << r.output;
    EXPECT_NE(r.output.find(name), std::string::npos) << flags << "\n" << r.output;
  }
  EXPECT_TRUE(fs::is_empty(cache)) << "a rejected command rendered something";
  // More bounces than a scene's bidirectional references hold: refused before anything renders.
  const contract::CliResult deep = contract::arenaCli(
      "render hard_light --resolution 8x8 --ref-spp 1 --frames 1 "
      "--max-bounces 20 --cache " +
      cache.string());
  EXPECT_EQ(deep.status, 2) << deep.output;
  EXPECT_NE(deep.output.find("hard_light.json: --max-bounces 20: its references are bidirectional"),
            std::string::npos)
      << deep.output;
  EXPECT_TRUE(fs::is_empty(cache)) << "rendered before refusing --max-bounces";
  for (const std::string target : {"0", "-1e-5", "nan", "1e-5x"}) {
    const contract::CliResult r = contract::arenaCli("refine cornell_static --cache " +
                                                     cache.string() + " --target " + target);
    EXPECT_EQ(r.status, 2) << target << "\n" << r.output;
    EXPECT_NE(r.output.find("--target: expected a relMSE > 0, e.g. 1e-5, got " + target),
              std::string::npos)
        << r.output;
  }
}

TEST(CliContract, ShardsParamsAndSweepsAreStrict) {
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
  contract::CliResult r =
      contract::arenaCli("sweep --denoiser svgf --grid 'sigmaL=[2,4]' --param eaw.sigmaL=3" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(
      r.output.find("--param eaw.sigmaL: this sweep runs only svgf and the baselines; a "
                    "sweep's --param sets svgf's fixed parameters (--param svgf.NAME=VALUE)\n"),
      std::string::npos)
      << r.output;
  r = contract::arenaCli(
      "sweep --denoiser svgf --grid 'sigmaL=[2,4]' --param temporal.alphaMin=0.1" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("; the baselines run at their defaults, as in every sweep"),
            std::string::npos)
      << r.output;
  r = contract::arenaCli("sweep --denoiser svgf --grid 'sigmaL=[2,4]' --grid 'sigmaL=[8]'" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("already an axis"), std::string::npos) << r.output;
  r = contract::arenaCli("sweep --denoiser svgf --grid 'sigmaL=[2,4,2.0]'" +
                         common);  // one value twice
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("2 and 2.0 are the same value of sigmaL"), std::string::npos) << r.output;
  r = contract::arenaCli("run --denoisers passthrough --scenes cornell_static --out ''");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--out: an empty directory name"), std::string::npos) << r.output;
  r = contract::arenaCli("sweep --denoiser svgf --grid 'sigmaL=[2,,4]'" +
                         common);  // a value left out
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(
      r.output.find("--grid 'sigmaL=[2,,4]': values '2,,4': an empty entry (a comma too many); "
                    "expected NAME=[v1,v2,...]"),
      std::string::npos)
      << r.output;
  r = contract::arenaCli("sweep --denoiser svgf --grid 'sigmaL=[]'" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--grid 'sigmaL=[]': no values"), std::string::npos) << r.output;
  // An axis of one value ablates nothing: said when the sweep starts, not only by the report.
  r = contract::arenaCli(
      "sweep --denoiser svgf --grid 'sigmaL=[4]' --grid 'sigmaZ=[1,2]' --scenes cornell_static "
      "--resolution 8x8 --frames 2 --ref-spp 1 --no-baselines --cache " +
      (dir / "cache").string() + " --out " + (dir / "one").string());
  EXPECT_NE(r.status, 2) << r.output;  // it runs (1 here: 2 frames leave nothing to summarise)
  EXPECT_NE(r.output.find("warning: --grid sigmaL: one value (4): it fixes the parameter"),
            std::string::npos)
      << r.output;
  // A scene or denoiser left out between commas is refused, not skipped.
  r = contract::arenaCli("run --denoisers passthrough --scenes cornell_static,,camera_cut --out " +
                         (dir / "run").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--scenes 'cornell_static,,camera_cut': an empty entry"),
            std::string::npos)
      << r.output;
  r = contract::arenaCli("render 'cornell_static,' --resolution 8x8 --frames 1 --cache " +
                         (dir / "c").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("scenes 'cornell_static,': an empty entry"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("--scenes"), std::string::npos)
      << "render takes its scenes as an argument\n"
      << r.output;
  r = contract::arenaCli("bench gpu-model --denoisers eaw,");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("expected built-in names"), std::string::npos) << r.output;
  r = contract::arenaCli("bench denoise --denoisers eaw, --resolution 8x8 --frames 1");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--denoisers 'eaw,': an empty entry"), std::string::npos) << r.output;
  // A block of 1 texel would be the frame itself: refused alike by the run and the bench.
  for (const std::string& cmd : std::vector<std::string>{
           "bench denoise --denoisers eaw --resolution 8x8 --frames 1 --lowres-factor 1",
           "run --denoisers passthrough --lowres-factor 1" + common,
           "bench denoise --denoisers eaw --lowres-factor 65"}) {
    r = contract::arenaCli(cmd);
    EXPECT_EQ(r.status, 2) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find(": expected 0 (none) or a block size in [2, "), std::string::npos)
        << cmd << "\n"
        << r.output;
  }
  r = contract::arenaCli("run --denoisers passthrough --shard 0/1junk" + common);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--shard '0/1junk'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "run" / "results.json"));
  // Identical outputs where the scaled footprint rounds the grid's steps together (8 lines): the
  // likely cause is said with the remedy.
  r = contract::arenaCli(
      "sweep --denoiser svgf --grid 'iterations=[1,5]' --warmup 1 --flip none --keep-frames none" +
      common);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("cornell_static: identical outputs (bit for bit, every frame): "
                          "svgf[iterations=1] = svgf[iterations=5] (they differ in iterations: "
                          "where that is a radius or a step, the scaled footprint can round it to "
                          "the same pixels at this size, and footprint=native keeps them apart; "
                          "where not, it changed nothing here)"),
            std::string::npos)
      << r.output;
  // Two denoisers that compute alike (eaw and a plugin of it) are identical for that reason: the
  // footprint's rounding is not offered as the cause.
  r = contract::arenaCli("run --denoisers eaw,plugin:" ARENA_EXAMPLES_BINARY_DIR
                         "/libarena_eaw_plugin.so --warmup 1 --flip none --keep-frames none" +
                         common);
  EXPECT_EQ(r.status, 0) << r.output;
  const size_t same =
      r.output.find("cornell_static: identical outputs (bit for bit, every frame): eaw = ");
  ASSERT_NE(same, std::string::npos) << r.output;
  EXPECT_EQ(r.output.substr(same, r.output.find('\n', same) - same).find("scaled footprint"),
            std::string::npos)
      << r.output;
}

TEST(CliContract, EveryOptionShowsItsDefault) {
  const std::vector<std::string> commands = {
      "scenes",  "render",    "study",        "run",           "sweep", "merge",
      "compare", "denoisers", "bench tracer", "bench denoise", "report"};
  // CLI11 prints "  --name TYPE=default", "  --name TYPE:{a,b}=default", "  --name INT:INT in [1 -
  // 64]=8", "  --name TEXT:FILE=(none)", "  name TEXT REQUIRED" (positionals); flags have no TYPE
  // and need no default.
  const std::regex valueLine(R"(^  (\S+) ([A-Z]+)\b.*)");
  const std::regex withDefault(
      R"(^  \S+ [A-Z]+(:\{[^}]*\}|:[A-Z]+ in \[[^\]]*\]|:[A-Z]+)?( \.\.\.)?(=\S| REQUIRED).*)");
  int valueOptions = 0;
  for (const std::string& c : commands) {
    contract::CliResult r = contract::arenaCli(c + " --help");
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

TEST(CliContract, AFullDiskDuringARunNamesTheFileThroughTheCli) {
  fs::path dir = test::freshDir("full_disk_cli");
  // ulimit -f counts 1024-byte blocks; SIGXFSZ ignored so the write fails with EFBIG instead.
  contract::CliResult r =
      contract::arenaCli("render cornell_static --resolution 32x16 --frames 2 --ref-spp 2 --cache " +
                   (dir / "cache").string(),
               "trap '' XFSZ; ulimit -f 4; ");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find((dir / "cache").string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(std::strerror(EFBIG)), std::string::npos) << r.output;
}

// A reference too noisy to separate the methods is said under the run's ranking (it was only in
// results.json and the report), with a refine command that finds the run's sequences.
TEST(CliContract, ARunSaysWhenAScenesReferenceMissesTheGoal) {
  fs::path dir = test::freshDir("noisy_reference_cli");
  // A cache whose path a shell would split, and a path length of the run's own: the printed
  // command must still find the run's sequence.
  const fs::path cache = dir / "Ann's cache";
  contract::CliResult r = contract::arenaCli(
      "run --scenes cornell_static --denoisers svgf --resolution 16x8 --frames 6 --warmup 2 "
      "--ref-spp 4 --max-bounces 2 "
      "--flip none --keep-frames none --cache " +
      shellWord(cache.string()) + " --out " + (dir / "run").string());
  ASSERT_EQ(r.status, 0) << r.output;
  // Each pair's rank with ties beside its mean, and whose clock and size its time is.
  EXPECT_NE(
      r.output.find("(rank on relMSE, = tied: not resolved at 95%; mean relMSE after the "
                    "warm-up; median ms a frame on this machine's CPU at 16x8, unless marked)"),
      std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("geometric mean over 1 scene of"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("reference quality: 1 of 1 scene(s) miss the goal"), std::string::npos)
      << r.output;
  // An image this small runs, as a smoke test, and is said to measure little.
  EXPECT_NE(
      r.output.find(
          "16x8 is too small to measure much: the statistics' 4x4 tiles hold a few pixels each, "
          "SSIM's 11x11 window is larger than the image"),
      std::string::npos)
      << r.output;
  EXPECT_EQ(tinyImageWarning("s", 16, 16), "");
  EXPECT_EQ(tinyImageWarning("s", 64, 12).find("SSIM"), std::string::npos);
  // Few frames after the warm-up: said with the results (a trial's sweep resolved more on 1 frame
  // than on 8); the run above summarises 4.
  EXPECT_NE(r.output.find("warning: cornell_static: only 4 frames follow the warm-up of 2: the "
                          "intervals resample so few frames"),
            std::string::npos)
      << r.output;
  EXPECT_NE(readText(dir / "run" / "results.json").find("only 4 frames follow the warm-up of 2"),
            std::string::npos);
  EXPECT_EQ(shortSequenceText(16, 8, false), "");
  EXPECT_EQ(shortSequenceText(9, 8, false).rfind("only 1 frame follows the warm-up of 8", 0), 0u);
  EXPECT_NE(shortSequenceText(15, 8, false)
                .find("(render more frames with --frames or lower --warmup; 8 or more frames "
                      "after it)"),
            std::string::npos);
  // Before the work, only a sequence with no frame left is said (with its source).
  EXPECT_EQ(shortSequenceWarning("s", 9, 8, false), "");
  EXPECT_EQ(shortSequenceWarning("s", 8, 8, true).rfind("s: the sequence has 8 frames", 0), 0u);
  // A warm-up of 0 is not to be lowered (it was advised).
  EXPECT_EQ(shortSequenceText(4, 0, false).find("--warmup"), std::string::npos);
  EXPECT_NE(shortSequenceText(4, 0, true).find("a capture's frames are what it holds"),
            std::string::npos);
  const std::string printed =
      "arena refine cornell_static --resolution 16x8 --frames 6 --ref-spp 4 --max-bounces 2 "
      "--cache " +
      shellWord(cache.string()) + " --target ";
  const size_t at = r.output.find(printed);
  ASSERT_NE(at, std::string::npos) << r.output;
  // Pasted (with a cap for its N), it refines that sequence rather than render another.
  std::string command = r.output.substr(at + 6, r.output.find('`', at) - at - 6);
  ASSERT_NE(command.find("--max-spp N"), std::string::npos) << command;
  command.replace(command.find("--max-spp N"), 11, "--max-spp 16");
  const contract::CliResult refined = contract::arenaCli(command);
  ASSERT_EQ(refined.status, 0) << command << "\n" << refined.output;
  EXPECT_NE(refined.output.find("reference 0: 4 -> "), std::string::npos) << refined.output;
  int sequences = 0;
  for (const auto& entry : fs::directory_iterator(cache)) sequences += entry.is_directory();
  EXPECT_EQ(sequences, 1) << refined.output;
}

// What concerns a scene (here its events beyond the frames rendered) is printed with the run's
// table, not left to results.json and the report.
TEST(CliContract, ARunPrintsItsScenesWarnings) {
  fs::path dir = test::freshDir("scene_warnings");
  contract::CliResult r = contract::arenaCli(
      "run --scenes light_switch --denoisers passthrough --no-baselines --resolution 8x8 --ref-spp "
      "1 "
      "--frames 4 --warmup 1 --flip none --keep-frames none --cache " +
      (dir / "cache").string() + " --out " + (dir / "run").string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find(
                "warning: light_switch: events beyond the sequence's 4 frames are not measured"),
            std::string::npos)
      << r.output;
}

// A scripted event's figures (lag energy, response, ...) with their intervals are printed by the
// run (an anti-lag sweep's main result was only in results.json and the report).
TEST(CliContract, ARunPrintsItsEventsFigures) {
  fs::path dir = test::freshDir("event_figures");
  contract::CliResult r = contract::arenaCli(
      "run --scenes light_switch --denoisers passthrough --resolution 16x8 --ref-spp 1 "
      "--frames 16 --warmup 1 --flip none --keep-frames none --cache " +
      (dir / "cache").string() + " --out " + (dir / "run").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const size_t table = r.output.find(" at frame 12: ranked on lagEnergy (");
  ASSERT_NE(table, std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\nlight_switch: light_", table - 40), std::string::npos) << r.output;
  for (const char* label : {"passthrough", "temporal"})
    EXPECT_NE(r.output.find(std::string(label) + " ", table), std::string::npos) << label;
  EXPECT_NE(r.output.find("lagEnergy ", table + 40), std::string::npos) << r.output;
}

// A shard whose slice of the pairs is empty (more shards than pairs) ran all it was given: not a
// run that measured nothing for want of inputs.
TEST(CliContract, AShardWithNoPairsIsNoFailure) {
  fs::path dir = test::freshDir("empty_shard");
  contract::CliResult r = contract::tinyCliRun(dir, "run", "--shard 3/4");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("no pair ran"), std::string::npos) << r.output;
  // A shard that ran pairs ranks its slice: the printout says so above its ranks.
  r = contract::arenaCli(
      "run --scenes cornell_static --denoisers passthrough,temporal,eaw --no-baselines "
      "--resolution 8x8 --ref-spp 1 --flip none --keep-frames none --frames 10 --warmup 1 "
      "--cache " +
      (dir / "cache").string() + " --out " + (dir / "s0").string() + " --shard 0/2");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("(shard 0/2: these ranks and scores are of this slice of the pairs "
                          "alone; `arena merge` of every shard gives the run's)"),
            std::string::npos)
      << r.output;
}

// Runs that differ in one parameter: --match compares the two labels, and --denoisers naming
// either label of a match keeps the matched pair (naming the candidate's made it "new").
TEST(CliContract, MatchedLabelsAreComparedAndGatedByEitherName) {
  fs::path dir = test::freshDir("match_labels");
  const std::string common =
      "run --scenes cornell_static --denoisers temporal --no-baselines "
      "--resolution 8x8 --ref-spp 1 --flip none --keep-frames none --frames 10 "
      "--warmup 1 --cache " +
      (dir / "cache").string();  // 8 or more frames after the warm-up: a gate that can judge
  ASSERT_EQ(contract::arenaCli(common + " --out " + (dir / "a").string()).status, 0);
  ASSERT_EQ(
      contract::arenaCli(common + " --param temporal.alphaMin=0.5 --out " + (dir / "b").string())
          .status,
      0);
  const std::string compare = "compare " + (dir / "a").string() + " " + (dir / "b").string() +
                              " --match 'temporal=temporal[alphaMin=0.5]' --tolerance 1000%";
  for (const std::string only :
       {"", " --denoisers temporal", " --denoisers 'temporal[alphaMin=0.5]'"}) {
    const contract::CliResult r = contract::arenaCli(compare + only);
    EXPECT_EQ(r.status, 0) << only << "\n" << r.output;
    EXPECT_NE(r.output.find("temporal -> temporal[alphaMin=0.5]"), std::string::npos)
        << only << "\n"
        << r.output;
    EXPECT_EQ(r.output.find("new (pair not in the baseline run)"), std::string::npos)
        << only << "\n"
        << r.output;
  }
  // A damaged tile record names the file, the pair and the field (it said only "tile data: sum is
  // not base64").
  const fs::path damaged = dir / "b" / "results.json";
  json b = parseJsonFile(damaged.string());
  std::string& sum = b["pairs"][0]["tiles"]["relMse"]["sum"].get_ref<std::string&>();
  sum.resize(sum.size() - 3);
  writeTextAtomically(damaged, b.dump());
  const contract::CliResult r = contract::arenaCli(compare);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(
      r.output.find(damaged.string() +
                    ": pair temporal[alphaMin=0.5] on cornell_static, tiles.relMse: tile data: "),
      std::string::npos)
      << r.output;
}

// A run of several input seeds prints each pair's error split, with intervals, beside its table
// (it was in results.json alone), and says the table's relMSE is the first seed's.
TEST(CliContract, ARunOfSeveralSeedsPrintsTheErrorSplit) {
  fs::path dir = test::freshDir("seeds_printed");
  const contract::CliResult r = contract::tinyCliRun(dir, "run", "--frames 6 --warmup 2 --seeds 2");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("error over the 2 input seeds (relMSE units"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("the relMSE above is the first seed's"), std::string::npos) << r.output;
  const json results = json::parse(readText(dir / "run" / "results.json"));
  const json& bias2 = results["pairs"][0]["biasVariance"]["summary"]["bias2"];
  const std::string printed = cli::figureText(bias2["mean"].get<double>()) + "  [" +
                              cli::figureText(bias2["ci95"][0].get<double>()) + ", " +
                              cli::figureText(bias2["ci95"][1].get<double>()) + "]";
  EXPECT_NE(r.output.find("passthrough  "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(printed), std::string::npos) << printed << "\n" << r.output;
  // One seed: no split.
  EXPECT_EQ(contract::tinyCliRun(dir, "one", "--frames 6 --warmup 2").output.find("input seeds"),
            std::string::npos);
}

TEST(CliContract, ARunShorterThanTheWarmupSaysWhyEveryReaderHasNoSummary) {
  fs::path dir = test::freshDir("short_run");
  // 3 frames, the default warm-up of 8: no frame survives it.
  contract::CliResult r = contract::tinyCliRun(dir, "run", "--frames 3");
  // It measured nothing: done, but no result (exit 1), saying why.
  ASSERT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("nothing measured: every summary of every pair is absent"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("warning: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the sequence has 3 frames and the warm-up excludes the first 8"),
            std::string::npos)
      << r.output;
  EXPECT_LT(r.output.find("warning: /"), r.output.find("results: ")) << "warned after the work";
  EXPECT_LT(r.output.find("the warm-up excludes the first 8"), r.output.find("results: "));
  EXPECT_NE(r.output.find("cornell_static: relMse absent in 1 pair(s): no frame after the warm-up"),
            std::string::npos)
      << r.output;
  const std::string run = (dir / "run").string();
  // Compared with itself, the gate could not judge (exit 2), whatever the run holds.
  r = contract::arenaCli("compare " + run + " " + run);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("hold the same run (name run, created "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the gate would pass having checked nothing"), std::string::npos)
      << r.output;
  // Against a later run of it, every figure absent: the gate says it compared nothing and could
  // not judge (exit 2, not the 1 of a regression), in one line for a CI log.
  const fs::path later = dir / "later";
  fs::create_directories(later);
  json copied = json::parse(readText(dir / "run" / "results.json"));
  copied["created"] = "2999-01-01T00:00:00Z";
  writeTextAtomically(later / "results.json", copied.dump());
  r = contract::arenaCli("compare " + run + " " + later.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("gate: COULD NOT JUDGE ("), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("absent"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no frame after the warm-up"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("nothing compared"), std::string::npos) << r.output;
  r = contract::arenaCli("report " + run + " --baseline " + run + " --out " + (dir / "report").string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("absent: cornell_static: relMse absent in 1 pair(s)"), std::string::npos)
      << r.output;
  r = contract::arenaCli("history " + (dir / "run" / "results.db").string() + " --out " +
                         (dir / "history").string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("relMse absent in 1 pair(s): no frame after the warm-up"),
            std::string::npos)
      << r.output;
  // The run directory and the results.db it appended to are one run, taken once (from the
  // directory, which keeps the tiles): compared with itself, the gate would pass on nothing.
  r = contract::arenaCli("history " + run + " " + (dir / "run" / "results.db").string() +
                         " --out " + (dir / "history2").string() + " --confidence 99%");
  EXPECT_EQ(r.status, 0) << r.output;
  // One run is said to be one, with nothing compared (it read "0 of 0 comparison(s) failing").
  EXPECT_NE(r.output.find("(one run: nothing to compare it with yet"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("0 of 0 comparison(s)"), std::string::npos) << r.output;
}

TEST(CliContract, UsageErrorsExitTwoAndOptionsAreStrict) {
  fs::path dir = test::freshDir("usage_errors");
  // CLI11's own codes (105 for a failed check, 106 for a missing option, 109 for an extra
  // argument) are the documented usage-error code.
  for (const std::string& args :
       {std::string("run --out x --warmup abc"), std::string("run"), std::string("scenes extra"),
        std::string("nosuchcommand"), std::string("run --out x --flip sometimes")}) {
    contract::CliResult r = contract::arenaCli(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    // Worded as every other bad input, with where the options are listed.
    EXPECT_EQ(r.output.rfind("arena: error: ", 0), 0u) << args << "\n" << r.output;
  }
  EXPECT_NE(contract::arenaCli("run --out x --warmup abc")
                .output.find("(`arena run --help` lists the options)"),
            std::string::npos);
  EXPECT_NE(
      contract::arenaCli("").output.find("arena: error: a command is required; the commands are: "),
      std::string::npos);
  EXPECT_NE(
      contract::arenaCli("nosuchcommand")
          .output.find(
              "arena: error: unknown command 'nosuchcommand'; the commands are: scenes, render,"),
      std::string::npos);
  // An option given twice, and two assignments in one --param, are said as such.
  const contract::CliResult twice = contract::arenaCli("run --out x --scenes a --scenes b");
  EXPECT_EQ(twice.status, 2);
  EXPECT_NE(twice.output.find("arena: error: --scenes given 2 times; give it once (a list is one "
                              "comma-separated value, e.g. --scenes a,b)"),
            std::string::npos)
      << twice.output;
  const contract::CliResult params =
      contract::arenaCli("run --out x --param svgf.sigmaL=8,svgf.alpha=0.1");
  EXPECT_EQ(params.status, 2);
  EXPECT_NE(params.output.find("--param 'svgf.sigmaL=8,svgf.alpha=0.1': one assignment per "
                               "--param; give each its own (--param svgf.sigmaL=8 --param "
                               "svgf.alpha=0.1)"),
            std::string::npos)
      << params.output;
  // A counter of the run has no tiles to average.
  EXPECT_NE(contract::arenaCli("metrics").output.find(
                "reads run; frame value: one per frame (no image, no tiles)"),
            std::string::npos);
  EXPECT_NE(contract::arenaCli("report somerun --out x --tolerance 5%")
                .output.find("report: --tolerance judges the regression view against a baseline"),
            std::string::npos);
  EXPECT_EQ(contract::arenaCli("run --help").status, 0);
  // A bench's --json that cannot be written is refused before the timed work, not after it.
  std::ofstream(dir / "afile") << "x";
  for (const std::string& target : {(dir / "afile" / "x.json").string(), dir.string()}) {
    contract::CliResult r = contract::arenaCli("bench tracer --frames 1 --size 8 --json " + target);
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_EQ(r.output.find("arena tracer:"), std::string::npos)
        << "timed before refusing: " << r.output;
    EXPECT_NE(r.output.find(target == dir.string() ? "is a directory" : "afile is not a directory"),
              std::string::npos)
        << r.output;
  }
  // Nor a --json that is not a file to write, or a file the bench did not write (a run's
  // results.json and /dev/full were replaced): before the work, the file untouched.
  std::ofstream(dir / "results.json") << "{\"pairs\": []}";
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"''", "an empty file name"},
      {"-", "'-' would be a file of that name"},
      {"/dev/null", "/dev/null is not a regular file"},
      {(dir / "results.json").string(),
       "exists and is not a file `arena bench tracer` wrote (no "
       "\"arenaBench\": \"bench tracer\" in it;"},
      {(dir / "marked.json").string(), "exists and is not a file `arena bench tracer` wrote"},
      {(dir / "link.json").string(), "is a symbolic link (the file would replace it)"},
      {(dir / "folder/").string(), "ends in a folder separator; expected a file name"}};
  std::ofstream(dir / "marked.json") << "{\"arenaBench\": null}";  // a mark of another kind
  fs::create_symlink(dir / "results.json", dir / "link.json");
  for (const auto& [target, why] : refused) {
    contract::CliResult r = contract::arenaCli("bench tracer --frames 1 --size 8 --json " + target);
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_EQ(r.output.find("arena tracer:"), std::string::npos)
        << "timed before refusing: " << r.output;
    EXPECT_NE(r.output.find(why), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("(`arena bench tracer --help` lists the options)"), std::string::npos)
        << r.output;
  }
  EXPECT_EQ(readText(dir / "results.json"), "{\"pairs\": []}");
  // Its own file it replaces; another bench's it does not.
  const std::string own = (dir / "own" / "tracer.json").string();
  for (int k = 0; k < 2; ++k)
    EXPECT_EQ(
        contract::arenaCli("bench tracer --frames 1 --warmup 0 --size 8 --json " + own).status, 0);
  EXPECT_EQ(parseJsonFile(own)["arenaBench"], "bench tracer");
  EXPECT_NE(contract::arenaCli("bench rank-agreement a b --json " + own)
                .output.find("is not a file `arena bench rank-agreement` wrote"),
            std::string::npos);
  // A whole-number option given a fraction says so rather than "not in range".
  EXPECT_NE(
      contract::arenaCli("bench gpu-model --frames 2.5")
          .output.find(
              "--frames: 2.5 is not a whole number written in digits; expected one from 2 to 100"),
      std::string::npos);
  // gpu-model prices built-ins, each once.
  EXPECT_NE(contract::arenaCli("bench gpu-model --denoisers plugin:x.so")
                .output.find("the model prices the built-ins only"),
            std::string::npos);
  EXPECT_NE(
      contract::arenaCli("bench gpu-model --denoisers svgf,svgf").output.find("names svgf twice"),
      std::string::npos);
  // A variant priced by --param: its names and values checked before the work, and only for a
  // denoiser priced.
  EXPECT_NE(contract::arenaCli("bench gpu-model --denoisers svgf --param svgf.iterationz=3")
                .output.find("svgf: unknown parameter 'iterationz'"),
            std::string::npos);
  EXPECT_NE(contract::arenaCli("bench gpu-model --denoisers svgf --param eaw.sigmaL=1")
                .output.find("--param eaw.sigmaL: eaw is not among the denoisers priced"),
            std::string::npos);
  // An empty denoiser list is not "only the baselines".
  for (const std::string& list : {std::string("''"), std::string("svgf,"), std::string(",")}) {
    contract::CliResult r = contract::arenaCli("run --scenes cornell_static --resolution 8x8 --frames 2 --ref-spp 1 --cache " +
                           (dir / "cache").string() + " --out " + (dir / "empty").string() + " --denoisers " + list);
    EXPECT_EQ(r.status, 2) << list << "\n" << r.output;
    EXPECT_NE(
        r.output.find(list == "''" ? "--denoisers '': empty" : "an empty entry (a comma too many)"),
        std::string::npos)
        << r.output;
  }
  EXPECT_FALSE(fs::exists(dir / "empty" / "results.json"));
  // A baseline that runs takes its --param; one that does not run is named as not running.
  contract::CliResult r = contract::arenaCli("run --scenes cornell_static --denoisers passthrough --resolution 8x8 --ref-spp 1 "
                         "--flip none --keep-frames none --frames 2 --warmup 1 --param temporal.maxHistory=4 "
                         "--cache " + (dir / "cache").string() + " --out " + (dir / "baseline").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const RunResults results = loadResults(dir / "baseline");
  bool found = false;
  for (const PairResult& p : results.pairs)
    if (p.denoiser == "temporal") {
      found = true;
      EXPECT_EQ(p.params["maxHistory"], 4) << p.params.dump();
    }
  EXPECT_TRUE(found);
  r = contract::tinyCliRun(dir, "nobaseline", "--frames 2 --param temporal.maxHistory=4");
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
  // Decimal, but beyond a double's range: too large, or so small it would round to 0 (it was
  // called "not finite", which 1e-400 is).
  for (const char* far : {"1e400", "1e-400"}) {
    const std::string e = test::errorOf([&] { svgf.resolve({{"sigmaL", far}}, "svgf"); });
    EXPECT_NE(e.find(std::string("svgf.sigmaL=") + far +
                     ": expected a finite number within a double's range"),
              std::string::npos)
        << e;
  }
  // A parameter with no meaning (a manifest may give none) is described without a dangling ": ".
  EXPECT_EQ(ParamSpec::real("k", 0.5, 0, 1, "").describe(), "k (float, default 0.5, range [0, 1])");
}

}  // namespace
}  // namespace arena
