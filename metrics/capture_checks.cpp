#include "metrics/capture_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <span>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/non_finite.hpp"
#include "core/text.hpp"
#include "metrics/error.hpp"

namespace arena {

namespace {

constexpr double kSoft = std::numeric_limits<double>::infinity();

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

CaptureCheck check(std::string name, double value, double warnAbove, double failAbove, std::string unit,
                   std::string detail) {
  CaptureCheck c{std::move(name), value, warnAbove, failAbove, std::move(unit), std::move(detail), CheckStatus::Pass};
  c.status = value > failAbove ? CheckStatus::Fail : value > warnAbove ? CheckStatus::Warn : CheckStatus::Pass;
  return c;
}

// A check failed because the importer's record it reads (capture.json `source.FIELD`) is not what
// the importer writes: edited or damaged, nothing to pass on.
CaptureCheck damagedSourceCheck(const std::string& name, double warnAbove, const std::string& unit,
                                const std::string& field, const std::string& expected) {
  CaptureCheck c = check(name, std::numeric_limits<double>::quiet_NaN(), warnAbove, kSoft, unit,
                         "capture.json source." + field + " is no " + expected +
                             ": edited or damaged, so nothing says what it measured");
  c.status = CheckStatus::Fail;
  return c;
}

// How far, in pixels, the picture of frame b's camera lies from frame a's: the turn of its axes
// and the change of its field of view at the focal length in pixels, plus its move seen at
// `nearDepth` (the nearest surfaces move most; without a depth, any move beyond rounding counts
// as a pixel).
double cameraShiftPixels(const CameraState& a, const CameraState& b, double nearDepth) {
  const double focal = 0.5 * a.height / double(a.tanHalfFovY);
  // atan2 of the cross and dot products, in double: acos of a float dot product near 1 reads a
  // turn of 3e-4 rad for two equal directions one rounding apart.
  auto angle = [](glm::vec3 u, glm::vec3 v) {
    const glm::dvec3 x(u), y(v);
    return std::atan2(glm::length(glm::cross(x, y)), glm::dot(x, y));
  };
  const double turn =
      std::max({angle(a.forward, b.forward), angle(a.up, b.up), angle(a.right, b.right)});
  const double zoom =
      std::abs(double(b.tanHalfFovY) / double(a.tanHalfFovY) - 1.0) * 0.5 * a.height;
  const double move = double(glm::length(b.eye - a.eye));
  const double moved = nearDepth > 0
                           ? move / nearDepth * focal
                           : (move > 1e-5 * (1.0 + double(glm::length(a.eye))) ? 1.0 : 0.0);
  return turn * focal + zoom + moved;
}

// The nearest surfaces' view depth: the 1st percentile of the positive finite depths (0: none).
double nearDepth(const LayerSet& frame) {
  if (!frame.has("depth")) return 0;
  std::vector<float> d;
  for (float v : frame.get("depth").raw())
    if (std::isfinite(v) && v > 0) d.push_back(v);
  if (d.empty()) return 0;
  const size_t k = d.size() / 100;
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(k), d.end());
  return d[k];
}

// A check the capture gives no data for: a warning saying so, never a pass (value NaN: none
// measured).
CaptureCheck unchecked(std::string name, std::string why) {
  return {std::move(name),
          std::numeric_limits<double>::quiet_NaN(),
          0,
          kSoft,
          "",
          "not checked: " + std::move(why),
          CheckStatus::Warn};
}

// High-frequency energy of an image's log luminance: sum (l - box3(l))^2 with l = log(L + eps).
// Edges and texture contribute to it in the input and the reference alike; noise only where there
// is noise. In the log domain an emitter's bright edge counts like any other edge instead of
// outweighing the noise of every dark region, so a converged reference has far less of it than a
// noisy input, and one with as much is not converged. `eps` is shared by the two images compared.
// A one-channel image's value at (x, y) minus its 3x3 box mean (edges clamped): its high frequency.
double boxResidual(const Image& l, int x, int y) {
  double box = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) box += double(l.atClamped(x + dx, y + dy));
  return double(l.at(x, y)) - box / 9.0;
}

double highFrequencyEnergy(const Image& rgb, double eps) {
  const Image lum = luminance(rgb);
  const int w = lum.width(), h = lum.height();
  Image logLum(w, h, 1);
  for (size_t i = 0; i < lum.pixelCount(); ++i) {
    const float v = lum.raw()[i];
    logLum.raw()[i] = std::isfinite(v) ? float(std::log(std::max(0.0, double(v)) + eps)) : 0.0f;
  }
  double energy = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double r = boxResidual(logLum, x, y);
      energy += r * r;
    }
  return energy;
}

// Sums over the pixels of the high-frequency parts of two images' linear luminance (each minus
// its 3x3 box): sum a^2, sum b^2 and sum a*b. For a noisy input a and its reference b, whose
// noises are independent and whose signals are the same, E(sum a*b) is the signal's own energy,
// so sum b^2 - sum a*b is the reference's noise and sum a^2 - sum a*b the input's: the ratio of
// their noises, with the signal (edges, texture) cancelled, unlike roughnessVsInput's.
struct HighFrequencySums {
  double aa = 0, bb = 0, ab = 0;
  // Only where the 3x3 neighbourhood is one flat surface (the same normal, depth within 2%, and
  // the same mesh id and albedo where the frame gives them): at an edge a 1-spp input sampled at
  // pixel centres and a reference that averages the pixel differ in the picture itself, which
  // would not cancel (cornell_static's read like 3 samples whatever the reference's count).
  void add(const Image& a, const Image& b, const LayerSet& frame) {
    const Image la = luminance(a), lb = luminance(b);
    const int w = la.width(), h = la.height();
    const Image& normal = frame.get("normal");
    const Image& depth = frame.get("depth");
    const Image* mesh = frame.has("meshId") ? &frame.get("meshId") : nullptr;
    const Image* albedo = frame.has("albedo") ? &frame.get("albedo") : nullptr;
    const auto flat = [&](int x, int y) {
      const float z = depth.at(x, y);
      if (!(z > 0) || !std::isfinite(z)) return false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = std::clamp(x + dx, 0, w - 1), v = std::clamp(y + dy, 0, h - 1);
          const float zn = depth.at(u, v);
          if (!(std::abs(zn - z) <= 0.02f * z)) return false;
          float dot = 0;
          for (int c = 0; c < 3; ++c) dot += normal.at(x, y, c) * normal.at(u, v, c);
          if (!(dot > 0.99f)) return false;
          if (mesh && mesh->at(u, v) != mesh->at(x, y)) return false;
          if (albedo)
            for (int c = 0; c < 3; ++c)
              if (!(std::abs(albedo->at(u, v, c) - albedo->at(x, y, c)) <= 1e-3f)) return false;
        }
      return true;
    };
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (!flat(x, y)) continue;
        const double ra = boxResidual(la, x, y), rb = boxResidual(lb, x, y);
        if (!std::isfinite(ra) || !std::isfinite(rb)) continue;
        aa += ra * ra, bb += rb * rb, ab += ra * rb;
      }
  }
  // The reference's noise over the input's; NaN when the input shows none.
  double ratio() const {
    return aa - ab > 0 ? (bb - ab) / (aa - ab) : std::numeric_limits<double>::quiet_NaN();
  }
};

double meanLuminance(const Image& rgb) {
  const Image lum = luminance(rgb);
  double sum = 0;
  for (float v : lum.raw())
    if (std::isfinite(v)) sum += std::max(0.0f, v);
  return lum.pixelCount() ? sum / double(lum.pixelCount()) : 0;
}

// The input's brightness against its reference's: the ratio of their mean luminances, and how many
// standard errors the mean per-pixel difference lies from 0. A noisy input is an unbiased estimate
// of the converged image, so a ratio far from 1 at a large z is no noise: an exposure, a scale or
// a colour space that differs between the two.
// Sums over pixels, so that one frame or the whole sequence is judged alike. The z assumes the
// differences are near normal, which rare bright paths at 1 spp (caustics, small lights) are not:
// a frame that misses them reads dark at a large z, so one frame only warns.
struct Brightness {
  double sumA = 0, sumB = 0, sumD = 0, sumD2 = 0;
  size_t n = 0;
  void add(const Image& input, const Image& reference) {
    const Image a = luminance(input), b = luminance(reference);
    for (size_t i = 0; i < a.raw().size(); ++i) {
      const double x = a.raw()[i], y = b.raw()[i];
      sumA += x;
      sumB += y;
      sumD += x - y;
      sumD2 += (x - y) * (x - y);
    }
    n += a.raw().size();
  }
  bool measured() const { return n >= 2 && sumA > 0 && sumB > 0; }
  double ratio() const { return measured() ? sumA / sumB : 1.0; }
  double factor() const { return std::max(ratio(), 1.0 / ratio()); }
  double z() const {
    if (!measured()) return 0;
    const double mean = sumD / double(n), variance = std::max(0.0, sumD2 / double(n) - mean * mean);
    return variance > 0 ? mean / std::sqrt(variance / double(n - 1)) : (mean != 0 ? 1e9 : 0.0);
  }
  // "the input's mean luminance is 4x its reference's, 38 standard errors from equal"; a darker
  // input says the factor the check's value is ("0.25x its reference's (4x darker)").
  std::string text() const {
    return "the input's mean luminance is " + number(ratio()) + "x its reference's" +
           (ratio() < 0.99 ? " (" + number(factor()) + "x darker)" : std::string()) + ", " +
           number(std::abs(z())) + " standard errors from equal";
  }
};

