#include <algorithm>
#include <map>
#include <set>

#include "core/error.hpp"
#include "harness/reference_quality.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/compare.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/results.hpp"
#include "metrics/run_statistics.hpp"

// Shard sets: runs combined into one, analysed once (run_matrix.hpp).
namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

std::pair<int, int> parseShard(const std::string& text) {
  // Whole text, digits only: "0/1junk" or "1/4294967297" must not pass as something else.
  const std::string expected = "--shard '" + text + "': expected i/n with integers 0 <= i < n <= 100000, e.g. 0/4";
  size_t slash = text.find('/');
  auto number = [&](const std::string& digits) {
    if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos)
      throw Error(expected);
    return std::stoi(digits);
  };
  if (slash == std::string::npos) throw Error(expected);
  const int i = number(text.substr(0, slash)), n = number(text.substr(slash + 1));
  if (n < 1 || n > 100000 || i >= n) throw Error(expected);
  return {i, n};
}

std::vector<std::string> failedPairs(const RunResults& results) {
  std::vector<std::string> out;
  for (const PairResult& p : results.pairs)
    if (!p.ok()) out.push_back(p.label + " on " + p.scene + ": " + p.error);
  return out;
}

std::vector<std::string> failedPairs(const json& results) {
  return failedPairs(RunResults::fromJson(results, "the run's results"));
}

