// metrics/results: results.json and results.db are written together, and a results file of the
// wrong shape or type is an error naming the file and the JSON path.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(ResultsContract, ResultsOfTheWrongShapeAreErrorsNamingThePath) {
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
  contract::CliResult r = contract::arenaCli("report " + run.string() + " --out " + (run / "report").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("$.pairs"), std::string::npos) << r.output;
}

TEST(ResultsContract, ResultsJsonAndDatabaseCommitTogether) {
  RunConfig cfg = contract::tinyRun("commit");
  json first = runMatrix(cfg);
  ASSERT_EQ(test::countRows(cfg.out / "results.db", "runs"), 1);
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
  EXPECT_EQ(test::countRows(cfg.out / "results.db", "runs"), 2);
  EXPECT_NE(readText(cfg.out / "results.json"), jsonBefore);
}

TEST(ResultsContract, AWrongTypeInResultsNamesTheFileAndThePath) {
  fs::path dir = test::freshDir("typed_results");
  RunConfig cfg = contract::tinyRun("typed");
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
  contract::CliResult c = contract::arenaCli("compare " + cfg.out.string() + " " + cfg.out.string());
  EXPECT_EQ(c.status, 2) << c.output;
  EXPECT_NE(c.output.find("$.pairs[0].summary.relMse.mean"), std::string::npos) << c.output;
}

}  // namespace
}  // namespace arena