// Which of two references a frame's input lies on: its own (`own`) or a neighbouring frame's
// (`other`). The input is an unbiased estimate of its own reference, so per value
// d = (x - other)^2 - (x - own)^2 has the expectation (own - other)^2 when `own` is the right one
// and -(own - other)^2 when `other` is; the references' own noise, where known (their variance),
// is taken off (var_other - var_own), so that a less converged neighbour does not read as a worse
// fit. `side()` is sum d / sum (own - other)^2: +1 on its own reference, -1 on the other; `z()`
// is sum d in standard errors of the input's noise, which is independent between pixels. The
// input is first scaled to its own reference's mean: a slightly dark input during a fade would
// otherwise lie nearer a darker neighbour. Each value's d (and gap) weighs 1 / (m^2 + 0.01 mean^2),
// m the two references' mean there, as relMSE weighs its errors: a path tracer's noise grows with
// the radiance, so unweighted sums were ruled by the bright pixels' noise and decided nothing on a
// 1-spp Cycles capture whose references were one frame late (z -1.7 where the weighted sum gives
// -19; aligned frames +10 to +28), scale-free (the capture's units are its own).
struct ReferenceFit {
  double sumD = 0, sumD2 = 0, sumGap = 0;
  size_t n = 0;
  bool noiseKnown = true;  // every reference compared carried its variance
  void add(const Image& input, const Image& own, const Image& other, const Image* ownVar,
           const Image* otherVar) {
    noiseKnown = noiseKnown && ownVar && otherVar;
    double sumX = 0, sumA = 0;
    for (size_t i = 0; i < input.raw().size(); ++i) sumX += input.raw()[i], sumA += own.raw()[i];
    const double gain = sumX > 0 && sumA > 0 ? sumA / sumX : 1.0;
    const double meanA = input.raw().empty() ? 0.0 : sumA / double(input.raw().size());
    const double epsilon = 0.01 * meanA * meanA + 1e-30;
    for (size_t i = 0; i < input.raw().size(); ++i) {
      const double x = gain * input.raw()[i], a = own.raw()[i], b = other.raw()[i];
      const double noise = ownVar && otherVar ? double(otherVar->raw()[i]) - ownVar->raw()[i] : 0.0;
      const double m = 0.5 * (a + b), w = 1.0 / (m * m + epsilon);
      const double d = w * ((x - b) * (x - b) - (x - a) * (x - a) - noise);
      sumD += d;
      sumD2 += d * d;
      sumGap += w * (a - b) * (a - b);
    }
    n += input.raw().size();
  }
  void add(const ReferenceFit& other) {  // pooled over frames
    sumD += other.sumD, sumD2 += other.sumD2, sumGap += other.sumGap, n += other.n;
    noiseKnown = noiseKnown && other.noiseKnown;
  }
  double side() const { return sumGap > 0 ? sumD / sumGap : 0.0; }
  double z() const {
    if (n < 2) return 0;
    const double mean = sumD / double(n), variance = std::max(0.0, sumD2 / double(n) - mean * mean);
    return variance > 0 ? mean / std::sqrt(variance / double(n - 1)) : 0.0;
  }
  // On the other reference beyond noise, and nearer it than its own.
  bool onOther() const { return z() < -5 && side() < -0.5; }
  bool onOwn() const { return z() > 5 && side() > 0.5; }
};

// How many of an image's values are negative radiance: below -1e-3 of its mean luminance (a
// filtered or denoised image carries values like -1e-7 from negative filter lobes; a negated one is
// negative throughout).
long negativeValues(const Image& c) {
  const float below = -1e-3f * float(meanLuminance(c)) - 1e-12f;
  long n = 0;
  for (float x : c.raw()) n += x < below;
  return n;
}

// Whether two images hold the same values bit for bit.
bool sameValues(const Image& a, const Image& b) {
  const std::span<const float> x = a.raw(), y = b.raw();
  return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size_bytes()) == 0;
}

// "a, b, c" (at most 8, then "...").
std::string listText(const std::vector<std::string>& items) {
  std::string out;
  for (size_t k = 0; k < items.size() && k < 8; ++k) out += (k ? ", " : "") + items[k];
  if (items.size() > 8) out += ", ...";
  return out;
}

// A soft check counting what the capture holds and nothing reads (folders, files, channels):
// "<before>a, b, c<after>" when there are any.
CaptureCheck namesWarning(std::string name, const std::vector<std::string>& names, std::string unit,
                          const std::string& before, const std::string& after) {
  return check(std::move(name), double(names.size()), 0, kSoft, std::move(unit),
               names.empty() ? "" : before + listText(names) + after);
}

// Unknown channel names with the layer channel each most likely misspells: "color.r (color.R?)".
std::vector<std::string> withLikelyNames(const std::vector<std::string>& unknown,
                                         const std::vector<std::string>& layersGiven) {
  // Only the channels the file lacks: "color.A" beside color.R, G and B is no misspelt color.R.
  std::vector<std::string> known;
  for (const LayerSpec& spec : channels::frameLayers())
    if (std::find(layersGiven.begin(), layersGiven.end(), spec.name) == layersGiven.end())
      for (int k = 0; k < spec.channels(); ++k) known.push_back(spec.channelName(k));
  std::vector<std::string> out;
  for (const std::string& name : unknown) {
    const std::string likely = closestName(name, known);
    out.push_back(likely.empty() ? name : name + " (" + likely + "?)");
  }
  return out;
}

// "0, 3, 7" (at most 8, then "...").
std::string frameList(const std::vector<int>& frames) {
  std::vector<std::string> items;
  for (int f : frames) items.push_back(std::to_string(f));
  return listText(items);
}

}  // namespace

const char* checkStatusName(CheckStatus s) {
  switch (s) {
    case CheckStatus::Pass: return "pass";
    case CheckStatus::Warn: return "warn";
    case CheckStatus::Fail: return "fail";
  }
  return "?";
}

CheckStatus CaptureValidation::status() const {
  CheckStatus worst = CheckStatus::Pass;
  for (const CaptureCheck& c : checks) worst = std::max(worst, c.status);
  return worst;
}

nlohmann::json CaptureValidation::toJson() const {
  nlohmann::json list = nlohmann::json::array();
  auto finiteOrNull = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  for (const CaptureCheck& c : checks)
    list.push_back({{"name", c.name}, {"value", finiteOrNull(c.value)}, {"warnAbove", finiteOrNull(c.warnAbove)},
                    {"failAbove", finiteOrNull(c.failAbove)}, {"unit", c.unit}, {"detail", c.detail},
                    {"status", checkStatusName(c.status)}});
  return {{"status", checkStatusName(status())}, {"checks", list}};
}

static std::string describe(const CaptureCheck& c) {
  const double limit = c.status == CheckStatus::Fail ? c.failAbove : c.warnAbove;
  return c.name + " " + number(c.value) + " > " + number(limit) + (c.unit.empty() ? "" : " (" + c.unit + ")") +
         (c.detail.empty() ? "" : ": " + c.detail);
}

std::string CaptureValidation::failures() const {
  std::string out;
  for (const CaptureCheck& c : checks)
    if (c.status == CheckStatus::Fail) out += (out.empty() ? "" : "; ") + describe(c);
  return out;
}

std::vector<std::string> CaptureValidation::warnings() const {
  std::vector<std::string> out;
  for (const CaptureCheck& c : checks)
    if (c.status == CheckStatus::Warn) out.push_back(describe(c));
  return out;
}

std::vector<DepthReading> depthReadings(double n, double f) {
  std::vector<DepthReading> out = {
      {"in millimetres (1000x the scene's units)", [](float z, float) { return z / 1000.0f; }},
      {"in centimetres (100x the scene's units)", [](float z, float) { return z / 100.0f; }},
      {"100x smaller than the scene's units", [](float z, float) { return z * 100.0f; }},
      {"1000x smaller than the scene's units", [](float z, float) { return z * 1000.0f; }},
      // A ray tracer's hit distance: the same as view depth at the image's centre, larger
      // towards its edges.
      {"a ray distance (eye to hit), not view depth along the camera's axis",
       [](float z, float cosine) { return z * cosine; }}};
  if (n > 0 && f > n) {  // a depth buffer's value d in [0, 1], linearised
    out.push_back({"a depth-buffer value (0 at near, 1 at far), not view depth",
                   [n, f](float d, float) { return float(n * f / (f - double(d) * (f - n))); }});
    out.push_back({"a reversed depth-buffer value (1 at near, 0 at far), not view depth",
                   [n, f](float d, float) { return float(n * f / (n + double(d) * (f - n))); }});
  }
  return out;
}

// The camera whose view matrix is the inverse of `c`'s: what capture.json meant when its `view`
// held camera-to-world matrices (the view's rows are the camera's axes, its translation the eye).
CameraState invertedCamera(const CameraState& c) {
  const glm::vec3 back = -c.forward;
  CameraState inv = c;
  inv.right = glm::vec3(c.right.x, c.up.x, back.x);
  inv.up = glm::vec3(c.right.y, c.up.y, back.y);
  inv.forward = -glm::vec3(c.right.z, c.up.z, back.z);
  inv.eye = -glm::vec3(glm::dot(c.right, c.eye), glm::dot(c.up, c.eye), glm::dot(back, c.eye));
  return inv;
}

