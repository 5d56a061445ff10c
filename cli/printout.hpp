#pragma once
// What `arena run` and `arena study` print of a run's statistics, formatted exactly as the report
// formats the same numbers (reports/web/shared.js fmt and interval), so the console and the page
// can be compared digit for digit.
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

namespace arena::cli {

// 4 significant digits, trailing zeros dropped; 2 decimals in exponent form below 1e-3 or from 1e5
// ("1.23e-4"); "0" for zero and "–" for a missing value (the report's fmt).
std::string figureText(double value);
std::string figureText(const nlohmann::json& value);
// "[lo, hi]" of a 2-element interval, "–" when there is none (the report's interval).
std::string intervalText(const nlohmann::json& interval);
// "tied with a, b" from a ranking entry's tiedWith, or "".
std::string tiedText(const nlohmann::json& rankedMethod);
// The run's overall ranking (statistics.overall): rank ("=" when tied), label, score, interval,
// ties; and who was left out and why. Nothing when the run has none.
void printOverallRanking(std::ostream& out, const nlohmann::json& results);

}  // namespace arena::cli
