#include "core/sequence.hpp"

#include <cstdio>

#include "core/atomic_file.hpp"
#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace channels {
const std::vector<LayerSpec>& frameLayers() {
  static const std::vector<LayerSpec> specs = {
      {"diffuse", {"R", "G", "B"}, false},     // demodulated diffuse radiance, 1 spp
      {"specular", {"R", "G", "B"}, false},    // demodulated specular radiance, 1 spp
      {"emission", {"R", "G", "B"}, false},    // emitted radiance at the primary hit (sky included)
      {"color", {"R", "G", "B"}, false},       // albedo*diffuse + specAlbedo*specular + emission
      {"color", {"R", "G", "B"}, false, true}, // the same as plain R,G,B, so any EXR viewer shows it
      {"albedo", {"R", "G", "B"}, false},      // diffuse albedo, (1 - metallic) * base colour
      {"specAlbedo", {"R", "G", "B"}, false},  // GGX directional albedo (Karis 2014 approximation)
      {"normal", {"X", "Y", "Z"}, true},       // world-space shading normal
      {"position", {"X", "Y", "Z"}, false},    // world-space position
      {"depth", {"Z"}, false},                 // linear view depth; 0 for sky
      {"roughness", {}, true},                 // perceptual roughness
      {"meshId", {}, false},                   // object/light index; -1 for sky
      {"materialId", {}, false},               // material index; -1 for sky and lights
      {"motion", {"X", "Y"}, false},           // pixel offset to this point in the previous frame
      {"specHitDist", {}, false},              // the 1-spp sample's first ray length (1e6 on miss)
      {"specHitDistMirror", {}, false},        // oracle: the noise-free mirror ray's (1e6 on miss)
  };
  return specs;
}
const std::map<std::string, std::string>& oracleLayers() {
  static const std::map<std::string, std::string> oracles = {
      {"specHitDistMirror", "the noise-free mirror ray's hit distance"}};
  return oracles;
}
const std::vector<LayerSpec>& referenceLayers() {
  static const std::vector<LayerSpec> specs = {
      {"color", {"R", "G", "B"}, false},       {"color", {"R", "G", "B"}, false, true},
      {"diffuse", {"R", "G", "B"}, false},
      {"specular", {"R", "G", "B"}, false},    {"colorVar", {"R", "G", "B"}, false},
      {"diffuseVar", {"R", "G", "B"}, false},  {"specularVar", {"R", "G", "B"}, false},
      {"colorHalf", {"R", "G", "B"}, false},  // mean of an independent half of the samples
  };
  return specs;
}
const std::vector<LayerSpec>& gradientLayers() {
  // pixel: current-frame pixel of the forward-projected sample; lumNew: re-shaded at frame t with
  // frame t-1's random numbers; lumOld: frame t-1's 1-spp luminance; valid: 1 or 0.
  static const std::vector<LayerSpec> specs = {
      {"gradient", {"pixelX", "pixelY", "lumNew", "lumOld", "valid"}, false},
  };
  return specs;
}
const std::vector<LayerSpec>& lowresLayers() {
  static const std::vector<LayerSpec> specs = {
      {"diffuse", {"R", "G", "B"}, false},    // demodulated diffuse radiance, mean of lowresSpp paths
      {"specular", {"R", "G", "B"}, false},   // demodulated specular radiance, mean of lowresSpp paths
      {"direction", {"X", "Y", "Z"}, false},  // luminance-weighted mean incident direction of the
                                              // diffuse signal (length <= 1: 1 = one direction)
  };
  return specs;
}
}  // namespace channels

json cameraToJson(const CameraState& c) {
  auto v = [](glm::vec3 x) { return json::array({x.x, x.y, x.z}); };
  json m = json::array();
  glm::mat4 view = c.view(), proj = c.projection();
  json jv = json::array(), jp = json::array();
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 4; ++k) {
      jv.push_back(view[i][k]);
      jp.push_back(proj[i][k]);
    }
  return {{"eye", v(c.eye)}, {"forward", v(c.forward)}, {"right", v(c.right)}, {"up", v(c.up)},
          {"tanHalfFovY", c.tanHalfFovY}, {"width", c.width}, {"height", c.height},
          {"view", jv}, {"projection", jp}};
}