MotionConsistency checkMotion(const std::vector<LayerSet>& frames,
                              const std::vector<CameraState>& cameras,
                              const std::vector<int>& cutFrames, double tol,
                              const std::set<int>& movingMeshes,
                              const std::vector<DepthReading>& readings) {
  // Per reading of the depth: the pixels where it predicts another motion than the depth as
  // written (by more than 2 tolerances), how many of those the stored motion fits under it, and
  // how many as written.
  struct DepthCount {
    long informative = 0, matched = 0, matchedAsWritten = 0;
  };
  std::vector<DepthCount> depthCounts(readings.size());
  // The conventions a capture may have slipped into, as the stored vector they predict from the
  // expected motion e (to the previous frame) and n (to the next): name -> prediction.
  struct Candidate {
    const char* name;
    bool needsNext;
    long informative = 0, matched = 0;
  };
  std::vector<Candidate> candidates = {
      {"as specified", false},
      {"sign flipped", false},
      {"x flipped", false},
      {"y flipped", false},
      {"axes swapped", false},
      {"scaled by 2", false},
      {"scaled by 1/2", false},
      {"in normalised units, not pixels", false},
      {"pointing to the next frame", true},
      {"in NDC units (2 / width, 2 / height a pixel), not pixels", false},
      {"in NDC units with y up (2 / width, -2 / height a pixel), not pixels", false},
      {"right for the inverse cameras (capture.json's view holding camera-to-world matrices: "
       "invert them, the vectors may be right)",
       false}};
  std::vector<CameraState> inverse;
  for (const CameraState& c : cameras) inverse.push_back(invertedCamera(c));
  MotionConsistency out;
  long off = 0,
       nextIsMirror = 0;  // informative pixels whose next-frame motion is -e (constant velocity)
  double errorSum = 0;
  auto isCut = [&](int t) { return std::find(cutFrames.begin(), cutFrames.end(), t) != cutFrames.end(); };
  const int n = int(frames.size());
  for (int t = 1; t < n; ++t) {
    if (isCut(t)) continue;
    const LayerSet& f = frames[size_t(t)];
    const Image &depth = f.get("depth"), &motion = f.get("motion"), &mesh = f.get("meshId");
    const CameraState &cam = cameras[size_t(t)], &prev = cameras[size_t(t - 1)];
    const bool hasNext = t + 1 < n && !isCut(t + 1);
    const int w = depth.width(), h = depth.height();
    const long pixelsBefore = out.pixels, offBefore = off;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float z = depth.at(x, y);
        if (!(z > 0) || !std::isfinite(z)) continue;
        if (movingMeshes.count(int(mesh.at(x, y)))) continue;  // not a static surface
        const glm::vec2 pixel(float(x) + 0.5f, float(y) + 0.5f);
        const glm::vec3 p = cam.pointAtDepth(pixel.x, pixel.y, z);
        glm::vec2 pp, pn;
        if (!prev.project(p, pp)) continue;
        const glm::vec2 e = pp - pixel;
        const bool next = hasNext && cameras[size_t(t + 1)].project(p, pn);
        const glm::vec2 nx = next ? pn - pixel : glm::vec2(0);
        const glm::vec2 m(motion.at(x, y, 0), motion.at(x, y, 1));
        if (!std::isfinite(m.x) || !std::isfinite(m.y)) continue;  // counted by the non-finite check
        // In double: a vector of 1e30 px squared overflows a float, and the mean read "inf px".
        const double err = glm::length(glm::dvec2(m) - glm::dvec2(e));
        out.depthWithinUnit = out.depthWithinUnit && z <= 1.0f;
        const float cosine =
            glm::dot(glm::normalize(cam.rayDirection(pixel.x, pixel.y)), cam.forward);
        for (size_t k = 0; k < readings.size(); ++k) {
          const float zk = readings[k].toViewDepth(z, cosine);
          glm::vec2 pk;
          if (!(zk > 0) || !std::isfinite(zk) ||
              !prev.project(cam.pointAtDepth(pixel.x, pixel.y, zk), pk))
            continue;
          const glm::vec2 ek = pk - pixel;
          // The two readings agree here; or this one predicts no motion, which a motion layer
          // left empty (or in other units) would match without saying anything of the depth.
          if (glm::length(ek - e) <= 2 * tol || glm::length(ek) <= tol) continue;
          ++depthCounts[k].informative;
          depthCounts[k].matched += glm::length(m - ek) <= tol;
          depthCounts[k].matchedAsWritten += err <= tol;
        }
        ++out.pixels;
        errorSum += err;
        off += err > tol;
        // Only motion of more than a few pixels tells conventions apart (at 0 they all agree).
        if (glm::length(e) < 4 * tol) continue;
        const glm::vec2 size{float(w), float(h)};
        const glm::vec2 ndc = 2.0f * e / size;
        // The motion under the inverse cameras: the point at this depth seen by frame t's
        // inverse, projected by frame t - 1's.
        glm::vec2 pi(std::numeric_limits<float>::quiet_NaN());
        if (!inverse[size_t(t - 1)].project(inverse[size_t(t)].pointAtDepth(pixel.x, pixel.y, z),
                                            pi))
          pi = glm::vec2(std::numeric_limits<float>::quiet_NaN());
        const glm::vec2 predictions[] = {e,          -e,       {-e.x, e.y},     {e.x, -e.y},
                                         {e.y, e.x}, 2.0f * e, 0.5f * e,        e / size,
                                         nx,         ndc,      {ndc.x, -ndc.y}, pi - pixel};
        nextIsMirror += next && glm::length(nx + e) < 2 * tol;
        for (size_t k = 0; k < candidates.size(); ++k) {
          if (candidates[k].needsNext && (!next || glm::length(nx + e) < 2 * tol)) continue;  // n = -e: no information
          ++candidates[k].informative;
          // Normalised and NDC units are a hundred times smaller: judged at a proportionally
          // smaller tolerance.
          const float tolerance = k == 7              ? float(tol) / std::max(size.x, size.y)
                                  : k == 9 || k == 10 ? 2 * float(tol) / std::max(size.x, size.y)
                                                      : float(tol);
          candidates[k].matched += glm::length(m - predictions[k]) <= tolerance;
        }
      }
    if (const long checked = out.pixels - pixelsBefore; checked >= 100) {  // sky: no verdict
      const double share = double(off - offBefore) / double(checked);
      if (share > out.worstFrameShare) out.worstFrameShare = share, out.worstFrame = t;
    }
  }
  if (out.pixels == 0) return out;
  out.offShare = double(off) / double(out.pixels);
  out.meanErrorPx = errorSum / double(out.pixels);
  out.conventionPixels = candidates[0].informative;
  auto share = [](const Candidate& c) { return c.informative > 0 ? double(c.matched) / double(c.informative) : 0.0; };
  const double asSpecified = share(candidates[0]);
  double best = 0;
  for (size_t k = 1; k < candidates.size(); ++k) best = std::max(best, share(candidates[k]));
  if (asSpecified < 0.5 && best >= 0.75 && best > asSpecified + 0.25) {
    for (size_t k = 1; k < candidates.size(); ++k)
      if (share(candidates[k]) >= best - 0.02)
        out.explanation += (out.explanation.empty() ? "" : " or ") + std::string(candidates[k].name);
    // At a constant camera velocity the next frame's motion is the previous frame's flipped: the
    // two slips predict the same vectors there, and the check cannot tell them apart.
    if (share(candidates[1]) >= best - 0.02 && share(candidates[8]) < best - 0.02 &&
        candidates[8].informative < nextIsMirror)
      out.explanation +=
          " (or pointing to the next frame: where the camera's velocity changes little from frame "
          "to frame the two predict nearly the same vectors, and these frames do not tell them "
          "apart)";
    out.explainedShare = best;
  }
  // A reading of the depth that the motion fits where the depth as written does not: on most of
  // the pixels it decides (at least 1% of those checked, so that a few edge pixels do not name it).
  for (size_t k = 0; k < readings.size(); ++k) {
    const DepthCount& c = depthCounts[k];
    if (c.informative < std::max<long>(20, out.pixels / 100)) continue;
    const double fit = double(c.matched) / double(c.informative),
                 asWritten = double(c.matchedAsWritten) / double(c.informative);
    if (fit >= 0.75 && asWritten < 0.5 && fit > out.depthExplainedShare)
      out.depthExplanation = readings[k].name, out.depthExplainedShare = fit;
  }
  return out;
}

PositionConsistency checkPositions(const std::vector<LayerSet>& frames,
                                   const std::vector<CameraState>& cameras) {
  PositionConsistency out;
  long off = 0;
  // The median ratio from at most about a million pixels (every k-th): a 1080p sequence of 100
  // frames would otherwise hold 200 million ratios.
  size_t all = 0;
  for (const LayerSet& f : frames) all += f.get("depth").pixelCount();
  const size_t every = std::max<size_t>(1, all / 1000000);
  std::vector<float> ratios;
  for (size_t t = 0; t < frames.size(); ++t) {
    const Image &depth = frames[t].get("depth"), &position = frames[t].get("position");
    const CameraState& cam = cameras[t];
    const float pixelAngle = 2.0f * cam.tanHalfFovY / float(cam.height);  // radians per pixel
    for (int y = 0; y < depth.height(); ++y)
      for (int x = 0; x < depth.width(); ++x) {
        const float z = depth.at(x, y);
        const glm::vec3 p(position.at(x, y, 0), position.at(x, y, 1), position.at(x, y, 2));
        if (!(z > 0) || !std::isfinite(z) || !std::isfinite(p.x + p.y + p.z))
          continue;  // sky, or counted as non-finite
        const float stored = cam.viewDepth(p);
        if (size_t(out.pixels++) % every == 0) ratios.push_back(stored / z);
        // Within the pixel's sample (jitter of up to a pixel, or a random point in it) and the
        // storage: a half float holds |p| to about 4.9e-4 |p| (world coordinates far from the
        // origin lose the most), which the depth and pixel tolerances both allow.
        const float storage = 4.9e-4f * glm::length(p);
        glm::vec2 pixel;
        const bool depthOff = !(std::abs(stored - z) <= 0.01f * z + storage + 1e-5f);
        const bool pixelOff = !cam.project(p, pixel) ||
                              glm::length(pixel - glm::vec2(float(x) + 0.5f, float(y) + 0.5f)) >
                                  2.0f + storage / (z * pixelAngle);
        off += depthOff || pixelOff;
      }
  }
  if (out.pixels == 0) return out;
  out.offShare = double(off) / double(out.pixels);
  std::nth_element(ratios.begin(), ratios.begin() + long(ratios.size() / 2), ratios.end());
  out.medianDepthRatio = ratios[ratios.size() / 2];
  return out;
}

