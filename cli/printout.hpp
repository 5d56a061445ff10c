#pragma once
// What `arena run` and `arena study` print of a run's statistics, formatted exactly as the report
// formats the same numbers (reports/web/shared.js fmt and interval), so the console and the page
// can be compared digit for digit. A library of its own (arena_printout), so that tests can hold
// the study's summary to its one screen.
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "metrics/run_results.hpp"

namespace arena::cli {

// 4 significant digits, trailing zeros dropped; 2 decimals in exponent form below 1e-3 or from 1e5
// ("1.23e-4"); "0" for zero and "–" for a missing value (the report's fmt).
std::string figureText(double value);
// Two significant digits, never in exponent form (a model's figures: 0.34, 4.2, 7, 120).
std::string twoDigitsText(double value);
// A relative change as a signed percentage with one decimal ("+4.1%", "-14.5%"); one that rounds
// to 0.0% but is not zero keeps two significant digits ("-0.031%": an interval [-14.5%, -0.0%]
// excludes zero, and read as if it touched it); "-" for a missing value. The report's A.pct.
std::string changePercentText(double change);
// "[lo, hi]" of an interval, "–" when there is none (the report's interval).
std::string intervalText(const Interval& interval);
// "tied with a, b" from a ranking entry's tiedWith, or "".
std::string tiedText(const RankedMethod& rankedMethod);
// A label as the rankings print it: "(+paths)" where it read paths beyond the frame's 1-spp ones,
// "(oracle)" where it read a layer no real-time engine has (the run's statistics say which).
std::string markedLabel(const RunResults& results, const std::string& label);
// The absent summaries of metrics other than relMSE whose reason is not one already said (relMSE's
// own on that scene, as no frame after the warm-up; a scene without a reference): a metric that
// gave no value on a pair (not finite on every frame) was printed nowhere. One line per scene,
// metric and reason, as absentSummaryLines.
std::vector<std::string> otherAbsentSummaryLines(const RunResults& results);
// The pairs' own warnings (pairs[].warnings): how many, on how many pairs.
struct PairWarningCount {
  size_t warnings = 0, pairs = 0;
};
PairWarningCount countPairWarnings(const RunResults& results);
// A scene's pairs whose outputs were bit-identical on every frame (pairs[].outputChecksum), each
// group "asvgf = svgf", groups separated by "; "; "" when none.
std::string identicalOutputsText(const RunResults& results, const std::string& scene);
// The groups of identicalOutputsText, each two or more pairs.
std::vector<std::vector<const PairResult*>> identicalOutputGroups(const RunResults& results,
                                                                  const std::string& scene);
// The scenes' image sizes, each once: "256x144" or "256x144, 512x288" ("" when none is recorded).
std::string sceneSizesText(const RunResults& results);
// The run's overall ranking (statistics.overall): rank ("=" when tied), label, score, interval,
// ties; and who was left out and why. Nothing when the run has none.
void printOverallRanking(std::ostream& out, const RunResults& results);
// The overall scores on the other metrics that declare one (statistics.overallByMetric: 1 - SSIM,
// the FLIPs): a row per method in the relMSE ranking's order, a column per metric holding its rank
// (ties "=") and score, so a reader sees whether the choice holds on them. Nothing without them.
void printOtherOverallScores(std::ostream& out, const RunResults& results);
// The methods at rank 1 on each of those metrics ("dssim svgf; ldrFlip passthrough"), "" if none.
std::string otherOverallFirstsText(const RunResults& results);
// The event-window figures with their 95% intervals, per scripted event and camera cut, methods in
// the order of their rank (lag energy, old-view leak) with ties (metrics/ghosting_intervals.hpp);
// printed by `run`, `sweep` and `study --verbose`. Nothing for a run without events.
void printEventTables(std::ostream& out, const RunResults& results);
// A run of several input seeds (--seeds K): each pair's error split over them (pairs[].
// biasVariance: bias2, variance, bias2Corrected, each mean with its interval), and that the
// table's relMSE is the first seed's. Nothing for a run of one seed.
void printSeedSplit(std::ostream& out, const RunResults& results);

// Where a finished study put its outputs, and how long it took.
struct StudyOutputs {
  std::string results, database, report;
  double seconds = 0;
};
// `arena study`'s summary, one screen (under 60 lines for the default study): the overall ranking
// with intervals; per scene one line, the best method on relMSE with its interval and the methods
// not resolved from it; the reference verdicts that miss the goal; each scene's warnings once
// (results.scenes.<scene>.warnings, asset fallbacks); a count of the pairs' own warnings and absent
// summaries; where the results and the report are. The full tables are printStudyTables'.
void printStudySummary(std::ostream& out, const RunResults& results, const StudyOutputs& where);
// What `arena study --verbose` prints before the summary: every scene's ranking with intervals,
// every event and camera cut with its figures and intervals, the absent summaries and every scene's
// reference verdict.
void printStudyTables(std::ostream& out, const RunResults& results);

}  // namespace arena::cli
