#include "core/env_info.hpp"

#include <ctime>

#include <array>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

namespace arena {

static std::string commandOutput(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  std::array<char, 256> buf{};
  while (fgets(buf.data(), int(buf.size()), p)) out += buf.data();
  pclose(p);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

nlohmann::json environmentInfo() {
  std::string cpu;
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  return {{"cpu", cpu},
          {"cores", std::thread::hardware_concurrency()},
          {"compiler", ARENA_COMPILER},
          {"flags", ARENA_CXX_FLAGS},
          {"git_commit", commandOutput("git -C '" ARENA_SOURCE_DIR "' rev-parse --short HEAD 2>/dev/null")}};
}

std::string utcTimestamp() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

}  // namespace arena