bool hasSignal(const Image& image) {
  for (float x : image.raw())
    if (std::isfinite(x) && x != 0.0f) return true;
  return false;
}

bool inputEqualsReference(const Image& input, const Image& reference) {
  // Over the input's finite values (a NaN pixel per frame, which the denoisers read as 0, kept an
  // input equal to its reference everywhere else from being found so: a re-trial), at least one.
  const std::span<const float> a = input.raw(), b = reference.raw();
  if (a.size() != b.size()) return false;
  size_t compared = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (!std::isfinite(a[i])) continue;
    if (a[i] != b[i]) return false;
    ++compared;
  }
  return compared > 0;
}

CaptureValidation validateCaptureOutputs(const CaptureDescription& capture,
                                         const std::vector<LayerSet>& references) {
  CaptureValidation v;
  for (const auto& [name, output] : capture.outputs) {
    // What `--denoisers file:NAME` meets frame by frame (the same reader and messages): the first
    // problem of each bad frame.
    std::vector<int> bad, equalsReference;
    std::string first;
    // Mean luminance of the output and of its references over the frames read: an output at
    // another exposure, or display-encoded, scores as a poor denoiser, which it may not be.
    double outputLight = 0, referenceLight = 0;
    for (int t = 0; t < capture.info.frames; ++t) {
      Image color;
      try {
        color = readCaptureOutput(capture, name, t);
      } catch (const Error& e) {
        bad.push_back(t);
        if (first.empty()) first = e.what();
        continue;
      }
      const size_t r = capture.info.hasReference ? size_t(capture.info.referenceOfFrame[size_t(t)])
                                                 : references.size();
      if (r < references.size() && sameValues(color, references[r].get("color")))
        equalsReference.push_back(t);
      if (r < references.size()) {
        outputLight += finiteLuminanceSum(color);
        referenceLight += finiteLuminanceSum(references[r].get("color"));
      } else if (!capture.info.hasReference) {  // no references: the noisy inputs average to them
        try {
          const double input = finiteLuminanceSum(readCaptureFrame(capture, t).get("color"));
          outputLight += finiteLuminanceSum(color);
          referenceLight += input;
        } catch (const Error&) {  // an unreadable frame is the frame checks' finding
        }
      }
    }
    v.checks.push_back(check(
        "output." + name, double(bad.size()), 0, 0, "frames",
        bad.empty() ? "" : "frame(s) " + frameList(bad) + " cannot be scored; first: " + first));
    if (!output.timingProblem.empty())
      v.checks.push_back(check("output." + name + ".timing", 1, 0, 0, "", output.timingProblem));
    // On every frame it is no denoiser's output: a run fails its pair (on every frame scored).
    if (!equalsReference.empty())
      v.checks.push_back(check(
          "output." + name + ".equalsReference", double(equalsReference.size()), 0,
          double(capture.info.frames) - 1, "frames",
          "frame(s) " + frameList(equalsReference) +
              " equal their reference value for value: a perfect score there (is the "
              "reference wired in as the output?); fails when every frame does, as a run fails "
              "the pair when every frame it scores does"));
    if (referenceLight > 0) {  // a black output is the extreme case: a ratio of 0
      const double ratio = std::max(outputLight, 0.0) / referenceLight;
      const bool againstReference = capture.info.hasReference;
      // Fails brighter than 2x the references (an exposure or an encoding: no denoiser adds that
      // much light) and black; darker is a warning, since a denoiser that clamps fireflies loses
      // light (hybrid keeps about 0.3x of hard_light's), and so is anything against the noisy
      // inputs, whose mean over a short sequence is itself uncertain.
      const bool failable = ratio == 0 || (againstReference && ratio > 1);
      v.checks.push_back(check(
          "output." + name + (againstReference ? ".brightnessVsReference" : ".brightnessVsInput"),
          ratio > 0 ? std::max(ratio, 1 / ratio) : std::numeric_limits<double>::infinity(), 1.25,
          failable ? 2 : kSoft, "x",
          "mean luminance " + number(ratio) + "x the " +
              (againstReference ? "references'" : "noisy inputs' (there are no references)") +
              (ratio > 0 && ratio < 0.99 ? " (" + number(1 / ratio) + "x darker, the value)"
                                         : std::string()) +
              " over its frames: outputs are linear radiance at the input's exposure; another "
              "exposure, a tone map or display encoding (sRGB, gamma) would be scored as the "
              "denoiser's error" +
              (ratio > 0 && ratio < 1
                   ? std::string("; a denoiser that clamps fireflies loses light "
                                 "too, so darker is a warning")
                   : std::string()) +
              " (a run scores it, with this warning)"));
    }
  }
  // Folders the description does not declare are never scored: said, so a forgotten entry shows.
  v.checks.push_back(
      namesWarning("outputs.undeclared", undeclaredOutputs(capture), "folders", "outputs/ holds ",
                   ", not in capture.json's \"outputs\": never scored until declared there"));
  return v;
}

