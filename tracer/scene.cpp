#include "tracer/scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <map>
#include <mutex>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/json_reader.hpp"
#include "core/text.hpp"
#include "tracer/asset.hpp"
#include "tracer/scene_state.hpp"

namespace arena {

namespace fs = std::filesystem;

glm::mat4 Transform::matrix() const {
  glm::mat4 m = glm::translate(glm::mat4(1.0f), translate);
  m = glm::rotate(m, glm::radians(rotateDegrees.z), glm::vec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(rotateDegrees.y), glm::vec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(rotateDegrees.x), glm::vec3(1, 0, 0));
  return glm::scale(m, scale);
}

Transform lerp(const Transform& a, const Transform& b, float s) {
  return {glm::mix(a.translate, b.translate, s), glm::mix(a.rotateDegrees, b.rotateDegrees, s),
          glm::mix(a.scale, b.scale, s)};
}

CameraKey lerp(const CameraKey& a, const CameraKey& b, float s) {
  return {glm::mix(a.eye, b.eye, s), glm::mix(a.target, b.target, s), glm::mix(a.up, b.up, s),
          glm::mix(a.fovYDegrees, b.fovYDegrees, s)};
}

LightValue lerp(const LightValue& a, const LightValue& b, float s) {
  return {glm::mix(a.intensity, b.intensity, s), glm::mix(a.color, b.color, s)};
}

namespace {

// Positions, rotations and scales beyond this lose every digit of float precision that the
// tracer needs (and 1e39 is +Inf in float): far larger than any scene, small enough to be safe.
constexpr float kMaxCoordinate = 1e6f;

void requireNonNegative(JsonReader& r, const std::string& key, glm::vec3 v) {
  if (v.x < 0 || v.y < 0 || v.z < 0) r.fail(key, "expected non-negative values");
}

std::string vecText(glm::vec3 v) {
  // Appended piecewise: GCC 12 warns (-Wrestrict, a false positive) on "[" + std::string.
  std::string text = "[";
  text.append(std::to_string(v.x)).append(", ").append(std::to_string(v.y)).append(", ");
  return text.append(std::to_string(v.z)).append("]");
}

void requireBounded(JsonReader& r, const std::string& key, glm::vec3 v, float bound) {
  if (glm::any(glm::greaterThan(glm::abs(v), glm::vec3(bound))))
    r.fail(key, "expected values within +-" + std::to_string(bound) + ", got " + vecText(v));
}

// A camera the tracer can build a basis from: eye != target, `up` non-zero and not parallel to
// the view direction (else the basis has a zero axis and every ray is NaN).
std::string cameraProblem(const CameraKey& c) {
  const glm::vec3 view = c.target - c.eye;
  if (glm::length(view) < 1e-6f) return "target equals the eye";
  if (glm::length(c.up) < 1e-6f) return "up is the zero vector";
  const float sine = glm::length(glm::cross(glm::normalize(view), glm::normalize(c.up)));
  if (!(sine > 1e-3f))
    return "up " + vecText(c.up) + " is parallel to the view direction " + vecText(view);
  return "";
}

float numberIn(JsonReader& r, const std::string& key, double fallback, double lo, double hi) {
  double v = r.number(key, fallback);
  if (v < lo || v > hi)
    r.fail(key, "expected a value in [" + shortestText(lo) + ", " + shortestText(hi) + "], got " +
                    shortestText(v));
  return float(v);
}

// Every "v x y z" line of an OBJ file holds three numbers that fit a float within
// kMaxMeshCoordinate. tinyobjloader reads "1e39" as +Inf and "nan" as 0 or NaN without a word,
// and a triangle with such a corner vanishes from the render (Embree skips it).
void requireUsableObjVertices(const std::string& text, const std::string& file) {
  std::istringstream lines(text);
  int lineNumber = 0, vertex = 0;
  for (std::string line; std::getline(lines, line);) {
    ++lineNumber;
    std::istringstream fields(line);
    std::string tag;
    if (!(fields >> tag) || tag != "v") continue;
    ++vertex;
    for (int axis = 0; axis < 3; ++axis) {
      std::string token;
      fields >> token;
      char* end = nullptr;
      const double v = std::strtod(token.c_str(), &end);
      if (token.empty() || *end != '\0' || !std::isfinite(v) || std::abs(v) > kMaxMeshCoordinate)
        throw Error(file + ":" + std::to_string(lineNumber) + ": vertex " + std::to_string(vertex) +
                    ": coordinate " + std::to_string(axis + 1) + " is '" + token +
                    "'; expected a finite number within +-1e18 (its triangles would vanish from "
                    "the render)");
    }
  }
}

// Reads "keys": [{frame, step?, ...fields}], each key inheriting unspecified fields from the
// previous one. `readValue` reads the fields into a value that starts as the previous key's.
template <class T, class ReadValue>
Track<T> readTrack(JsonReader& parent, const std::string& key, int frames, T initial,
                   ReadValue readValue) {
  Track<T> track;
  T current = initial;
  for (JsonReader& k : parent.requiredArray(key)) {
    typename Track<T>::Key out;
    out.frame = k.integer("frame");
    out.step = k.boolean("step", false);
    if (out.frame < 0 || out.frame >= frames)
      k.fail("frame", "expected a frame in [0, " + std::to_string(frames - 1) +
                          "] (the sequence has " + std::to_string(frames) + " frames), got " +
                          std::to_string(out.frame));
    if (!track.keys.empty() && out.frame <= track.keys.back().frame)
      k.fail("frame", "keyframes must be strictly increasing in frame");
    readValue(k, current);
    out.value = current;
    track.keys.push_back(out);
    k.rejectUnread();
  }
  if (track.keys.empty()) parent.fail(key, "expected at least one keyframe");
  return track;
}

void readTransform(JsonReader& k, Transform& t) {
  t.translate = k.vec3("translate", t.translate);
  t.rotateDegrees = k.vec3("rotate", t.rotateDegrees);
  t.scale = k.vec3("scale", t.scale);
  requireBounded(k, "translate", t.translate, kMaxCoordinate);
  requireBounded(k, "rotate", t.rotateDegrees, kMaxCoordinate);
  requireBounded(k, "scale", t.scale, kMaxCoordinate);
}

Shape readShape(JsonReader& r, bool allowMesh) {
  std::string s = r.string("shape");
  if (s == "quad") return Shape::Quad;
  if (s == "sphere") return Shape::Sphere;
  if (allowMesh && s == "box") return Shape::Box;
  if (allowMesh && s == "mesh") return Shape::Mesh;
  r.fail("shape", allowMesh ? "expected one of quad, box, sphere, mesh; got '" + s + "'"
                            : "expected quad or sphere for a light; got '" + s + "'");
}

int materialOf(JsonReader& o, const std::map<std::string, int>& materialIndex,
               const std::string& key) {
  std::string m = o.string(key);
  auto it = materialIndex.find(m);
  if (it == materialIndex.end()) o.fail(key, "unknown material '" + m + "' (not in $.materials)");
  return it->second;
}

// "assets:<path>" is in the extracted-asset cache; anything else is relative to the scene file.
fs::path resolveAssetPath(const std::string& file, const fs::path& sceneDir) {
  const std::string prefix = "assets:";
  if (file.rfind(prefix, 0) == 0) return fs::path(assetCacheDir()) / file.substr(prefix.size());
  return sceneDir / file;
}

// Imports an asset, once per process for files in the extracted-asset cache ("assets:" paths):
// those are written once, atomically, by scripts/extract_assets.py and only read afterwards, and
// scenes place them many times (living_room's ten tatami mats) and are parsed many times (the
// scene mutation tests parse each shipped scene hundreds of times). The key holds the import
// settings and the file's size and modification time. Other files are imported every time.
std::shared_ptr<const AssetData> importAsset(const std::string& file, const fs::path& resolved,
                                             const AssetRef& ref) {
  if (file.rfind("assets:", 0) != 0)
    return std::make_shared<const AssetData>(loadAsset(resolved.string(), ref));
  std::error_code ec;
  const auto size = fs::file_size(resolved, ec);
  const auto stamp = fs::last_write_time(resolved, ec).time_since_epoch().count();
  std::string key = resolved.string();
  for (const std::string& part :
       {std::to_string(ref.unitMeters), std::string(1, ref.upAxis), std::to_string(ref.fps),
        std::to_string(size), std::to_string(stamp)})
    key += "|" + part;
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const AssetData>> imported;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = imported.find(key); it != imported.end()) return it->second;
  }
  auto asset = std::make_shared<const AssetData>(loadAsset(resolved.string(), ref));
  std::lock_guard<std::mutex> lock(mutex);
  return imported.emplace(key, asset).first->second;
}

