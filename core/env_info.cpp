#include "core/env_info.hpp"

#include <cctype>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <string>
#include <thread>

#include "git_state.hpp"  // generated at build time (cmake/git_state.cmake)

namespace arena {

nlohmann::json environmentInfo() {
  std::string cpu;
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  // The machine's load when the measurement began (1, 5 and 15 minute averages): times taken
  // beside other work read slower, and this says whether there was any.
  double load[3] = {-1, -1, -1};
  const bool loadKnown = getloadavg(load, 3) == 3;
  return {{"cpu", cpu},
          {"cores", std::thread::hardware_concurrency()},
          {"loadAverage",
           loadKnown ? nlohmann::json{load[0], load[1], load[2]} : nlohmann::json(nullptr)},
          {"compiler", ARENA_COMPILER},
          {"flags", ARENA_CXX_FLAGS},
          {"git_commit", ARENA_GIT_COMMIT}};
}

std::string utcTimestamp() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

bool isUtcTimestamp(const std::string& text) {
  // YYYY-MM-DDTHH:MM:SSZ: 20 characters, digits where the form has them.
  static const std::string form = "0000-00-00T00:00:00Z";
  if (text.size() != form.size()) return false;
  for (size_t i = 0; i < form.size(); ++i)
    if (form[i] == '0' ? !std::isdigit(static_cast<unsigned char>(text[i])) : text[i] != form[i])
      return false;
  auto field = [&](size_t at, size_t digits) { return std::stoi(text.substr(at, digits)); };
  const int year = field(0, 4), month = field(5, 2), day = field(8, 2);
  if (month < 1 || month > 12 || day < 1) return false;
  static const int days[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  if (day > days[month - 1] + (month == 2 && leap ? 1 : 0)) return false;
  return field(11, 2) < 24 && field(14, 2) < 60 && field(17, 2) <= 60;  // 60: a leap second
}

}  // namespace arena