CaptureValidation validateCapture(const Sequence& sequence, const EvaluationInput& input) {
  const SequenceInfo& info = sequence.info();
  CaptureValidation v;
  const std::vector<std::string> derived = sequence.isCapture() ? sequence.capture().derived : std::vector<std::string>{};
  const std::vector<std::string> given = info.availableLayers();
  auto isGiven = [&](const std::string& layer) { return contains(given, layer) && !contains(derived, layer); };

  // 1. Non-finite values, per layer and channel: guides must be finite, the colour's are counted.
  std::map<std::string, std::map<std::string, long>> bad;  // layer -> channel -> count
  std::map<std::string, std::vector<int>> empty;           // layer -> frames without a finite value
  std::map<std::string, std::string> firstBad;             // layer -> "frame t, pixel (x, y)"
  for (size_t t = 0; t < input.frames.size(); ++t)
    for (const LayerSpec& spec : channels::frameLayers()) {
      const LayerSet& f = input.frames[t];
      if (spec.topLevel || !isGiven(spec.name) || !f.has(spec.name)) continue;
      const Image& img = f.get(spec.name);
      long inFrame = 0;
      for (int c = 0; c < spec.channels(); ++c) {
        long n = 0;
        const auto plane = img.planeSpan(c);
        for (size_t i = 0; i < plane.size(); ++i)
          if (!std::isfinite(plane[i]) && n++ == 0 && !firstBad.count(spec.name))
            firstBad[spec.name] = "frame " + std::to_string(t) + ", pixel (" +
                                  std::to_string(i % size_t(img.width())) + ", " +
                                  std::to_string(i / size_t(img.width())) + ")";
        if (n) bad[spec.name][spec.channelName(c)] += n;
        inFrame += n;
      }
      if (inFrame > 0 && size_t(inFrame) == img.raw().size()) empty[spec.name].push_back(int(t));
    }
  for (const LayerSpec& spec : channels::frameLayers()) {
    if (spec.topLevel || !isGiven(spec.name)) continue;
    const bool colour = spec.name == "color" || spec.name == "diffuse" || spec.name == "specular" || spec.name == "emission";
    long total = 0;
    std::string detail;
    for (const auto& [channel, n] : bad[spec.name]) {
      total += n;
      detail += (detail.empty() ? "" : ", ") + channel + " x" + std::to_string(n);
    }
    if (total) detail += "; the first at " + firstBad[spec.name];
    if (colour)
      detail = total ? detail + " (replaced by 0 before a denoiser reads them, and counted per pair)" : "";
    else if (total)
      detail += " (a guide must be finite)";
    v.checks.push_back(check("nonFinite." + spec.name, double(total), 0, colour ? kSoft : 0, "values", detail));
    // A frame with no finite value of a colour layer holds no data: replaced by 0 it would be
    // denoised and scored (a flawless, flicker-free black) as if it were a measurement.
    if (colour) {
      const std::vector<int>& frames = empty[spec.name];
      const std::string which = frameList(frames);
      v.checks.push_back(
          check("nonFinite." + spec.name + ".wholeFrames", double(frames.size()), 0, 0, "frames",
                frames.empty()
                    ? ""
                    : "frame(s) " + which + " hold no finite " + spec.name + " value: no data"));
    }
  }

  // 2. Ranges: unit normals, positive depth, albedos and roughness in [0, 1].
  long surface = 0, notUnit = 0, negativeDepth = 0, depthValues = 0;
  // Of the pixels whose normal is not unit: those with no normal at all at their frame's largest
  // depth, the far plane an engine writes where nothing was hit (its sky then reads as a surface).
  long zeroAtFar = 0, unitNearer = 0;  // unitNearer: good normals well in front of that depth
  float farDepth = 0;
  std::map<std::string, std::pair<long, long>> range;  // layer -> (outside, values)
  for (const LayerSet& f : input.frames) {
    const Image &depth = f.get("depth"), &normal = f.get("normal");
    float largest = 0;
    for (float z : depth.raw())
      if (std::isfinite(z)) largest = std::max(largest, z);
    for (size_t i = 0; i < depth.pixelCount(); ++i) {
      const float z = depth.raw()[i];
      ++depthValues;
      negativeDepth += z < 0;
      if (!(z > 0) || !std::isfinite(z)) continue;
      ++surface;
      const double len = std::sqrt(double(normal.plane(0)[i]) * normal.plane(0)[i] +
                                   double(normal.plane(1)[i]) * normal.plane(1)[i] +
                                   double(normal.plane(2)[i]) * normal.plane(2)[i]);
      const bool off = !(std::abs(len - 1) <= 0.02);  // half floats hold a unit vector to ~1e-3
      notUnit += off;
      if (off && len < 0.02 && z == largest) ++zeroAtFar, farDepth = z;
      unitNearer += !off && z < 0.5f * largest;
    }
    for (const char* layer : {"albedo", "specAlbedo", "roughness"}) {
      if (!isGiven(layer)) continue;
      auto& [outside, values] = range[layer];
      for (float x : f.get(layer).raw()) {
        ++values;
        outside += std::isfinite(x) && (x < -1e-3f || x > 1.001f);
      }
    }
  }
  std::string unitDetail = "normals must be unit length (| |n| - 1 | <= 0.02)";
  if (notUnit > 0 && zeroAtFar >= notUnit / 2 && unitNearer > 0)
    unitDetail += "; " + std::to_string(zeroAtFar) + " of the " + std::to_string(notUnit) +
                  " have no normal at their frame's largest depth (" + number(farDepth) +
                  "): sky written as the far plane? Write depth 0 where nothing was hit";
  v.checks.push_back(check("normal.unitLength", surface ? double(notUnit) / double(surface) : 0, 0,
                           0.01, "share of surface pixels", unitDetail));
  v.checks.push_back(check("depth.positive", depthValues ? double(negativeDepth) / double(depthValues) : 0, 0, 0,
                           "share of pixels", "view depth is positive on surfaces and 0 where there is none (sky)"));
  for (const auto& [layer, counts] : range)
    v.checks.push_back(check(layer + ".range", counts.second ? double(counts.first) / double(counts.second) : 0, 0, 0.001,
                             "share of values", layer + " must lie in [0, 1]"));

  // 2b. Positions against depth and the camera: a stored world position must lie where the pixel's
  // view depth and its camera put it (the same units, the same space). A position layer in other
  // units or another space would silently steer every denoiser that reads it.
  if (isGiven("position")) {
    const PositionConsistency pc = checkPositions(input.frames, info.cameras);
    if (pc.pixels == 0)
      v.checks.push_back(
          unchecked("position.consistency",
                    "no surface pixel (depth > 0): the positions could not be checked"));
    else
      v.checks.push_back(
          check("position.consistency", pc.offShare, 0.05, 0.25,
                "share of surface pixels off by more than 2 px or 1% of the depth",
                "the stored world position against the one rebuilt from depth and camera; median "
                "view depth of "
                "the stored positions / depth layer " +
                    number(pc.medianDepthRatio) +
                    (std::abs(pc.medianDepthRatio - 1) > 0.01 ? " (another unit or space?)" : "")));
  }

  // 3. Motion against depth and the two cameras, on static surfaces.
  std::vector<int> cuts;
  std::set<int> moving;
  for (const SequenceEvent& e : info.events) {
    if (e.kind == EventKind::CameraCut) cuts.push_back(e.frame);
    if (e.kind == EventKind::ObjectMoves && e.meshId >= 0) moving.insert(e.meshId);
  }
  if (!isGiven("meshId")) moving.clear();  // no ids to tell objects apart: every surface counts
  if (info.frames < 2) {
    v.checks.push_back(
        unchecked("motion.consistency", "one frame: nothing to check motion against"));
  } else if (const MotionConsistency m = checkMotion(
                 input.frames, info.cameras, cuts, 1.0, moving,
                 sequence.isCapture()
                     ? depthReadings(sequence.capture().nearPlane, sequence.capture().farPlane)
                     : depthReadings(0, 0));
             m.pixels == 0) {
    v.checks.push_back(
        unchecked("motion.consistency",
                  "no static surface pixel with depth in two consecutive frames: the motion "
                  "vectors could not be checked"));
  } else {
    std::string detail = "mean error " + number(m.meanErrorPx) + " px over " + std::to_string(m.pixels) +
                         " static surface pixels (motion = previous-frame pixel - this pixel, in pixels, x right, y down)";
    if (!m.explanation.empty())
      detail = "the motion vectors look " + m.explanation + " (" + number(m.explainedShare * 100) +
               "% of the pixels with motion fit that); " + detail;
    if (!m.depthExplanation.empty() && m.explanation.empty())
      detail = "the depth layer looks " + m.depthExplanation + " (" +
               number(m.depthExplainedShare * 100) +
               "% of the pixels where that reading moves differently fit the motion with it); " +
               detail;
    else if (m.offShare > 0.25 && m.depthWithinUnit && m.explanation.empty())
      detail +=
          "; every depth lies in (0, 1]: a depth buffer's value rather than view depth?" +
          (sequence.isCapture()
               ? " (read as one with near " + number(sequence.capture().nearPlane) + " and far " +
                     number(sequence.capture().farPlane) +
                     ", capture.json's or the defaults where it gives none, it fits no better: "
                     "give the capture's planes)"
               : std::string());
    // (Not where the depth was found to be read wrongly: the motion predicted from it is then wrong
    // too, and small where the depth reads far.)
    if (m.offShare > 0.05 && m.explanation.empty() && m.depthExplanation.empty() &&
        m.conventionPixels < std::max(20L, m.pixels / 100))
      detail += "; the motion the cameras and depth predict is under 4 px a frame on " +
                std::string(m.conventionPixels == 0 ? "every" : "all but a few") +
                " pixel, too little to tell a sign, scale or unit slip from an error: not tried (a "
                "larger resolution or a faster move would)";
    if (m.worstFrameShare > 0.05)
      detail += "; worst at frame " + std::to_string(m.worstFrame) + " (" +
                number(m.worstFrameShare * 100) + "% off)";
    // One frame off where the others fit: that frame's vectors or its camera, and a frame missing
    // before it (the rest renumbered: its camera two steps from the one before, its vectors one,
    // read as vectors "scaled by 1/2") as likely as a slip of the vectors.
    if (m.worstFrameShare > 0.5 && m.offShare < 0.5 * m.worstFrameShare)
      detail += "; most frames fit: where frame " + std::to_string(m.worstFrame) +
                " is off alone, its vectors or camera are, or a frame is missing before it (its "
                "camera then steps twice as far as its vectors)";
    if (!isGiven("meshId") && !moving.empty()) detail += "; no meshId, so moving objects count too";
    // Blender's Vector pass with motion blur on is not the frame-to-frame motion (a technical
    // artist's capture failed with 99% of its pixels off and no hint).
    if (m.offShare > 0.25 && m.explanation.empty() && sequence.isCapture() &&
        sequence.capture().source.is_object() &&
        sequence.capture().source.value("importer", "") == "arena import blender")
      detail +=
          "; from Blender: was motion blur on? With it, Cycles' Vector pass does not hold "
          "the motion from one frame to the next (Render Properties > Motion Blur: off)";
    v.checks.push_back(check("motion.consistency", m.offShare, 0.05, 0.25, "share of pixels off by more than 1 px", detail));
  }

  // 4. Colour against its parts, when both are given.
  if (isGiven("color") && isGiven("diffuse") && isGiven("specular") && isGiven("albedo") && isGiven("specAlbedo")) {
    // The denoisers read the parts, remodulated, and not the colour: parts that describe another
    // image rank them on that image. The commonest slip, a part written before demodulation (the
    // engine's lit diffuse, not diffuse / albedo), is tried and named, and fails the capture.
    long mismatched = 0, values = 0, diffuseLit = 0, specularLit = 0, bothLit = 0;
    // Without an emission layer (then zero): the colour's light the parts lack, as a share of
    // all of it. A visible light is a few pixels but much of the light; the denoisers, which
    // remodulate without it, would lose it.
    const bool emissionDerived = !isGiven("emission");
    double colourLight = 0, lacking = 0;
    const auto off = [](float colour, float sum) {
      return std::abs(colour - sum) > 1e-3f * (std::abs(colour) + 1e-2f);
    };
    for (const LayerSet& f : input.frames) {
      const Image &c = f.get("color"), &a = f.get("albedo"), &d = f.get("diffuse"), &sa = f.get("specAlbedo"),
                  &s = f.get("specular"), &e = f.get("emission");
      for (size_t i = 0; i < c.raw().size(); ++i) {
        const float colour = c.raw()[i], ad = a.raw()[i] * d.raw()[i],
                    ss = sa.raw()[i] * s.raw()[i], em = e.raw()[i];
        ++values;
        mismatched += off(colour, ad + ss + em);
        diffuseLit += off(colour, d.raw()[i] + ss + em);
        specularLit += off(colour, ad + s.raw()[i] + em);
        bothLit += off(colour, d.raw()[i] + s.raw()[i] + em);
        if (emissionDerived && std::isfinite(colour) && std::isfinite(ad + ss)) {
          colourLight += std::max(0.0f, colour);
          lacking += std::max(0.0f, colour - (ad + ss));
        }
      }
    }
    const double share = values ? double(mismatched) / double(values) : 0;
    std::string detail =
        "color = albedo * diffuse + specAlbedo * specular + emission (transmission, volumes and "
        "other lobes end up in the difference)";
    // A slip is named where it leaves at most a tenth of the values the parts miss unexplained
    // and explains at least 0.5% of all values; of those, the one leaving the fewest, a single
    // part before both on a tie (where specular is about 0, "both lit" fits as well as "diffuse
    // lit", and would ask for a division the specular does not need).
    const std::pair<long, const char*> slips[] = {
        {diffuseLit,
         "diffuse holds lit radiance, not demodulated (color = diffuse + specAlbedo * specular + "
         "emission): write diffuse / albedo"},
        {specularLit,
         "specular holds lit radiance, not demodulated (color = albedo * diffuse + specular + "
         "emission): write specular / specAlbedo"},
        {bothLit,
         "diffuse and specular hold lit radiance, not demodulated (color = diffuse + specular + "
         "emission): write diffuse / albedo and specular / specAlbedo"}};
    bool named = false;
    const std::pair<long, const char*>* fittest = nullptr;
    if (share > 0.01)
      for (const auto& slip : slips)
        if (double(slip.first) <= 0.1 * double(mismatched) &&
            mismatched - slip.first >= values / 200 && (!fittest || slip.first < fittest->first))
          fittest = &slip;
    if (fittest) {
      detail = fittest->second + std::string(" (") +
               number(100.0 * double(mismatched - fittest->first) / double(values)) +
               "% of the values fit that, against the parts as given); the denoisers read the "
               "parts, so they would be ranked on another image than this colour";
      named = true;
    }
    if (!named && share > 0.01)
      detail +=
          "; the denoisers read the parts, not this colour: where they differ, they are ranked on "
          "the parts' image";
    v.checks.push_back(
        check("color.equalsParts", share, 0.01, named ? 0.01 : kSoft, "share of values", detail));
    if (emissionDerived && colourLight > 0 && !named)
      v.checks.push_back(check(
          "emission.missing", lacking / colourLight, 0.01, kSoft, "share of the colour's light",
          "the colour's light that albedo * diffuse + specAlbedo * specular lacks, with no "
          "emission "
          "layer given: a visible light or sky there is lost to every denoiser that remodulates "
          "the parts (they are given no emission); give the emission layer"));
  }

  // 4a. The importer's own figures, where capture.json's source records them (arena import
  // blender): each a share the import could not help but compute, checked here.
  // A figure the importer wrote is a share in [0, 1]: one edited to anything else (a string, -5,
  // null) is no figure to pass on (it passed at -5, or dropped its check), so it fails its check.
  const auto sourceFigure = [&](const char* key) -> std::optional<double> {
    if (!sequence.isCapture()) return std::nullopt;
    const nlohmann::json& source = sequence.capture().source;
    if (!source.is_object() || !source.contains(key)) return std::nullopt;
    const nlohmann::json& value = source[key];
    // emissionBeyondEmitEnv is a sum over Combined's and may pass 1 (a transparent film's bright
    // sky is in Env, not in Combined): finite and not negative; the other a share of pixels.
    const double most =
        std::string(key) == "emissionBeyondEmitEnv" ? std::numeric_limits<double>::max() : 1.0;
    if (!value.is_number() || !(value.get<double>() >= 0 && value.get<double>() <= most))
      return std::numeric_limits<double>::quiet_NaN();
    return value.get<double>();
  };
  // Light kept in emission beyond what was emitted (Blender: Combined minus the two lobes, minus
  // Emit and Env): volumes and transmission, lobes a capture has no signal for. A denoiser of
  // diffuse and specular adds emission back unfiltered, noise and all (a trial's volume put 12% of
  // the colour there, and nothing said so).
  // A figure that is no share fails its check, naming the field (check() passes a NaN).
  const auto figureCheck = [](const char* name, double share, double warnAbove, const char* unit,
                              const char* key, std::string detail) {
    if (std::isnan(share))
      return damagedSourceCheck(name, warnAbove, unit, key,
                                "figure the importer writes (a finite share, 0 or more)");
    return check(name, share, warnAbove, kSoft, unit, std::move(detail));
  };
  if (const auto share = sourceFigure("emissionBeyondEmitEnv"))
    v.checks.push_back(figureCheck(
        "emission.beyondEmitEnv", *share, 0.02, "share of the colour", "emissionBeyondEmitEnv",
        "the colour's light in emission that is neither emitted nor the sky (volumes, "
        "transmission: lobes a capture has no signal for; from Blender also a transparent film, "
        "Film > Transparent): a denoiser of diffuse and specular adds it back unfiltered, its "
        "noise included (capture.json source.emissionBeyondEmitEnv)"));
  // The surface normals the importer renormalised: averaging over edges at more than 1 spp
  // explains a few percent to a sixth (0.027 at 4 spp, 0.15 at 16); most of the frame means a pass
  // that is no unit normal at all, which the renormalising would otherwise hide.
  if (const auto share = sourceFigure("normalsRenormalised"))
    v.checks.push_back(figureCheck(
        "normal.renormalised", *share, 0.5, "share of surface pixels", "normalsRenormalised",
        "normals the importer renormalised (more than 1% off unit length); an edge's average at "
        "more than 1 spp explains a few percent, most of the frame a Normal pass that holds no "
        "unit normals (capture.json source.normalsRenormalised)"));

  // The renders' Cycles settings the importer read (cameras.json "renders"): those a capture
  // should not have and no other check sees (a fixed seed for the noisy frames, adaptive
  // sampling, another pixel filter), each said.
  if (sequence.isCapture() && sequence.capture().source.is_object() &&
      sequence.capture().source.contains("renderDeviations")) {
    const nlohmann::json& deviations = sequence.capture().source["renderDeviations"];
    std::string said;
    bool read = deviations.is_array();
    for (const nlohmann::json& d : read ? deviations : nlohmann::json::array()) {
      read = read && d.is_string();
      if (d.is_string()) said += (said.empty() ? "" : "; ") + d.get<std::string>();
    }
    v.checks.push_back(
        read ? check("render.settings", double(deviations.size()), 0, kSoft, "settings",
                     said.empty() ? "the renders' Cycles settings (capture.json source.renders): "
                                    "the same light in every render, an animated seed, Box 1 "
                                    "px, no adaptive sampling"
                                  : said)
             : damagedSourceCheck("render.settings", 0, "settings", "renderDeviations",
                                  "list of texts (the importer writes one)"));
  }

  // 4b. Signal: a colour layer black in every frame holds no measurement (every method would
  // score a flawless, flicker-free black, or tie at relMSE 1); a few black frames (a fade) warn.
  {
    std::vector<int> black;
    long negative = 0, values = 0;  // below -1e-3 of the frame's mean luminance, as for references
    for (size_t t = 0; t < input.frames.size(); ++t) {
      const Image& c = input.frames[t].get("color");
      if (!hasSignal(c)) black.push_back(int(t));
      Image scratch;  // a NaN pixel would make the frame's mean, and so its threshold, NaN
      negative += negativeValues(finiteInput(c, scratch));
      values += long(c.raw().size());
    }
    v.checks.push_back(check(
        "color.negative", values ? double(negative) / double(values) : 0, 0, kSoft,
        "share of values below -0.001 x the mean luminance",
        "radiance is not negative: the input was filtered, sharpened or offset before capture, or "
        "converted from a wider gamut (a denoiser's input is the renderer's raw estimate)"));
    v.checks.push_back(check(
        "color.blackFrames", double(black.size()), 0, double(input.frames.size()) - 1, "frames",
        black.empty() ? ""
                      : "frame(s) " + frameList(black) +
                            " of the input colour hold no nonzero "
                            "finite value (fails when every frame does: nothing was captured)"));
  }

  // 5. The reference: present, less noisy than the input, its noise floor known.
  if (input.references.empty()) {
    v.checks.push_back(
        check("reference.present", 1, 0, kSoft, "",
              "no reference: the error metrics are absent and the scene is not ranked (the "
              "rankings rank relMSE); the metrics that need none (stabilityFine, "
              "stabilityCoarse, the times) are measured, each with its interval"));
  } else {
    // Which reference frames are black, hold negative radiance, or repeat their input frame.
    // Negative: below -1e-3 of the reference's mean luminance (a filtered or denoised reference
    // carries values like -1e-7 from negative filter lobes; a negated one is negative throughout).
    std::vector<int> black, equal;
    long negative = 0, values = 0;
    for (size_t r = 0; r < input.references.size(); ++r) {
      const Image& c = input.references[r].get("color");
      if (!hasSignal(c)) black.push_back(int(r));
      negative += negativeValues(c);
      values += long(c.raw().size());
    }
    // Equal to the input: frames with signal only (a black frame of a fade is black in both, and
    // color.blackFrames names it).
    int signalFrames = 0;
    for (size_t t = 0; t < input.frames.size(); ++t) {
      const Image& color = input.frames[t].get("color");
      if (!hasSignal(color)) continue;
      ++signalFrames;
      if (inputEqualsReference(color,
                               input.references[size_t(input.referenceOfFrame[t])].get("color")))
        equal.push_back(int(t));
    }
    // An independent half equal to the mean gives a noise floor of exactly 0.
    std::vector<int> halfIsMean;
    for (size_t r = 0; r < input.references.size(); ++r)
      if (input.references[r].has("colorHalf") &&
          sameValues(input.references[r].get("colorHalf"), input.references[r].get("color")))
        halfIsMean.push_back(int(r));
    v.checks.push_back(check(
        "reference.blackFrames", double(black.size()), 0, double(input.references.size()) - 1,
        "references",
        black.empty() ? ""
                      : "reference(s) " + frameList(black) +
                            " hold no nonzero finite value: "
                            "relative errors there measure only the output's own brightness (fails "
                            "when every reference does: nothing to measure against)"));
    v.checks.push_back(check("reference.negative", values ? double(negative) / double(values) : 0,
                             0, 0.001, "share of values below -0.001 x the mean luminance",
                             "radiance is not negative; a negative reference is not one"));
    v.checks.push_back(check(
        "reference.equalsInput", double(equal.size()), 0, std::max(0, signalFrames - 1), "frames",
        equal.empty() ? ""
                      : "frame(s) " + frameList(equal) +
                            " equal their reference value for value: the input scores as perfect "
                            "there (a reference must be rendered apart from the input; fails when "
                            "every frame with a signal does)"));
    // Frames that share a reference must show one picture: a reference named for a frame whose
    // camera moved (one reference too few, the last frame pointed at the one before) scores that
    // frame against another view, and nothing else notices it (the alignment checks judge a frame
    // between two neighbours of other references). Each frame against the first frame naming its
    // reference.
    if (int(info.cameras.size()) == int(input.frames.size())) {
      std::map<int, int> firstOfReference;
      std::vector<std::string> moved;
      double worst = 0;
      for (size_t t = 0; t < input.frames.size(); ++t) {
        const int r = input.referenceOfFrame[t];
        const auto [it, first] = firstOfReference.emplace(r, int(t));
        if (first) continue;
        const size_t a = size_t(it->second);
        const double shift =
            cameraShiftPixels(info.cameras[a], info.cameras[t],
                              std::min(nearDepth(input.frames[a]), nearDepth(input.frames[t])));
        worst = std::max(worst, shift);
        if (shift > 0.25)
          moved.push_back("frame " + std::to_string(t) + " on reference " + std::to_string(r) +
                          " of frame " + std::to_string(a) + " (" + number(shift) + " px)");
      }
      v.checks.push_back(check(
          "reference.sharedAcrossCameras", worst, 0.25, 1.0,
          "px of camera motion between frames sharing a reference",
          moved.empty()
              ? ""
              : listText(moved) +
                    ": the camera moved between frames that reference.ofFrame gives one reference; "
                    "each frame needs the reference of its own view (a reference missing, or "
                    "ofFrame off by one?)"));
    }
    if (sequence.isCapture() && sequence.capture().referenceHasHalf)
      v.checks.push_back(
          check("reference.halfEqualsMean", double(halfIsMean.size()), 0, kSoft, "references",
                halfIsMean.empty() ? ""
                                   : "reference(s) " + frameList(halfIsMean) +
                                         ": colorHalf equals "
                                         "color, so their noise floor reads 0 (no noise, or no "
                                         "independent half)"));
    double roughRatio = 0;
    int counted = 0;
    HighFrequencySums noiseSums;
    double inputError = 0, floorSum = 0;
    // The worst frame of each ratio: a mean over the sequence hides one bad reference (a frame
    // whose reference is as noisy as its input moved a 12-frame mean by a tenth of the threshold).
    // Warnings only: one frame whose input is itself nearly converged (a sky, a fade) reads high
    // with a good reference, and refusing the capture for it would be wrong.
    double worstRough = 0, worstNoise = 0;
    int worstRoughFrame = -1, worstNoiseFrame = -1;
    // The input's brightness against the references: over the sequence (a reference at another
    // scale or in another colour space), and the frame brightest or darkest beyond its noise.
    Brightness pooled, worstBrightness;
    int worstFactorFrame = -1;
    for (size_t t = 0; t < input.frames.size(); ++t) {
      const LayerSet& ref = input.references[size_t(input.referenceOfFrame[t])];
      const double eps = 0.01 * meanLuminance(ref.get("color")) + 1e-6;
      Image scratch;  // the input as the denoisers read it: one NaN pixel must not void the checks
      const Image& color = finiteInput(input.frames[t].get("color"), scratch);
      const double ri = highFrequencyEnergy(color, eps);
      Brightness b;
      b.add(color, ref.get("color"));
      pooled.add(color, ref.get("color"));
      if (std::abs(b.z()) > 5 && b.factor() > worstBrightness.factor())
        worstBrightness = b, worstFactorFrame = int(t);
      noiseSums.add(color, ref.get("color"), input.frames[t]);
      if (ri > 0) {
        const double ratio = highFrequencyEnergy(ref.get("color"), eps) / ri;
        roughRatio += ratio;
        ++counted;
        if (ratio > worstRough) worstRough = ratio, worstRoughFrame = int(t);
      }
      if (input.referenceNoiseKnown) {
        const double floor = referenceRelMse(ref.get("color"), ref.get("colorVar"));
        const double error = linearError(color, ref.get("color"), &ref.get("colorVar")).relMse;
        floorSum += floor;
        inputError += error;
        if (error > 0 && floor / error > worstNoise)
          worstNoise = floor / error, worstNoiseFrame = int(t);
      }
    }
    // Each frame's input against the references of the frames before and after it: references
    // written one frame late (or early) score every method against the wrong image, and favour
    // the methods that lag. A frame is judged only between two neighbours: a misaligned reference
    // puts its input on one neighbour's, a noisy own reference (or a periodic texture moving by
    // its period) makes both look nearer, and says nothing of alignment. Frames whose neighbours
    // share their reference (a still capture with one reference) decide nothing.
    const int frames = int(input.frames.size());
    std::vector<std::array<ReferenceFit, 2>> fits(size_t(std::max(frames, 0)));  // [before, after]
    for (int t = 1; t + 1 < frames; ++t)
      for (int side = 0; side < 2; ++side) {
        const size_t own = size_t(input.referenceOfFrame[size_t(t)]),
                     other = size_t(input.referenceOfFrame[size_t(t + (side ? 1 : -1))]);
        if (own == other) continue;
        const LayerSet &a = input.references[own], &b = input.references[other];
        const bool variances = input.referenceNoiseKnown && a.has("colorVar") && b.has("colorVar");
        Image scratch;
        fits[size_t(t)][size_t(side)].add(
            finiteInput(input.frames[size_t(t)].get("color"), scratch), a.get("color"),
            b.get("color"), variances ? &a.get("colorVar") : nullptr,
            variances ? &b.get("colorVar") : nullptr);
      }
    for (int side = 0; side < 2; ++side) {
      std::vector<int> onOther;
      int onOwn = 0;
      ReferenceFit onOtherFit;  // the frames on the other reference
      for (int t = 1; t + 1 < frames; ++t) {
        const ReferenceFit &fit = fits[size_t(t)][size_t(side)],
                           &opposite = fits[size_t(t)][size_t(1 - side)];
        if (fit.onOther() && !opposite.onOther()) {
          onOther.push_back(t);
          onOtherFit.add(fit);
        }
        onOwn += fit.onOwn();
      }
      const double z = onOtherFit.z();
      const int decided = int(onOther.size()) + onOwn;
      const std::string neighbour = side == 0 ? "before" : "after";
      // One frame alone is no pattern (a reference re-rendered at another sample count beside
      // it); and without the references' variances a less converged reference beside a better
      // one reads as this, so the check then warns rather than refuses.
      const bool pattern = onOther.size() >= 2;
      v.checks.push_back(check(
          "reference.alignment." + neighbour, pattern ? double(onOther.size()) / decided : 0.0, 0.2,
          onOtherFit.noiseKnown ? 0.5 : kSoft,
          "share of frames nearer the reference of the frame " + neighbour + " than their own",
          onOther.empty()
              ? (decided ? ""
                         : "not decided: no frame's neighbouring references differ beyond the "
                           "input's noise (a still camera: misaligned or not, they are one image)")
          : !pattern
              ? "frame " + frameList(onOther) + " alone lies on the reference of the frame " +
                    neighbour + " (one frame is no pattern: a reference of other noise beside it?)"
              : "frame(s) " + frameList(onOther) + " lie on the reference of the frame " +
                    neighbour + ", " + std::to_string(onOther.size()) + " of the " +
                    std::to_string(decided) + " frames decided (" + number(-z) +
                    " standard errors nearer it than their own): the references look one frame " +
                    (side == 0
                         ? "ahead of their inputs (each holds the frame after's image: rendered "
                           "after the scene advanced past its frame?); every "
                           "error metric would then count a frame's motion as error, the most "
                           "against the methods that lag"
                         : "behind their inputs (each holds the frame before's image: rendered "
                           "before the scene advanced to its frame?); every error metric would "
                           "then favour the methods that lag") +
                    (onOtherFit.noiseKnown
                         ? ""
                         : " (a warning: without the references' colorVar, a less "
                           "converged reference beside better ones can read so)")));
    }
    // Frame t on the reference after it and frame t + 1 on the one before: two frames (or their
    // references) swapped, which each side's check above takes for one frame alone. Frames whose
    // files carry their number are refused on reading; these did not.
    std::vector<int> swapped;
    bool swapNoiseKnown = true;
    for (int t = 1; t + 2 < frames; ++t)
      if (fits[size_t(t)][1].onOther() && fits[size_t(t + 1)][0].onOther()) {
        swapped.push_back(t);
        swapNoiseKnown =
            swapNoiseKnown && fits[size_t(t)][1].noiseKnown && fits[size_t(t + 1)][0].noiseKnown;
      }
    std::string pairs;
    for (int t : swapped)
      pairs += (pairs.empty() ? "" : ", ") + std::to_string(t) + " and " + std::to_string(t + 1);
    v.checks.push_back(
        check("reference.alignment.swapped", double(swapped.size()), 0, swapNoiseKnown ? 0 : kSoft,
              "pairs of frames",
              swapped.empty()
                  ? ""
                  : "frames " + pairs +
                        " each lie on the other's reference: two frames, or their references, "
                        "swapped (frame files numbered out of order?); each is scored against the "
                        "other's image"));
    const auto worstFrame = [&](const std::string& name, double value, int frame, double warn,
                                double fail, const std::string& unit) {
      v.checks.push_back(check(
          name, value, warn, fail, unit,
          frame < 0
              ? ""
              : "worst at frame " + std::to_string(frame) + " (" +
                    Sequence::referencePath({}, input.referenceOfFrame[size_t(frame)]).string() +
                    ")"));
    };
    const std::string causes =
        " (a noisy input averages to its reference: an exposure, a scale or a colour space differs "
        "between "
        "them, or the input is clamped or biased)";
    v.checks.push_back(
        check("reference.brightnessVsInput", std::abs(pooled.z()) > 5 ? pooled.factor() : 1.0, 1.1,
              2.0, "factor between mean luminances over the sequence",
              std::abs(pooled.z()) > 5 ? "over the sequence, " + pooled.text() + causes : ""));
    v.checks.push_back(check(
        "reference.brightnessVsInput.worstFrame", worstBrightness.factor(), 1.1, kSoft,
        "factor between mean luminances, worst frame",
        worstFactorFrame < 0
            ? ""
            : "frame " + std::to_string(worstFactorFrame) + ": " + worstBrightness.text() + causes +
                  "; one frame can also miss the rare bright paths of a 1-spp input"));
    if (counted == 0)
      v.checks.push_back(
          unchecked("reference.roughnessVsInput",
                    "the input has no high-frequency energy on any frame: nothing to compare the "
                    "reference's smoothness with"));
    else
      v.checks.push_back(
          check("reference.roughnessVsInput", roughRatio / counted, 0.5, 1.0,
                "ratio of high-frequency energy, reference / input",
                "a converged reference is far smoother than a noisy input; above 1 it is noisier"));
    if (counted > 0)
      worstFrame("reference.roughnessVsInput.worstFrame", worstRough, worstRoughFrame, 0.5, kSoft,
                 "ratio of high-frequency energy, reference / input");
    // The reference's pixel noise against the input's with the signal cancelled: a reference of N
    // samples over a 1-spp input reads about 1/N. A capture author's reference of 1 sample declared
    // as 4096 read 0.999 on roughnessVsInput (a warning) and was ranked on; it reads about 1 here.
    // Fails where it reads as at most about 2.5x the input's samples while 16x or more are
    // declared; warns beyond 8x what the declared samples give a 1-spp input (and above 0.1).
    if (const double noiseRatio = noiseSums.ratio();
        !std::isfinite(noiseRatio) && !info.referenceSpp.empty()) {
      v.checks.push_back(unchecked("reference.noiseVsDeclared",
                                   "no pixel of a flat surface shows the input's noise: nothing to "
                                   "compare the references' noise with"));
    } else if (!info.referenceSpp.empty()) {
      const int declared = *std::min_element(info.referenceSpp.begin(), info.referenceSpp.end());
      const double implied =
          noiseRatio > 0 ? 1 / noiseRatio : std::numeric_limits<double>::infinity();
      v.checks.push_back(check(
          "reference.noiseVsDeclared", std::max(noiseRatio, 0.0), std::max(8.0 / declared, 0.1),
          declared >= 16 ? 0.4 : kSoft, "reference noise / input noise, high frequencies",
          noiseRatio * declared > 8 && noiseRatio > 0.1
              ? "the references' pixel noise is " + number(noiseRatio) +
                    " of the input's (their high frequencies against the input's, where the "
                    "picture cancels): what about " +
                    number(implied) +
                    "x the input's samples give, while their fewest declared is " +
                    std::to_string(declared) +
                    " (a reference rendered with fewer samples than "
                    "capture.json says?)"
              : ""));
    }
    if (input.referenceNoiseKnown && !(inputError > 0)) {
      v.checks.push_back(unchecked(
          "reference.noiseVsInput",
          "the input equals the reference: no input error to compare its noise floor with"));
    } else if (input.referenceNoiseKnown) {
      const double ratio = floorSum / inputError;
      v.checks.push_back(check("reference.noiseVsInput", ratio, 0.1, 1.0, "reference relMSE floor / input relMSE",
                               "reference noise floor " + number(floorSum / double(input.frames.size())) +
                                   " (from its variance or independent half)"));
      worstFrame("reference.noiseVsInput.worstFrame", worstNoise, worstNoiseFrame, 0.1, kSoft,
                 "reference relMSE floor / input relMSE");
    } else {
      v.checks.push_back(check("reference.noiseFloorKnown", 1, 0, kSoft, "",
                               "the reference has neither colorVar nor colorHalf: its noise floor is unknown, and "
                               "relMseCorrected subtracts nothing"));
    }
  }

  if (sequence.isCapture()) {
    // 6. What the folder holds beyond the description: never read, so a typo or a stray frame is
    // said rather than silently ignored.
    const CaptureDescription& c = sequence.capture();
    v.checks.push_back(
        namesWarning("channels.unknown", withLikelyNames(c.unknownChannels, c.layers), "channels",
                     captureFramePath(c.dir, 0).filename().string() + " holds ",
                     ", which no layer names (docs/captures.md lists them): ignored"));
    v.checks.push_back(
        namesWarning("files.unexpected", undescribedEntries(c), "files", "the folder holds ",
                     ", which capture.json does not describe (a frame beyond `frames`, a "
                     "reference no frame names): never read"));

    // 7. Jitter: built-in denoisers assume samples at pixel centres.
    double maxJitter = 0;
    for (const auto& j : sequence.capture().jitter) maxJitter = std::max({maxJitter, std::abs(j[0]), std::abs(j[1])});
    v.checks.push_back(check("jitter", maxJitter, 0, kSoft, "px",
                             maxJitter > 0 ? "jittered frames: the built-in denoisers assume samples at pixel centres"
                                           : ""));
  }

  // 8. Events the frames contradict. An object_moves event whose meshId no frame's meshId layer
  // holds: its window then measures only where the reference changed, not the object's trail. A
  // camera_cut where the camera moves no more than on its neighbouring frames: every denoiser's
  // history is thrown away there for nothing, and the old-view leak has no old view to measure.
  std::vector<std::string> noObject, noCut;
  // A camera's step into frame t: how far its eye moved and how far its view turned (radians).
  const auto step = [&](size_t t) {
    const CameraState &a = info.cameras[t - 1], &b = info.cameras[t];
    const double turn = std::acos(std::clamp(double(glm::dot(a.forward, b.forward)), -1.0, 1.0)) +
                        std::acos(std::clamp(double(glm::dot(a.up, b.up)), -1.0, 1.0));
    return std::array<double, 2>{double(glm::length(b.eye - a.eye)), turn};
  };
  // The largest of the steps into the frames on either side of frame t.
  const auto stepsAround = [&](size_t t) {
    std::array<double, 2> around{0, 0};
    for (const size_t n : {t - 1, t + 1})
      if (n >= 1 && n < info.cameras.size())
        for (const std::array<double, 2> neighbour = step(n); size_t k : {size_t(0), size_t(1)})
          around[k] = std::max(around[k], neighbour[k]);
    return around;
  };
  for (const SequenceEvent& e : info.events) {
    if (e.kind == EventKind::ObjectMoves && e.meshId >= 0 && isGiven("meshId")) {
      // The id as the trail's test reads it (metrics/ghosting.cpp addTrail: int(v) of plane 0).
      const bool held =
          std::any_of(input.frames.begin(), input.frames.end(), [&](const LayerSet& f) {
            if (!f.has("meshId")) return false;
            const auto plane = f.get("meshId").planeSpan(0);
            return std::any_of(plane.begin(), plane.end(),
                               [&](float id) { return int(id) == e.meshId; });
          });
      if (!held)
        noObject.push_back("frame " + std::to_string(e.frame) + ", meshId " +
                           std::to_string(e.meshId));
    }
    if (e.kind == EventKind::CameraCut && e.frame >= 1 && size_t(e.frame) < info.cameras.size()) {
      const std::array<double, 2> atCut = step(size_t(e.frame));
      const std::array<double, 2> around = stepsAround(size_t(e.frame));
      const float fovBefore = info.cameras[size_t(e.frame - 1)].tanHalfFovY,
                  fovAt = info.cameras[size_t(e.frame)].tanHalfFovY;
      const bool sameFov = std::abs(fovAt - fovBefore) <= 1e-4f * std::max(fovAt, fovBefore);
      if (sameFov && atCut[0] <= 2 * around[0] + 1e-6 && atCut[1] <= 2 * around[1] + 1e-6)
        noCut.push_back("frame " + std::to_string(e.frame));
    }
  }
  v.checks.push_back(namesWarning(
      "events.meshIdAbsent", noObject, "events", "object_moves at ",
      ": no frame's meshId layer holds that id, so the event's window measures only where "
      "the reference changed, not the object's trail (give the id the meshId layer writes)"));
  // The other way round: a cut the cameras show and no event marks (an engine that did not flag
  // it). Every denoiser then carries its history across the change and the run measures no cut.
  // A jump is a step over 4x the steps on either side that is large in itself: the eye moves more
  // than 5% of the viewing distance (the median depth before it; 1 where there is no depth) or the
  // view turns more than 3 degrees, in one frame. A camera that starts, stops or accelerates
  // smoothly changes its step by less.
  std::set<size_t> marked;
  for (const SequenceEvent& e : info.events)
    if (e.kind == EventKind::CameraCut && e.frame >= 0) marked.insert(size_t(e.frame));
  std::vector<std::string> unmarked;
  for (size_t t = 1; t < info.cameras.size() && t < input.frames.size(); ++t) {
    if (marked.count(t)) continue;
    const std::array<double, 2> at = step(t), around = stepsAround(t);
    double distance = 1;
    if (input.frames[t - 1].has("depth")) {
      std::vector<float> depths;
      for (const float z : input.frames[t - 1].get("depth").planeSpan(0))
        if (std::isfinite(z) && z > 0) depths.push_back(z);
      if (!depths.empty()) {
        std::nth_element(depths.begin(), depths.begin() + long(depths.size() / 2), depths.end());
        distance = depths[depths.size() / 2];
      }
    }
    constexpr double kDegree = 3.14159265358979323846 / 180.0;
    const bool moved = at[0] > 0.05 * distance && at[0] > 4 * around[0];
    const bool turned = at[1] > 3 * kDegree && at[1] > 4 * around[1];
    if (!moved && !turned) continue;
    char text[200];
    std::snprintf(text, sizeof text,
                  "frame %zu (the eye moves %.3g and the view turns %.3g degrees; into the frames "
                  "beside it at most %.3g and %.3g degrees)",
                  t, at[0], at[1] / kDegree, around[0], around[1] / kDegree);
    unmarked.push_back(text);
  }
  v.checks.push_back(namesWarning(
      "events.cutUnmarked", unmarked, "frames", "the camera jumps at ",
      " with no camera_cut event there: every denoiser keeps its history across the change and "
      "the run measures no cut (add {\"frame\": N, \"kind\": \"camera_cut\"} to \"events\" if the "
      "shot changes there)"));
  v.checks.push_back(namesWarning(
      "events.cutWithoutMotion", noCut, "events", "camera_cut at ",
      ": the camera moves there no more than on the frames around it; a cut resets every "
      "denoiser's history and has no old view to measure leaking (remove the event if the "
      "shot goes on)"));
  return v;
}

}  // namespace arena
