#include "tests/test_util.hpp"

#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "core/sequence.hpp"

namespace arena::test {

double queryNumber(const std::filesystem::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr);
  sqlite3_stmt* s = nullptr;
  double v = std::nan("");
  if (sqlite3_prepare_v2(h, sql.c_str(), -1, &s, nullptr) == SQLITE_OK &&
      sqlite3_step(s) == SQLITE_ROW && sqlite3_column_type(s, 0) != SQLITE_NULL)
    v = sqlite3_column_double(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(h);
  return v;
}

int countRows(const std::filesystem::path& db, const char* table) {
  sqlite3* h = nullptr;
  sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr);
  sqlite3_stmt* s = nullptr;
  int n = -1;
  if (sqlite3_prepare_v2(h, (std::string("SELECT COUNT(*) FROM ") + table).c_str(), -1, &s,
                         nullptr) == SQLITE_OK &&
      sqlite3_step(s) == SQLITE_ROW)
    n = sqlite3_column_int(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(h);
  return n;
}

CommandResult runCommand(const std::string& commandLine) {
  CommandResult r;
  FILE* pipe = popen((commandLine + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

namespace {
struct ProcessDir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("arena_test_" + std::to_string(getpid()));
  ~ProcessDir() {
    if (std::getenv("ARENA_KEEP_TEST_DIRS")) return;
    std::error_code ignored;  // best effort: a leftover directory must not fail a passing test
    std::filesystem::remove_all(path, ignored);
  }
};
}  // namespace

const std::filesystem::path& processDir() {
  static const ProcessDir dir;
  return dir.path;
}

RunResults typed(const nlohmann::json& run) { return RunResults::fromJson(run, "the test's run"); }

nlohmann::json statisticsBlock(const nlohmann::json& parts) {
  nlohmann::json block = {{"method", "crossed bootstrap (a test's block)"},
                          {"confidence", 0.95},
                          {"replicates", 1000},
                          {"tileGrid", {4, 4}},
                          {"rankedOn", "relMse"},
                          {"scenes", nlohmann::json::object()}};
  block.update(parts);
  return block;
}

std::filesystem::path freshDir(const std::string& name) {
  const auto dir = processDir() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

Scene shippedScene(const std::string& name) {
  return loadScene(defaultScenesDir() + "/" + name + ".json");
}

RenderSettings tinySettings(int w, int h, int frames, int refSpp) {
  RenderSettings s;
  s.preset = "test";
  s.width = w;
  s.height = h;
  s.frames = frames;
  s.referenceSpp = refSpp;
  s.referenceMinSpp = refSpp;
  s.referenceRelError = 0;
  return s;
}

float hashUniform(uint32_t a, uint32_t b, uint32_t c) {
  uint32_t v = a * 747796405u + b * 2891336453u + c * 277803737u + 12345u;
  v = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
  v = (v >> 22u) ^ v;
  return float(v >> 8) / float(1u << 24);
}

FrameContext stillCameraContext(int t, int w, int h) {
  FrameContext ctx;
  ctx.frameIndex = t;
  ctx.width = w;
  ctx.height = h;
  ctx.camera = CameraState::lookAt({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 45.0f, w, h);
  ctx.previousCamera = ctx.camera;
  ctx.reset = t == 0;
  return ctx;
}

LayerSet planeFrame(int w, int h, float spacing) {
  LayerSet frame;
  for (const LayerSpec& spec : channels::frameLayers())
    frame.set(spec.name, Image(w, h, spec.channels()));
  frame.get("albedo").fill(1.0f);
  frame.get("color").fill(0.5f);
  frame.get("depth").fill(2.0f);
  frame.get("roughness").fill(0.5f);
  frame.get("specHitDist").fill(1e6f);
  frame.get("specHitDistMirror").fill(1e6f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      frame.get("normal").at(x, y, 2) = 1.0f;
      frame.get("position").at(x, y, 0) = spacing * float(x);
      frame.get("position").at(x, y, 1) = -spacing * float(y);
      frame.get("position").at(x, y, 2) = -2.0f;
    }
  return frame;
}

std::unique_ptr<Denoiser> createDenoiser(const std::string& name,
                                         const std::map<std::string, std::string>& params,
                                         SignalKind kind) {
  const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
  return info.create(info.schema.resolve(params, name), kind);
}

int responseOrWindow(const nlohmann::json& g) {
  return g["responseFrames"].is_null() ? g["windowEnd"].get<int>() - g["eventFrame"].get<int>() + 1
                                       : g["responseFrames"].get<int>();
}

void rewriteCachedExr(const std::filesystem::path& file, const std::vector<LayerSpec>& specs,
                      const std::function<void(LayerSet&)>& edit) {
  ExrContents c = readExr(file, specs);
  edit(c.layers);
  ExrAttributes attributes;
  for (const auto& [key, value] : c.attributes)
    if (key.rfind("arena.sum.", 0) != 0) attributes[key] = value;
  writeExr(file, c.layers, specs, attributes, ExrCompression::None, ExrChecksums::PerChannel);
}

}  // namespace arena::test