json mergeRuns(const std::vector<fs::path>& runs, const fs::path& out) {
  if (runs.empty()) throw Error("merge: no runs given");
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw Error(out.string() + ": exists and is not a directory; --out needs a run directory");
  for (const fs::path& run : runs)
    if (fs::exists(out, ec) && fs::equivalent(out, run, ec))
      throw Error("merge: --out " + out.string() + " is one of the shards it merges (" +
                  run.string() + "); write the merged run to another directory");
  RunResults merged;
  std::set<std::string> seen,
      seenNotRun;  // "scene\nlabel" of the pairs run, and of those not run (notRun)
  // A gate must not pass on a partial study: every shard i/n of one n, each exactly once.
  std::map<int, std::string> shards;
  int shardCount = 0;
  for (const fs::path& run : runs) {
    RunResults r = loadResults(run);
    // Its images are partly another run's: the merged report would show them as the shard's.
    if (const std::string note = unfinishedRunNote(run); !note.empty())
      throw Error(note + "; run that shard again to completion before merging it");
    const std::string shard = r.settings.shard();
    if (shard == "merged") throw Error(run.string() + ": already a merged run; merge the shards it came from");
    const auto [i, n] = parseShard(shard);
    if (shardCount && n != shardCount)
      throw Error(run.string() + ": shard " + shard + " is of another split than " + shards.begin()->second + "'s /" +
                  std::to_string(shardCount));
    shardCount = n;
    if (!shards.emplace(i, run.string()).second)
      throw Error(run.string() + ": shard " + shard + " is already given by " + shards[i]);
    std::vector<PairResult> pairs = std::move(r.pairs);
    const json scenes = std::move(r.scenes);
    if (shards.size() == 1) {  // the first shard given: the run's identity, settings, metrics and sweep
      merged = std::move(r);
      merged.pairs.clear();
      merged.scenes = json::object();
      merged.statistics.reset();
      merged.settings.setShard("merged");
    } else if (const std::vector<std::string> differ = jsonDifferences(
                   merged.settings.measurement(), r.settings.measurement(), "settings");
               !differ.empty()) {
      std::string fields;
      for (size_t k = 0; k < differ.size() && k < 3; ++k) fields += (k ? "; " : "") + differ[k];
      if (differ.size() > 3) fields += "; and " + std::to_string(differ.size() - 3) + " more";
      throw Error(run.string() + ": settings differ from " + runs.front().string() + " (" + fields +
                  "); only shards of one run can be merged");
    }
    for (auto it = scenes.begin(); it != scenes.end(); ++it) {
      // Each shard lists the capture's denoisers it did not run (notRun): the merge keeps them all.
      json notRun = merged.scenes.value(it.key(), json::object()).value("notRun", json::array());
      for (const json& entry : it.value().value("notRun", json::array()))
        if (std::find(notRun.begin(), notRun.end(), entry) == notRun.end()) notRun.push_back(entry);
      merged.scenes[it.key()] = it.value();
      if (!notRun.empty()) merged.scenes[it.key()]["notRun"] = notRun;
      // A pair not run for want of inputs is accounted for, as a pair run is.
      for (const json& entry : notRun)
        seenNotRun.insert(it.key() + "\n" + entry.value("label", ""));
    }
    for (PairResult& p : pairs) {
      if (!seen.insert(p.scene + "\n" + p.label).second)
        throw Error(run.string() + ": pair " + p.label + " on " + p.scene + " appears in two shards");
      merged.pairs.push_back(std::move(p));
    }
  }
  // The statistics are recomputed below with this build's event figures: shards whose event
  // figures were measured under other ghosting settings (an older build) would mix two definitions.
  // (Shards that record none, as hand-made ones, are taken as they are.)
  if (const json recorded = merged.settings.measurement().value("ghosting", json());
      recorded.is_object() && recorded != GhostingConfig{}.toJson())
    throw Error(
        "merge: the shards' settings.ghosting differ from this build's (their event figures were "
        "measured under another definition); run the shards again with this build, or compare them "
        "unmerged; nothing was written");
  std::string missing;
  for (int i = 0; i < shardCount; ++i)
    if (!shards.count(i)) missing += (missing.empty() ? "" : ", ") + std::to_string(i) + "/" + std::to_string(shardCount);
  if (!missing.empty()) throw Error("merge: incomplete shard set, missing " + missing + "; nothing was written");
  // Every pair of the plan the shards record (each sequence with each contender) is in one of
  // them: a shard that lost a pair would merge into a run silently without it.
  if (const json plan = merged.settings.measurement().value("plan", json()); plan.is_object()) {
    std::string lost;
    int count = 0;
    for (const json& sequence : plan.value("sequences", json::array()))
      for (const json& label : plan.value("labels", json::array()))
        if (sequence.is_object() && sequence.value("name", json()).is_string() &&
            label.is_string() &&
            !seen.count(sequence["name"].get<std::string>() + "\n" + label.get<std::string>()) &&
            !seenNotRun.count(sequence["name"].get<std::string>() + "\n" +
                              label.get<std::string>())) {
          if (++count <= 5)
            lost += (lost.empty() ? "" : ", ") + label.get<std::string>() + " on " +
                    sequence["name"].get<std::string>();
        }
    if (count > 0)
      throw Error("merge: " + std::to_string(count) +
                  " pair(s) of the run's plan are in no shard (" + lost +
                  (count > 5 ? ", ..." : "") + "); a shard lost them; nothing was written");
    // The pairs in the plan's order (each sequence, each contender), as one run writes them; the
    // shards' order would interleave them.
    std::map<std::string, size_t> sequenceAt, labelAt;
    for (const json& sequence : plan.value("sequences", json::array()))
      if (sequence.is_object() && sequence.value("name", json()).is_string())
        sequenceAt.emplace(sequence["name"].get<std::string>(), sequenceAt.size());
    for (const json& label : plan.value("labels", json::array()))
      if (label.is_string()) labelAt.emplace(label.get<std::string>(), labelAt.size());
    const auto at = [](const std::map<std::string, size_t>& order, const std::string& key) {
      const auto it = order.find(key);
      return it == order.end() ? order.size() : it->second;
    };
    std::stable_sort(merged.pairs.begin(), merged.pairs.end(),
                     [&](const PairResult& a, const PairResult& b) {
                       return std::pair(at(sequenceAt, a.scene), at(labelAt, a.label)) <
                              std::pair(at(sequenceAt, b.scene), at(labelAt, b.label));
                     });
  }
  const RunDirectoryLock outLock = checkRunOutputs(
      out);  // creates --out only now: shards that cannot be merged leave no directory behind
  // The images are the shards', as the results are: a previous merge's in --out go.
  markRunUnfinished(out);
  fs::remove_all(out / "images", ec);
  if (ec)
    throw Error((out / "images").string() +
                ": cannot replace the images of a previous merge: " + ec.message());
  for (const fs::path& run : runs)
    if (fs::exists(run / "images"))
      fs::copy(run / "images", out / "images", fs::copy_options::recursive | fs::copy_options::skip_existing);
  // The statistics and the verdicts are computed on the document as the run loop writes it.
  json document = merged.toJson();
  warnOfIdenticalSweepPoints(document, nullptr);
  document["statistics"] = analyseRun(document).toJson();
  addReferenceQuality(document, merged.settings.warmup());
  commitResults(out, document);
  return document;
}

}  // namespace arena