// {"name", "asset": {"file", "unitMeters", "upAxis", "fps"?}, "material"?, "keys"}: imports the
// file, appends its materials to the scene's (named "<object>/<material>") unless "material"
// overrides them all, and hashes every file it read.
void readAssetObject(JsonReader& o, const fs::path& sceneDir,
                     const std::map<std::string, int>& materialIndex, Object& obj, Scene& scene,
                     Hasher& hasher) {
  obj.shape = Shape::Asset;
  JsonReader a = o.child("asset");
  const std::string file = a.string("file");
  const double unit = a.number("unitMeters");
  if (!(unit >= 1e-6 && unit <= 1e6))
    a.fail("unitMeters",
           "expected metres per asset unit in [1e-6, 1e6], got " + std::to_string(unit));
  obj.assetRef.unitMeters = float(unit);
  const std::string up = a.string("upAxis");
  if (up != "y" && up != "z") a.fail("upAxis", "expected \"y\" or \"z\", got '" + up + "'");
  obj.assetRef.upAxis = up[0];
  obj.assetRef.fps = numberIn(a, "fps", 30.0, 1e-3, 1e4);
  const fs::path resolved = resolveAssetPath(file, sceneDir);
  obj.assetRef.file = resolved.string();
  std::error_code ec;
  if (!fs::exists(resolved, ec)) {
    if (file.rfind("assets:", 0) == 0)
      a.fail("file", "asset file not found: " + resolved.string() +
                         " (the extracted-asset cache, $ARENA_ASSET_DIR or <repo>/cache/assets; "
                         "run `bash scripts/setup.sh` to extract the packaged assets)");
    a.fail("file", "asset file not found: " + resolved.string());
  }
  try {
    obj.asset = importAsset(file, resolved, obj.assetRef);
  } catch (const Error& e) {
    a.fail("file", e.what());
  }
  a.rejectUnread();
  hasher.add(obj.asset->contentHash);
  for (const std::string& w : obj.asset->warnings)
    scene.warnings.push_back(resolved.string() + ": " + w);
  obj.material = -1;
  if (o.has("material")) {
    obj.material = materialOf(o, materialIndex, "material");
  } else {
    obj.assetMaterialBase = int(scene.materials.size());
    for (Material m : obj.asset->materials) {
      m.name = obj.name + "/" + m.name;
      scene.materials.push_back(std::move(m));
    }
  }
}

}  // namespace