CameraState cameraFromJson(const json& j) {
  // Checked field by field (a frame protocol's camera comes from another program): a short array
  // indexed unchecked is undefined behaviour, a missing key nlohmann's own words.
  const auto what = [](const json& x) {
    return x.is_null() ? std::string("nothing") : x.dump().substr(0, 80);
  };
  if (!j.is_object())
    throw Error(
        "a camera must be an object (eye, forward, right, up, tanHalfFovY, width, height), got " +
        what(j));
  auto v = [&](const char* key) {
    const json& a = j.contains(key) ? j[key] : json();
    if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() ||
        !a[2].is_number())
      throw Error(std::string("camera.") + key + ": expected 3 numbers, got " + what(a));
    return glm::vec3(a[0].get<float>(), a[1].get<float>(), a[2].get<float>());
  };
  auto positive = [&](const char* key, bool integer) {
    const json& x = j.contains(key) ? j[key] : json();
    if (!(integer ? x.is_number_integer() : x.is_number()) || !(x.get<double>() > 0))
      throw Error(std::string("camera.") + key + ": expected a positive " +
                  (integer ? "integer" : "number") + ", got " + what(x));
    return x.get<double>();
  };
  CameraState c;
  c.eye = v("eye");
  c.forward = v("forward");
  c.right = v("right");
  c.up = v("up");
  c.tanHalfFovY = float(positive("tanHalfFovY", false));
  c.width = int(positive("width", true));
  c.height = int(positive("height", true));
  c.aspect = float(c.width) / float(c.height);
  return c;
}

namespace {
constexpr std::pair<EventKind, const char*> kEventKindNames[] = {
    {EventKind::LightOff, "light_off"},       {EventKind::LightOn, "light_on"},
    {EventKind::LightChange, "light_change"}, {EventKind::ObjectMoves, "object_moves"},
    {EventKind::CameraCut, "camera_cut"}};
}  // namespace

const char* eventKindName(EventKind kind) {
  for (const auto& [k, name] : kEventKindNames)
    if (k == kind) return name;
  return "unknown";
}

std::optional<EventKind> eventKindFromName(std::string_view name) {
  for (const auto& [k, n] : kEventKindNames)
    if (name == n) return k;
  return std::nullopt;
}

std::vector<std::string> eventKindNameList() {
  std::vector<std::string> out;
  for (const auto& [k, name] : kEventKindNames) out.emplace_back(name);
  return out;
}

std::string eventKindNames() {
  std::string out;
  for (const auto& [k, name] : kEventKindNames) out += (out.empty() ? "" : ", ") + std::string(name);
  return out;
}

json SequenceInfo::toJson() const {
  json cams = json::array();
  for (auto& c : cameras) cams.push_back(cameraToJson(c));
  json evs = json::array();
  for (auto& e : events) {
    json ev = {{"frame", e.frame}, {"kind", eventKindName(e.kind)}, {"what", e.what}};
    if (e.meshId >= 0) ev["meshId"] = e.meshId;
    evs.push_back(ev);
  }
  return {{"format", kSequenceFormatVersion}, {"complete", true}, {"scene", scene},
          {"purpose", purpose}, {"hash", hash}, {"width", width}, {"height", height},
          {"frames", frames}, {"referenceOfFrame", referenceOfFrame}, {"referenceSpp", referenceSpp},
          {"cameras", cams}, {"events", evs}, {"settings", settings},
          {"gradientStratum", kGradientStratum}, {"referenceEstimatedRelMse", referenceEstimatedRelMse},
          {"referenceCapped", referenceCapped}, {"lowresPathsPerSecond", lowresPathsPerSecond},
          {"inputPathsPerSecond", inputPathsPerSecond}};
}

SequenceInfo SequenceInfo::fromJson(const json& j, const std::string& file) {
  try {
    if (j.value("format", 0) != kSequenceFormatVersion)
      throw Error(file + ": sequence format " + std::to_string(j.value("format", 0)) + ", expected " +
                  std::to_string(kSequenceFormatVersion) + " (re-render with `arena render`)");
    if (!j.value("complete", false)) throw Error(file + ": sequence is incomplete (render interrupted?)");
    SequenceInfo s;
    s.scene = j.at("scene").get<std::string>();
    s.purpose = j.value("purpose", "");
    s.hash = j.at("hash").get<std::string>();
    s.width = j.at("width").get<int>();
    s.height = j.at("height").get<int>();
    s.frames = j.at("frames").get<int>();
    s.referenceOfFrame = j.at("referenceOfFrame").get<std::vector<int>>();
    s.referenceSpp = j.at("referenceSpp").get<std::vector<int>>();
    for (auto& c : j.at("cameras")) s.cameras.push_back(cameraFromJson(c));
    for (auto& e : j.at("events")) {
      const std::string kind = e.at("kind").get<std::string>();
      const std::optional<EventKind> k = eventKindFromName(kind);
      if (!k) throw Error(file + ": event kind '" + kind + "': expected one of " + eventKindNames());
      s.events.push_back({e.at("frame").get<int>(), *k, e.value("what", ""), e.value("meshId", -1)});
    }
    s.settings = j.value("settings", json::object());
    s.referenceEstimatedRelMse = j.value("referenceEstimatedRelMse", std::vector<double>(s.referenceSpp.size(), 0.0));
    s.referenceCapped = j.value("referenceCapped", std::vector<bool>(s.referenceSpp.size(), false));
    s.lowresPathsPerSecond = j.value("lowresPathsPerSecond", 0.0);
    s.inputPathsPerSecond = j.value("inputPathsPerSecond", 0.0);
    if (int(s.referenceOfFrame.size()) != s.frames || int(s.cameras.size()) != s.frames)
      throw Error(file + ": per-frame lists do not match the frame count");
    return s;
  } catch (const json::exception& e) {
    throw Error(file + ": malformed sequence description: " + e.what());
  }
}

