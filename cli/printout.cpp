#include "cli/printout.hpp"

#include <cmath>
#include <cstdio>
#include <iomanip>

namespace arena::cli {

using nlohmann::json;

std::string figureText(double v) {
  if (!std::isfinite(v)) return "–";
  const double a = std::abs(v);
  if (a == 0) return "0";
  char buf[64];
  if (a < 1e-3 || a >= 1e5) {
    std::snprintf(buf, sizeof buf, "%.2e", v);  // 1.23e-04 -> 1.23e-4, as JavaScript writes it
    std::string s = buf;
    const size_t e = s.find('e');
    std::string mantissa = s.substr(0, e), exponent = s.substr(e + 1);
    const char sign = exponent[0];
    exponent = exponent.substr(1);
    while (exponent.size() > 1 && exponent[0] == '0') exponent.erase(0, 1);
    return mantissa + "e" + sign + exponent;
  }
  // Four significant digits, then the shortest text of that number (JavaScript's
  // Number(v.toPrecision(4)).toString()).
  std::snprintf(buf, sizeof buf, "%.4g", v);
  double rounded = std::strtod(buf, nullptr);
  std::snprintf(buf, sizeof buf, "%.15g", rounded);
  return buf;
}

std::string figureText(const json& v) { return v.is_number() ? figureText(v.get<double>()) : "–"; }

std::string intervalText(const json& ci) {
  if (!ci.is_array() || ci.size() != 2) return "–";
  std::string text = "[";  // appended, not "[" + string: GCC 12 warns falsely (-Wrestrict) on that
  text += figureText(ci[0]);
  text += ", ";
  text += figureText(ci[1]);
  text += "]";
  return text;
}

std::string tiedText(const json& m) {
  std::string s;
  for (const json& t : m.value("tiedWith", json::array())) s += (s.empty() ? "" : ", ") + t.get<std::string>();
  return s.empty() ? "" : "tied with " + s;
}

void printOverallRanking(std::ostream& out, const json& results) {
  const json st = results.value("statistics", json::object());
  if (!st.contains("overall")) return;
  const json& o = st["overall"];
  out << "\noverall: " << o.value("normalisation", "") << " (lower is better)\n";
  for (const json& m : o.value("ranking", json::array())) {
    const bool tied = !m.value("tiedWith", json::array()).empty();
    out << "  " << std::left << std::setw(4) << (std::to_string(m.value("rank", 0)) + (tied ? "=" : "")) << std::setw(26)
        << m.value("label", "") << std::right << std::setw(11) << figureText(m.value("score", json())) << "  "
        << std::left << std::setw(24) << intervalText(m.value("ci95", json())) << tiedText(m) << "\n";
  }
  if (o.contains("excluded")) out << "  not ranked overall: " << o["excluded"].get<std::string>() << "\n";
}

}  // namespace arena::cli