Scene loadScene(const std::string& path) {
  return parseScene(readText(path), path);
}

Scene parseScene(const std::string& text, const std::string& path) {
  const nlohmann::json doc = parseJsonText(text, path);
  if (!doc.is_object()) throw Error(path + ": $: expected a JSON object at the top level");
  JsonReader root(doc, path);
  Scene scene;
  scene.file = path;
  scene.name = fs::path(path).stem().string();
  // The file's name names the scene's folders in the cache and in a run ("..", a newline or a byte
  // that is not UTF-8 wrote outside the run or stopped it: a bad-input trial).
  if (!isPlainName(scene.name))
    throw Error(path + ": the file's name " + quotedText(scene.name) +
                " cannot name a scene (it names the scene's folders: UTF-8 without spaces, "
                "slashes, commas or control characters, not . or ..); rename the file");
  scene.purpose = root.string("purpose");
  auto res = root.numbers("resolution", 2);
  // Range first: converting 1e39 to int is undefined.
  for (double v : res)
    if (!(v >= 1 && v <= kMaxSceneResolution) || v != std::floor(v))
      root.fail("resolution", "expected two integers [width, height] in [1, " +
                                  std::to_string(kMaxSceneResolution) + "], got " +
                                  shortestText(v));
  scene.width = int(res[0]);
  scene.height = int(res[1]);
  scene.frames = root.integerIn("frames", 1, kMaxSceneFrames);
  scene.seed = uint32_t(root.integerIn("seed", 1, 0, JsonReader::kIntMax));
  scene.maxBounces = root.integerIn("max_bounces", 4, 1, 64);
  const std::string estimator = root.string("reference_estimator", "path");
  if (estimator == "bidirectional")
    scene.referenceEstimator = ReferenceEstimator::Bidirectional;
  else if (estimator != "path")
    root.fail("reference_estimator", "expected path or bidirectional, got '" + estimator + "'");
  if (scene.referenceEstimator == ReferenceEstimator::Bidirectional &&
      scene.maxBounces > kMaxBidirectionalBounces)
    root.fail("max_bounces", "at most " + std::to_string(kMaxBidirectionalBounces) +
                                 " with \"reference_estimator\": \"bidirectional\", got " +
                                 std::to_string(scene.maxBounces));

  if (auto sky = root.optionalChild("sky")) {
    glm::vec3 c = sky->vec3("color", glm::vec3(0.0f));
    scene.skyTop = sky->vec3("top", c);
    scene.skyBottom = sky->vec3("bottom", c);
    requireNonNegative(*sky, "top", scene.skyTop);
    requireNonNegative(*sky, "bottom", scene.skyBottom);
    requireBounded(*sky, "top", scene.skyTop, kMaxRadiance);
    requireBounded(*sky, "bottom", scene.skyBottom, kMaxRadiance);
    sky->rejectUnread();
  }

  JsonReader cam = root.child("camera");
  scene.camera =
      readTrack<CameraKey>(cam, "keys", scene.frames, CameraKey{}, [](JsonReader& k, CameraKey& c) {
        c.eye = k.vec3("eye", c.eye);
        c.target = k.vec3("target", c.target);
        c.up = k.vec3("up", c.up);
        c.fovYDegrees = numberIn(k, "fov", c.fovYDegrees, 1.0, 170.0);
        requireBounded(k, "eye", c.eye, kMaxCoordinate);
        requireBounded(k, "target", c.target, kMaxCoordinate);
        requireBounded(k, "up", c.up, kMaxCoordinate);
        std::string problem = cameraProblem(c);
        if (!problem.empty()) k.fail("up", "expected a usable camera basis: " + problem);
      });
  // Keys can each be fine while the interpolation between them is not (up flipping through zero).
  for (int t = 0; t < scene.frames; ++t) {
    std::string problem = cameraProblem(scene.camera.at(float(t)));
    if (!problem.empty())
      cam.fail("keys", "the interpolated camera at frame " + std::to_string(t) +
                           " is unusable: " + problem);
  }
  cam.rejectUnread();

  std::map<std::string, int> materialIndex;
  JsonReader mats = root.child("materials");
  for (const std::string& name : mats.memberNames()) {
    JsonReader m = mats.child(name);
    Material mat;
    mat.name = name;
    mat.albedo = m.vec3("albedo", mat.albedo);
    if (auto chk = m.optionalChild("checker")) {
      mat.checker = true;
      mat.checkerAlbedo = chk->vec3("albedo");
      if (glm::any(glm::lessThan(mat.checkerAlbedo, glm::vec3(0.0f))) ||
          glm::any(glm::greaterThan(mat.checkerAlbedo, glm::vec3(1.0f))))
        chk->fail("albedo", "expected values in [0, 1]");
      mat.checkerScale = numberIn(*chk, "scale", mat.checkerScale, 1e-3, 1e4);
      chk->rejectUnread();
    }
    mat.roughness = numberIn(m, "roughness", mat.roughness, 0.0, 1.0);
    mat.metallic = numberIn(m, "metallic", mat.metallic, 0.0, 1.0);
    mat.specular = numberIn(m, "specular", mat.specular, 0.0, 1.0);
    mat.emission = m.vec3("emission", mat.emission);
    requireNonNegative(m, "albedo", mat.albedo);
    requireNonNegative(m, "emission", mat.emission);
    requireBounded(m, "emission", mat.emission, kMaxRadiance);
    if (glm::any(glm::greaterThan(mat.albedo, glm::vec3(1.0f))))
      m.fail("albedo", "expected values in [0, 1]");
    m.rejectUnread();
    materialIndex[name] = int(scene.materials.size());
    scene.materials.push_back(mat);
  }

  const fs::path sceneDir = fs::path(path).parent_path();
  Hasher hasher;
  hasher.add(jsonText(doc));
  // Objects and lights share one namespace: events name them ("what"), and asset materials are
  // named "<object>/<material>"; a second use of a name would make either ambiguous.
  std::map<std::string, std::string> namedAt;  // name -> the JSON path that first used it
  auto claimName = [&](JsonReader& r, const std::string& name) {
    auto [it, fresh] = namedAt.emplace(name, r.path());
    if (!fresh)
      r.fail("name", "'" + name + "' is already the name of " + it->second +
                         "; objects and lights need distinct names");
  };
  for (JsonReader& o : root.requiredArray("objects")) {
    Object obj;
    obj.name = o.string("name");
    claimName(o, obj.name);
    if (o.has("asset")) {
      readAssetObject(o, sceneDir, materialIndex, obj, scene, hasher);
    } else {
      obj.shape = readShape(o, true);
      if (obj.shape == Shape::Mesh) {
        obj.meshFile = (sceneDir / o.string("file")).string();
        if (!fs::exists(obj.meshFile)) o.fail("file", "mesh file not found: " + obj.meshFile);
        try {
          // A regular file of bounded size (not /dev/zero).
          const std::string mesh = readText(obj.meshFile, kMaxMeshBytes);
          requireUsableObjVertices(mesh, obj.meshFile);
          // Parsed now, once, from the bytes hashed below: a face it cannot read (an index out of
          // range, a malformed "f" line) is this field's error, not a failure at the first frame.
          obj.mesh = std::make_shared<const MeshData>(parseObjMesh(mesh, obj.meshFile));
          hasher.add(mesh);
        } catch (const Error& e) {
          o.fail("file", e.what());
        }
      }
      obj.material = materialOf(o, materialIndex, "material");
    }
    // A zero scale collapses an object and it vanishes without a word (lights refuse it too): all
    // three for any object; for a quad either of its plane's axes (x, z); for a box or sphere any
    // (a flat one's side faces have no normal). A mesh may be flat along an axis of its own.
    const Shape shape = obj.shape;
    obj.transform = readTrack<Transform>(
        o, "keys", scene.frames, Transform{}, [shape](JsonReader& k, Transform& t) {
          readTransform(k, t);
          const glm::vec3 s = t.scale;
          const bool collapsed = (s.x == 0 && s.y == 0 && s.z == 0) ||
                                 (shape == Shape::Quad && (s.x == 0 || s.z == 0)) ||
                                 ((shape == Shape::Box || shape == Shape::Sphere) &&
                                  (s.x == 0 || s.y == 0 || s.z == 0));
          if (collapsed)
            k.fail("scale",
                   "a scale that collapses the object (a quad needs x and z, a box or sphere every "
                   "component, "
                   "any object one component non-zero), got " +
                       vecText(s));
        });
    o.rejectUnread();
    scene.objects.push_back(std::move(obj));
  }
  for (JsonReader& l : root.optionalArray("lights")) {
    Light light;
    light.name = l.string("name");
    claimName(l, light.name);
    light.shape = readShape(l, false);
    struct LightKey {
      Transform t;
      LightValue v;
    };
    auto track =
        readTrack<LightKey>(l, "keys", scene.frames, LightKey{}, [](JsonReader& k, LightKey& v) {
          readTransform(k, v.t);
          // An emitter emits from the front of its triangles: a zero scale leaves it no area (it is
          // never sampled, and its normals are NaN), a negative one mirrors it and turns its front
          // away. Either would light the scene wrongly and silently.
          if (!(v.t.scale.x > 0 && v.t.scale.y > 0 && v.t.scale.z > 0))
            k.fail(
                "scale",
                "expected every component > 0 for a light (zero leaves it no area, negative turns "
                "its emitting side away), got " +
                    vecText(v.t.scale));
          v.v.intensity = numberIn(k, "intensity", v.v.intensity, 0.0, 1e9);
          v.v.color = k.vec3("color", v.v.color);
          requireNonNegative(k, "color", v.v.color);
          if (v.v.intensity * std::max({v.v.color.x, v.v.color.y, v.v.color.z}) > kMaxRadiance)
            k.fail("color",
                   "expected intensity * color <= " + std::to_string(kMaxRadiance) + " (radiance)");
        });
    for (auto& key : track.keys) {
      light.transform.keys.push_back({key.frame, key.step, key.value.t});
      light.emission.keys.push_back({key.frame, key.step, key.value.v});
    }
    l.rejectUnread();
    scene.lights.push_back(std::move(light));
  }
  auto knownName = [&](const std::string& n) {
    return std::any_of(scene.objects.begin(), scene.objects.end(),
                       [&](auto& o) { return o.name == n; }) ||
           std::any_of(scene.lights.begin(), scene.lights.end(),
                       [&](auto& l) { return l.name == n; });
  };
  for (JsonReader& e : root.optionalArray("events")) {
    SceneEvent ev;
    ev.frame = e.integer("frame");
    const std::string kind = e.string("kind");
    ev.what = e.string("what", "");
    // An event is measured against the frames before it (ghosting's window, a cut's old view): at
    // frame 0 there are none, and the metrics would skip it without a word.
    if (scene.frames < 2)
      e.fail("frame",
             "a scene of one frame has no frame for an event (events lie in frames 1..N-1)");
    if (ev.frame < 1 || ev.frame >= scene.frames)
      e.fail("frame",
             "expected a frame in [1, " + std::to_string(scene.frames - 1) +
                 "] (an event at frame 0 has no earlier frame to be measured against), got " +
                 std::to_string(ev.frame));
    const std::optional<EventKind> parsed = eventKindFromName(kind);
    if (!parsed) e.fail("kind", "expected one of " + eventKindNames() + "; got '" + kind + "'");
    ev.kind = *parsed;
    if (!ev.what.empty() && !knownName(ev.what))
      e.fail("what", "no object or light is named '" + ev.what + "'");
    // What an event names is of its kind: a light's switch or change names a light, a move an
    // object (whose trail the ghosting figures follow: without it they measured the whole frame
    // and said nothing).
    const bool isLight = std::any_of(scene.lights.begin(), scene.lights.end(),
                                     [&](auto& l) { return l.name == ev.what; });
    if (ev.kind == EventKind::ObjectMoves && (ev.what.empty() || isLight))
      e.fail("what", "an object_moves event names the object that moves (one of $.objects)" +
                         (ev.what.empty() ? std::string() : "; '" + ev.what + "' is a light"));
    if ((ev.kind == EventKind::LightOff || ev.kind == EventKind::LightOn ||
         ev.kind == EventKind::LightChange) &&
        !ev.what.empty() && !isLight)
      e.fail("what", "a " + kind + " event names a light (one of $.lights); '" + ev.what +
                         "' is an object");
    for (const SceneEvent& earlier : scene.events)
      if (earlier.frame == ev.frame && earlier.kind == ev.kind && earlier.what == ev.what)
        e.fail("kind", "this event (" + kind + (ev.what.empty() ? "" : " " + ev.what) +
                           " at frame " + std::to_string(ev.frame) + ") is given twice");
    if (ev.kind == EventKind::CameraCut) {
      // A cut is the camera's: it names nothing else, and the camera must jump there, or the
      // recovery and old-view figures would measure a cut that never happened.
      if (!ev.what.empty())
        e.fail("what", "a camera_cut names no object or light; got '" + ev.what + "'");
      if (!scene.camera.stepsAt(ev.frame))
        e.fail("frame", "a camera_cut at frame " + std::to_string(ev.frame) +
                            " needs a camera key there with \"step\": true; $.camera.keys has none "
                            "(the view would not cut)");
    }
    e.rejectUnread();
    scene.events.push_back(ev);
  }
  for (JsonReader& c : root.optionalArray("credits")) {
    Credit credit;
    credit.asset = c.string("asset");
    credit.author = c.string("author");
    credit.license = c.string("license");
    credit.source = c.string("source", "");
    c.rejectUnread();
    scene.credits.push_back(credit);
  }
  root.rejectUnread();
  if (scene.objects.empty() && scene.lights.empty())
    root.fail("objects", "expected at least one object or light");
  // Something must emit at some frame (a light switched off for a while is a scene's event, one
  // never on a mistake): a black reference leaves every relative metric without meaning.
  auto emits = [](glm::vec3 c) { return std::max({c.x, c.y, c.z}) > 0.0f; };
  bool emitting = emits(scene.skyTop) || emits(scene.skyBottom);
  for (const Light& light : scene.lights)
    for (const auto& key : light.emission.keys)
      emitting |= key.value.intensity > 0.0f && emits(key.value.color);
  for (const Object& obj : scene.objects) {
    if (obj.material >= 0) {
      emitting |= emits(scene.materials[size_t(obj.material)].emission);
    } else if (obj.asset) {  // the asset's own materials
      for (size_t i = 0; i < obj.asset->materials.size(); ++i)
        emitting |= emits(scene.materials[size_t(obj.assetMaterialBase) + i].emission);
    }
  }
  if (!emitting)
    root.fail("lights",
              "expected something to emit at some frame: every light's intensity x color is 0 at "
              "every key, and no object's material and no sky emits (the references would be black "
              "and every relative metric meaningless)");
  scene.contentHash = hasher.hex();
  return scene;
}

std::string assetCacheDir() {
  const char* dir = std::getenv("ARENA_ASSET_DIR");
  // Built as a path, as defaultScenesDir below, for the same GCC 12 false positive.
  return dir && *dir ? std::string(dir)
                     : (std::filesystem::path(ARENA_SOURCE_DIR) / "cache" / "assets").string();
}

std::string defaultScenesDir() {
  // As a path: GCC 12 warns (a false positive, -Warray-bounds) on string + "/scenes" here.
  return (std::filesystem::path(ARENA_SOURCE_DIR) / "scenes").string();
}

std::vector<std::string> listSceneFiles(const std::string& scenesDir) {
  std::vector<std::string> out;
  if (!fs::is_directory(scenesDir)) throw Error(scenesDir + ": scenes directory not found");
  for (auto& e : fs::directory_iterator(scenesDir))
    if (e.path().extension() == ".json") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace arena