std::string numberedFileName(const char* prefix, int n, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s_%0*d.exr", prefix, digits, n);
  return buf;
}

fs::path Sequence::framePath(const fs::path& dir, int t) { return dir / numberedFileName("frame", t, 4); }
fs::path Sequence::referencePath(const fs::path& dir, int r) { return dir / numberedFileName("reference", r, 3); }
fs::path Sequence::gradientPath(const fs::path& dir, int t) { return dir / numberedFileName("gradients", t, 4); }
fs::path Sequence::lowresPath(const fs::path& dir, int t) { return dir / numberedFileName("lowres", t, 4); }

std::vector<std::string> SequenceInfo::availableLayers() const {
  if (!layers.empty()) return layers;
  std::vector<std::string> all;
  for (const LayerSpec& spec : channels::frameLayers())
    if (!spec.topLevel) all.push_back(spec.name);
  return all;
}

const CaptureDescription& Sequence::capture() const {
  if (!capture_) throw Error(dir_.string() + ": not a capture");
  return *capture_;
}

Sequence Sequence::open(const fs::path& dir) {
  if (arena::isCapture(dir)) {
    Sequence s;
    s.dir_ = dir;
    auto description = std::make_shared<CaptureDescription>(readCaptureDescription(dir));
    s.info_ = description->info;
    s.capture_ = std::move(description);
    return s;
  }
  fs::path file = dir / "sequence.json";
  if (!fs::exists(file)) {
    if (const std::string render = blenderRenderText(dir); !render.empty()) throw Error(render);
    throw Error(
        dir.string() +
        ": neither a capture (no capture.json, docs/captures.md) nor a rendered sequence (no "
        "sequence.json)");
  }
  Sequence s;
  s.dir_ = dir;
  s.info_ = SequenceInfo::fromJson(parseJsonFile(file.string()), file.string());
  return s;
}

LayerSet Sequence::frame(int t) const {
  if (capture_) return readCaptureFrame(*capture_, t);
  if (t < 0 || t >= info_.frames) throw Error(dir_.string() + ": frame " + std::to_string(t) + " out of range");
  return readExr(framePath(dir_, t), channels::frameLayers(), ExrSize{info_.width, info_.height})
      .layers;
}

LayerSet Sequence::reference(int t) const {
  if (t < 0 || t >= info_.frames) throw Error(dir_.string() + ": frame " + std::to_string(t) + " out of range");
  if (capture_) return readCaptureReference(*capture_, info_.referenceOfFrame[size_t(t)]);
  return readExr(referencePath(dir_, info_.referenceOfFrame[t]), channels::referenceLayers(),
                 ExrSize{info_.width, info_.height})
      .layers;
}

LayerSet Sequence::referenceByIndex(int r) const {
  if (!info_.hasReference) throw Error(dir_.string() + ": the capture has no reference");
  if (capture_) return readCaptureReference(*capture_, r);
  return readExr(referencePath(dir_, r), channels::referenceLayers(),
                 ExrSize{info_.width, info_.height})
      .layers;
}

LayerSet Sequence::gradients(int t) const {
  if (!info_.hasGradients)
    throw Error(dir_.string() + ": the capture has no gradient samples (A-SVGF's re-shaded samples; docs/captures.md)");
  if (capture_) {
    if (t < 1 || t >= info_.frames) throw Error(dir_.string() + ": gradient samples exist for frames 1.." + std::to_string(info_.frames - 1));
    return readExr(captureGradientPath(dir_, t), channels::gradientLayers()).layers;
  }
  if (t < 1 || t >= info_.frames)
    throw Error(dir_.string() + ": gradient samples exist for frames 1.." + std::to_string(info_.frames - 1));
  return readExr(gradientPath(dir_, t), channels::gradientLayers()).layers;
}

LayerSet Sequence::lowres(int t) const {
  if (info_.lowresFactor() <= 0)
    throw Error(dir_.string() + ": the sequence has no low-resolution buffer (render it with --lowres-factor)");
  if (t < 0 || t >= info_.frames) throw Error(dir_.string() + ": frame " + std::to_string(t) + " out of range");
  return readExr(lowresPath(dir_, t), channels::lowresLayers()).layers;
}

}  // namespace arena
