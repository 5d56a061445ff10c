#pragma once
// `arena report`: a static HTML dashboard built from a run's results.json (and, optionally, a
// baseline run's). Reports only read results: nothing here includes a denoiser or the tracer.
//
// The page opens from disk (file://) with no server and no network, so the data travels as a
// script (data.js sets window.ARENA_DATA) instead of a fetch(), and the charting library (Vega,
// Vega-Lite, vega-embed from reports/node_modules) is copied next to index.html.
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "metrics/compare.hpp"
#include "metrics/gate.hpp"
#include "metrics/run_results.hpp"

namespace arena {

struct ReportOptions {
  std::filesystem::path run;       // the run directory to report
  std::filesystem::path baseline;  // optional: a run to compare against (regression view)
  Gate gate;                       // the regression view's: `arena compare`'s options
  std::filesystem::path out;       // where index.html and its files go
  // The page's static files and the npm packages with the browser builds; the defaults are the
  // source tree's, tests point them elsewhere.
  std::filesystem::path webDir = defaultWebDir();
  std::filesystem::path nodeModulesDir = defaultNodeModulesDir();

  static std::filesystem::path defaultWebDir();
  static std::filesystem::path defaultNodeModulesDir();
};

struct ReportSummary {
  std::filesystem::path index;  // <out>/index.html
  size_t pairs = 0, failedPairs = 0;
  // The run's display images the page shows: copied beside it, or there already when the page is
  // written into the run directory itself (imagesInPlace).
  size_t images = 0;
  bool imagesInPlace = false;
  // The run's absent summaries with their reasons (metrics/run_results.hpp), for the printout:
  // the page shows them as empty cells.
  std::vector<std::string> absentSummaries;
  std::filesystem::path ablation;  // <out>/ablation.csv for a sweep (ablationCsv), else empty
  std::filesystem::path points;    // <out>/points.csv for a sweep (sweepPointsCsv), else empty
  std::string noAblation;          // a sweep without ablation rows: why (the printout says it)
  // With a baseline, the regression view's judgement for the printout (a CI log): compare's
  // verdict and exit code, why it would refuse the runs, its warnings, the rows' verdicts counted.
  bool judged = false;
  std::string gate, refused, verdicts;
  int gateExitCode = 0;
  std::vector<std::string> gateWarnings;
};

// The document embedded as data.js. `runDir` is where the run's images are looked up (only images
// that exist are offered to the viewer); `baseline` may be null, and is judged with `gate`. Pure
// apart from those look-ups.
nlohmann::json reportData(const RunResults& results, const std::filesystem::path& runDir,
                          const RunResults* baseline, const Gate& gate = {});

// A sweep's ablation (reportData's "ablation") as CSV, one line per row and metric, for a paper's
// table: parameter, value, versus, given (the other grid parameters' settings where the row is one
// match), scene ("all scenes" for the mean over them), matched, metric, delta, relative, verdict,
// matches, intervals, resolved, and the paired 95% interval (ci95Lo, ci95Hi) where one match
// carries it; a row over several matches is followed by a line per match (given its settings,
// with its own paired difference). Empty when the run is no sweep or has no rows.
std::string ablationCsv(const nlohmann::json& ablation);

// A sweep's points themselves, for a plot of a metric against a parameter: one line per contender
// (the grid's points, then the run's other contenders, e.g. the baselines), scene and metric, with
// a column per grid parameter (empty for a contender that is no grid point) and per fixed
// parameter, the mean, its 95% interval and rank from the run's statistics where the metric is
// ranked (else the summary's own interval and no rank), and the frames summarised. The event
// figures the statistics rank are metrics named as results.db names them ("ghosting@12.lagEnergy").
// Time is the median frame time. Empty when the run is no sweep.
std::string sweepPointsCsv(const RunResults& results);

// Loads the run (and baseline) through loadResults, so a missing run or another schema version is
// an arena::Error; a missing charting library is an Error that says to run scripts/setup.sh.
ReportSummary writeReport(const ReportOptions& options);

// The page's files: checkPageAssets throws an Error naming a missing static file (webDir) or a
// missing charting library (nodeModulesDir: run scripts/setup.sh); copyPageAssets copies both
// into `out`. Shared by `arena report` and `arena history`.
struct PageFile {
  std::string source, target;  // names in webDir and in out
};
void checkPageAssets(const std::filesystem::path& webDir,
                     const std::filesystem::path& nodeModulesDir,
                     const std::vector<PageFile>& files);
// Refuses an empty --out and one that exists and is not a directory (before any work); `command`
// ("report", "history") begins the message.
void requirePageDirectory(const std::filesystem::path& out, const std::string& command);
// Refuses an --out that holds files the page would replace which no Denoise Arena page wrote (a
// website's folder, say): an index.html that is no report's or dashboard's, a `dataFile`
// (data.js, history-data.js) that its generator did not write, or any other of the page's files
// (`files`' targets, the charting libraries, `outputs`: what else it writes or removes, such as
// report's tiles/) where no page's index.html is. Before any work.
void requireOwnPageFiles(const std::filesystem::path& out, const std::vector<PageFile>& files,
                         const std::string& dataFile, const std::vector<std::string>& outputs,
                         const std::string& command);
void copyPageAssets(const std::filesystem::path& webDir,
                    const std::filesystem::path& nodeModulesDir, const std::vector<PageFile>& files,
                    const std::filesystem::path& out);

// The section ids index.html must contain, in page order (the tests check them).
const std::vector<std::string>& reportSectionIds();

}  // namespace arena
