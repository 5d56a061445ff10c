#include "core/blender_import.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "core/json_reader.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string frameFile(int t) { return numberedFileName("frame", t, 4); }

// The view layer to read ("ViewLayer"): the one named, or the only one holding Combined. A file of
// several view layers was read as whichever sorted first (a user's "AAA_fg" override layer was
// imported in place of "ViewLayer", silently).
std::string viewLayer(const fs::path& file, const ExrHeader& header, const std::string& wanted,
                      const std::string& wantedFrom) {
  const std::string suffix = ".Combined.R";
  std::vector<std::string> layers;
  for (const std::string& c : header.channels)
    if (c.size() > suffix.size() && c.compare(c.size() - suffix.size(), suffix.size(), suffix) == 0)
      layers.push_back(c.substr(0, c.size() - suffix.size()));
  if (layers.empty())
    throw Error(
        file.string() +
        ": no Combined pass (channel '<view layer>.Combined.R'); is it a Blender multilayer "
        "EXR?");
  std::string names;
  for (const std::string& l : layers) names += (names.empty() ? "'" : ", '") + l + "'";
  if (!wanted.empty()) {
    if (std::find(layers.begin(), layers.end(), wanted) != layers.end()) return wanted;
    throw Error(file.string() + ": no view layer '" + wanted + "' (" + wantedFrom + "); it holds " +
                names);
  }
  if (layers.size() > 1)
    throw Error(file.string() + ": " + std::to_string(layers.size()) + " view layers (" + names +
                "); name the one to import with --view-layer");
  return layers[0];
}

struct BlenderPass {
  const char* name;  // in the file: "<view layer>.<name>.<channel>"
  std::vector<std::string> channels;
  const char* where;  // where Blender's interface enables it
};

// Blender's passes of one file, by pass name ("Combined", "DiffDir", ...). Every pass missing is
// named at once, with where Blender enables it (EEVEE's files lack five: they were met one error at
// a time); a pass only partly there names the channels it lacks. `wantedFrom`: where the layer's
// name came from (the option, or the first frame), for the error where a file lacks it.
LayerSet readPasses(const fs::path& file, const std::vector<BlenderPass>& passes,
                    const std::string& wantedLayer, const std::string& wantedFrom,
                    std::string* layerRead = nullptr) {
  const ExrHeader header = readExrHeader(file);
  const std::string layer = viewLayer(file, header, wantedLayer, wantedFrom);
  if (layerRead) *layerRead = layer;
  const std::set<std::string> held(header.channels.begin(), header.channels.end());
  std::vector<LayerSpec> specs;
  std::string missing;
  int missingCount = 0;
  for (const BlenderPass& pass : passes) {
    const std::string name = layer + "." + pass.name;
    std::string lacking;
    size_t lacked = 0;
    for (const std::string& c : pass.channels)
      if (!held.count(name + "." + c)) lacking += (lacked++ ? ", " : "") + c;
    if (lacked > 0) {
      missing +=
          (missing.empty() ? "" : ", ") + std::string(pass.name) + " (" +
          (lacked == pass.channels.size()
               ? std::string(pass.where)
               : "its channel" + std::string(lacked > 1 ? "s " : " ") + lacking + " missing") +
          ")";
      ++missingCount;
    }
    specs.push_back({name, pass.channels, false});
  }
  if (missingCount > 0)
    throw Error(file.string() + ": view layer '" + layer + "' lacks " +
                (missingCount == 1 ? "a pass" : std::to_string(missingCount) + " passes") +
                " the capture needs: " + missing + "; enable " +
                (missingCount == 1 ? "it" : "them") +
                " in View Layer Properties > Passes and render with Cycles (EEVEE has no indirect "
                "light, Vector or index passes; scripts/blender/render_capture.py shows every "
                "setting)");
  LayerSet read = readExr(file, specs).layers;
  LayerSet out;
  for (const BlenderPass& pass : passes) out.set(pass.name, read.get(layer + "." + pass.name));
  return out;
}

Image rgb(const Image& rgba) {  // the capture's colour: Combined's R, G and B
  Image out(rgba.width(), rgba.height(), 3);
  for (int c = 0; c < 3; ++c) std::copy(rgba.plane(c), rgba.plane(c) + rgba.pixelCount(), out.plane(c));
  return out;
}

Image sum(const Image& a, const Image& b) {
  Image out = a;
  for (size_t i = 0; i < out.raw().size(); ++i) out.raw()[i] += b.raw()[i];
  return out;
}

const std::vector<BlenderPass>& framePasses() {
  static const std::vector<BlenderPass> passes = {
      {"Combined", {"R", "G", "B"}, "Combined"},  // (its alpha, where written, is not read)
      {"DiffDir", {"R", "G", "B"}, "Light > Diffuse > Direct"},
      {"DiffInd", {"R", "G", "B"}, "Light > Diffuse > Indirect"},
      {"DiffCol", {"R", "G", "B"}, "Light > Diffuse > Color"},
      {"GlossDir", {"R", "G", "B"}, "Light > Glossy > Direct"},
      {"GlossInd", {"R", "G", "B"}, "Light > Glossy > Indirect"},
      {"GlossCol", {"R", "G", "B"}, "Light > Glossy > Color"},
      {"Emit", {"R", "G", "B"}, "Light > Other > Emission"},
      {"Env", {"R", "G", "B"}, "Light > Other > Environment"},
      {"Normal", {"X", "Y", "Z"}, "Data > Normal"},
      {"Depth", {"Z"}, "Data > Z"},
      {"Vector", {"X", "Y", "Z", "W"}, "Data > Vector, which needs motion blur off"},
      {"IndexOB", {"X"}, "Data > Indexes > Object Index"},
      {"IndexMA", {"X"}, "Data > Indexes > Material Index"},
      {"roughness",
       {"X"},
       "Shader AOV > a Value AOV named 'roughness', which every material writes"}};
  return passes;
}

// The frame file t of a folder, or an Error saying what the folder holds (frames numbered from 1,
// Blender's default, or a folder renamed).
fs::path existingFrame(const fs::path& dir, int t, int frames) {
  const fs::path file = dir / frameFile(t);
  if (fs::exists(file)) return file;
  // Numbered from 1: Blender's own frame numbers written as the file names.
  const bool fromOne = t == 0 && fs::exists(dir / frameFile(1)) && !fs::exists(dir / frameFile(0));
  throw Error(file.string() + ": file does not exist; frames are " + frameFile(0) + " to " +
              frameFile(frames - 1) + " (numbered from 0, four digits" +
              (fromOne
                   ? "; this folder is numbered from 1, Blender's frame numbers: name the files "
                     "from 0 whatever the scene's first frame, as "
                     "scripts/blender/render_capture.py writes frame f as f - frame_start"
                   : std::string()) +
              ")" + exrFilesHeld(dir));
}

// The Cycles settings of each render (cameras.json's optional "renders": noisy, reference_a,
// reference_b; scripts/blender/render_capture.py writes them). What shapes the light must be the
// same in every render: a reference of other bounces, clamps, exposure, film or pixel filter is
// another image, and passed every check where its overall brightness agreed (a reference without
// bounces was not caught). Cycles' denoiser in any render is refused. What the checks cannot see
// but a capture should not have (a fixed seed for the noisy frames, adaptive sampling, another
// pixel filter than Box 1 px) is returned as deviations, recorded and warned of.
struct RenderSettingsRead {
  json renders = json::object();
  std::vector<std::string> deviations;
};

RenderSettingsRead readRenderSettings(JsonReader& root, const std::vector<std::string>& halves,
                                      const std::string& file, int spp, int referenceSpp) {
  RenderSettingsRead out;
  std::optional<JsonReader> renders = root.optionalChild("renders");
  if (!renders) return out;
  static const char* const kTransport[] = {
      "maxBounces",    "diffuseBounces",     "glossyBounces",      "transmissionBounces",
      "volumeBounces", "transparentBounces", "clampDirect",        "clampIndirect",
      "exposure",      "filmTransparent",    "motionBlur",         "filter",
      "filterWidth",   "blurGlossy",         "causticsReflective", "causticsRefractive"};
  std::vector<std::string> names = {"noisy"};
  names.insert(names.end(), halves.begin(), halves.end());
  for (const std::string& name : names) {
    JsonReader r = renders->child(name);
    // Every setting given (a switch left out is no "off": it was not recorded).
    const auto flag = [&r](const char* key) {
      if (!r.has(key)) r.value(key);  // an error naming the missing field
      return r.boolean(key, false);
    };
    json settings = {{"samples", r.integerIn("samples", 1, 1000000000)},
                     {"seed", r.integer("seed")},
                     {"animatedSeed", flag("animatedSeed")},
                     {"adaptiveSampling", flag("adaptiveSampling")},
                     {"denoising", flag("denoising")},
                     {"filmTransparent", flag("filmTransparent")},
                     {"motionBlur", flag("motionBlur")},
                     {"causticsReflective", flag("causticsReflective")},
                     {"causticsRefractive", flag("causticsRefractive")},
                     {"blurGlossy", r.number("blurGlossy")},
                     {"filter", r.string("filter")},
                     {"filterWidth", r.number("filterWidth")},
                     {"exposure", r.number("exposure")},
                     {"clampDirect", r.number("clampDirect")},
                     {"clampIndirect", r.number("clampIndirect")}};
    for (const char* k : {"maxBounces", "diffuseBounces", "glossyBounces", "transmissionBounces",
                          "volumeBounces", "transparentBounces"})
      settings[k] = r.integerIn(k, 0, 1024);
    r.rejectUnread();
    if (settings["denoising"].get<bool>())
      throw Error(file + ": $.renders." + name + ".denoising: Cycles' denoiser was on for the " +
                  name +
                  " frames; a capture holds what the path tracer gave (Render Properties > "
                  "Sampling > Render > Denoise: off)");
    // The samples cameras.json declares (the noise floor and the recorded samples rest on them).
    const int declared = name == "noisy" ? spp : std::max(1, referenceSpp / 2);
    if (settings["samples"].get<int>() != declared)
      throw Error(file + ": $.renders." + name + ".samples: " +
                  std::to_string(settings["samples"].get<int>()) + ", where cameras.json's " +
                  (name == "noisy"
                       ? "spp declares " + std::to_string(spp)
                       : "referenceSpp declares " + std::to_string(declared) + " for each half") +
                  ": the samples recorded would not be those rendered");
    out.renders[name] = settings;
  }
  // A folder left out since (one reference half removed: the other is the reference) leaves its
  // entry unread.
  for (const char* half : {"reference_a", "reference_b"})
    if (renders->has(half)) renders->value(half);
  renders->rejectUnread();
  const json& noisy = out.renders["noisy"];
  for (const std::string& half : halves)
    for (const char* k : kTransport)
      if (out.renders[half][k] != noisy[k])
        throw Error(file + ": $.renders." + half + "." + k + ": " + out.renders[half][k].dump() +
                    ", where the noisy frames' is " + noisy[k].dump() +
                    ": a reference must render the same light (bounces, clamps, exposure, film, "
                    "pixel filter) with more samples, or it is the reference of another image");
  if (!noisy["animatedSeed"].get<bool>())
    out.deviations.push_back(
        "the noisy frames' seed is not animated (every frame the same noise pattern: a temporal "
        "filter's history cannot average it away; Sampling > Advanced > Seed, the clock icon)");
  for (const auto& [name, settings] : out.renders.items()) {
    if (settings["adaptiveSampling"].get<bool>())
      out.deviations.push_back("adaptive sampling was on for the " + name +
                               " frames (their noise is not of the samples per pixel recorded)");
    if (name == "noisy" && (settings["filter"] != "BOX" || settings["filterWidth"] != 1.0))
      out.deviations.push_back("the pixel filter is " + settings["filter"].get<std::string>() +
                               " of " + shortestText(settings["filterWidth"].get<double>()) +
                               " px, not Box of 1 px (each pixel's samples spread over its "
                               "neighbours: noise correlated between pixels)");
  }
  for (const std::string& half : halves)
    if (out.renders[half]["seed"] == noisy["seed"] &&
        out.renders[half]["animatedSeed"] == noisy["animatedSeed"])
      out.deviations.push_back("the " + half +
                               " frames share the noisy frames' seed: the input's noise is part "
                               "of its reference, which flatters every method that keeps it");
  if (halves.size() == 2 &&
      out.renders["reference_a"]["seed"] == out.renders["reference_b"]["seed"])
    out.deviations.push_back(
        "the two reference halves share their seed: they are one render twice, and the noise "
        "floor they give is none");
  return out;
}

// A frame file beyond the `frames` cameras.json declares: a capture cut short silently otherwise.
void refuseFramesBeyond(const fs::path& dir, int frames, const fs::path& camerasFile) {
  std::error_code ec;
  std::vector<std::string> beyond;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    int t = -1;
    char rest = 0;
    if (std::sscanf(n.c_str(), "frame_%d.ex%c", &t, &rest) == 2 && n == frameFile(t) && t >= frames)
      beyond.push_back(n);
  }
  if (beyond.empty()) return;
  std::sort(beyond.begin(), beyond.end());
  throw Error(
      dir.string() + ": holds " + beyond.front() +
      (beyond.size() > 1 ? " and " + std::to_string(beyond.size() - 1) + " more" : "") +
      " beyond the " + std::to_string(frames) + " frames " + camerasFile.string() +
      " declares ($.frames); render cameras.json with the frames, or remove the extra files");
}

}  // namespace

void importBlender(const fs::path& source, const fs::path& out, const BlenderImportOptions& options) {
  const fs::path camerasFile = source / "cameras.json";
  if (!fs::exists(camerasFile))
    throw Error(source.string() + ": no cameras.json (written by scripts/blender/render_capture.py)");
  const std::string name =
      options.name.empty() ? folderName(source) : options.name;  // "render/": render
  if (!isPlainName(name))
    throw Error(std::string(options.name.empty() ? "the source folder's name" : "--name") + " " +
                quotedText(name) +
                " cannot name a capture (expected UTF-8 with no spaces, slashes, commas or control "
                "characters, not . "
                "or ..)" +
                (options.name.empty() ? "; give one with --name" : ""));
  const json doc = parseJsonFile(camerasFile.string());
  JsonReader root(doc, camerasFile.string());
  const int width = root.integerIn("width", 1, 16384), height = root.integerIn("height", 1, 16384);
  const int frames = root.integerIn("frames", 1, 100000);
  const double fps = root.number("fps");
  if (!(fps > 0) || !std::isfinite(fps)) root.fail("fps", "a positive number of frames per second");
  const double clipStart = root.number("clipStart"), clipEnd = root.number("clipEnd");
  if (!(clipStart > 0) || !std::isfinite(clipStart))
    root.fail("clipStart", "expected a positive number (the camera's clip start)");
  if (!(clipEnd > clipStart) || !std::isfinite(clipEnd))
    root.fail("clipEnd", "expected a number above clipStart " + std::to_string(clipStart) +
                             " (the camera's clip end)");
  const std::string producer = root.string("producer");
  const int spp = root.integerIn("spp", 1, 1000000000),
            referenceSpp = root.integerIn("referenceSpp", 1, 1000000000);
  // Arrays of rows: read as plain JSON (our script writes them), checked for shape and numbers.
  const json cams = root.node().contains("cameras") ? root.node()["cameras"] : json();
  root.optionalArray("cameras");
  if (!cams.is_array()) throw Error(camerasFile.string() + ": $.cameras: expected an array");
  if (int(cams.size()) != frames)
    throw Error(camerasFile.string() + ": " + std::to_string(cams.size()) + " cameras for " + std::to_string(frames) +
                " frames");
  json cameras = json::array();
  for (int t = 0; t < frames; ++t) {
    // cameraToWorld rows; Blender's camera looks down its local -Z with +Y up, as OpenGL's does, so
    // the view matrix is its inverse: rotation R^T, translation -R^T p.
    double m[4][4], p[4][4];
    for (const auto& [key, matrix] : {std::pair<const char*, double(*)[4]>{"cameraToWorld", m}, {"projection", p}}) {
      const std::string where = camerasFile.string() + ": $.cameras[" + std::to_string(t) + "]." + key;
      const json& rows = cams[size_t(t)].is_object() && cams[size_t(t)].contains(key) ? cams[size_t(t)][key] : json();
      if (!rows.is_array() || rows.size() != 4) throw Error(where + ": expected 4 rows of 4 numbers");
      for (int r = 0; r < 4; ++r) {
        if (!rows[size_t(r)].is_array() || rows[size_t(r)].size() != 4) throw Error(where + ": expected 4 rows of 4 numbers");
        for (int c = 0; c < 4; ++c) {
          const json& v = rows[size_t(r)][size_t(c)];
          if (!v.is_number() || !std::isfinite(v.get<double>()))
            throw Error(where + "[" + std::to_string(r) + "][" + std::to_string(c) + "]: expected a finite number");
          matrix[r][c] = v.get<double>();
        }
      }
    }
    // Cameras a capture cannot hold, said in Blender's words (the capture's reader named the
    // converted matrix, and advised a jitter for a lens shift).
    const std::string where = camerasFile.string() + ": $.cameras[" + std::to_string(t) + "]";
    for (int c = 0; c < 3; ++c) {
      const double length = std::sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
      if (std::abs(length - 1) > 1e-4)
        throw Error(where + ".cameraToWorld: the camera object is scaled (its " + "XYZ"[c] +
                    " axis has length " + std::to_string(length) +
                    "); clear the scale of the camera and of its parents to 1 (Object > Clear > "
                    "Scale, Alt+S: "
                    "applying it does nothing to a camera)");
    }
    if (std::abs(p[3][2]) < 1e-9 && std::abs(p[3][3] - 1) < 1e-9)
      throw Error(where +
                  ".projection: an orthographic camera; a capture needs a perspective one "
                  "(Camera > Lens > Type: Perspective)");
    if (std::abs(p[0][2]) > 1e-6 || std::abs(p[1][2]) > 1e-6)
      throw Error(where + ".projection: a lens shift (P[0][2] = " + std::to_string(p[0][2]) +
                  ", P[1][2] = " + std::to_string(p[1][2]) +
                  "); a capture needs a centred projection: set the camera's Shift X and Y to 0");
    std::vector<double> view(16, 0.0), projection(16, 0.0);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) view[size_t(c * 4 + r)] = m[c][r];  // (R^T)[r][c] = R[c][r]
      view[size_t(3 * 4 + r)] = -(m[0][r] * m[0][3] + m[1][r] * m[1][3] + m[2][r] * m[2][3]);
    }
    view[15] = 1;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) projection[size_t(c * 4 + r)] = p[r][c];
    cameras.push_back({{"view", view}, {"projection", projection}, {"position", {m[0][3], m[1][3], m[2][3]}}});
  }
  json events = json::array();
  for (JsonReader& e : root.optionalArray("events")) {
    json ev = {{"frame", e.integer("frame")}, {"kind", e.string("kind")}, {"what", e.string("what", "")}};
    if (e.has("passIndex")) ev["meshId"] = e.integer("passIndex");
    e.rejectUnread();
    events.push_back(ev);
  }
  // The reference folders there are: both halves (the script's), one (a render of the reference
  // alone: no noise floor), or none (a capture without a reference: the metrics that need none).
  std::vector<std::string> halves;
  for (const char* half : {"reference_a", "reference_b"})
    if (fs::is_directory(source / half)) halves.push_back(half);
  const RenderSettingsRead renders =
      readRenderSettings(root, halves, camerasFile.string(), spp, referenceSpp);
  root.rejectUnread();
  // referenceSpp counts both halves' samples together.
  const int referenceSamples = halves.size() == 2 ? referenceSpp : std::max(1, referenceSpp / 2);

  // Frames numbered from 1 are named as such first (their last one is also "beyond").
  existingFrame(source / "noisy", 0, frames);
  for (const std::string& half : halves) existingFrame(source / half, 0, frames);
  refuseFramesBeyond(source / "noisy", frames, camerasFile);
  for (const std::string& half : halves) refuseFramesBeyond(source / half, frames, camerasFile);
  CaptureWriter writer(out);
  double emissionResidual = 0, combinedTotal = 0;
  // Surface pixels, and those whose normal was not of unit length (beyond 1%): Cycles averages a
  // pixel's samples, so at more than 1 spp a pixel over an edge holds the mean of two normals,
  // shorter than 1 (0.027 of a frame's pixels at 4 spp, 0.13 at 16: refused as not unit length).
  // Renormalised, as a G-buffer holds one surface's normal per pixel; the share is recorded.
  double surfacePixels = 0, renormalised = 0;
  std::string layer = options.viewLayer;  // frame 0's, then the same in every file
  std::string layerFrom = "--view-layer";
  for (int t = 0; t < frames; ++t) {
    const fs::path file = existingFrame(source / "noisy", t, frames);
    const LayerSet passes = readPasses(file, framePasses(), layer, layerFrom, &layer);
    if (t == 0 && options.viewLayer.empty()) layerFrom = "the one " + file.string() + " holds";
    if (passes.width() != width || passes.height() != height)
      throw Error(file.string() + ": " + std::to_string(passes.width()) + "x" + std::to_string(passes.height()) +
                  ", expected " + std::to_string(width) + "x" + std::to_string(height) + " (cameras.json)");
    LayerSet f;
    const Image color = rgb(passes.get("Combined"));
    const Image diffuse = sum(passes.get("DiffDir"), passes.get("DiffInd"));
    const Image specular = sum(passes.get("GlossDir"), passes.get("GlossInd"));
    const Image &albedo = passes.get("DiffCol"), &specAlbedo = passes.get("GlossCol");
    Image emission(width, height, 3);
    const Image emitEnv = sum(passes.get("Emit"), passes.get("Env"));
    for (size_t i = 0; i < emission.raw().size(); ++i) {
      emission.raw()[i] = color.raw()[i] - albedo.raw()[i] * diffuse.raw()[i] - specAlbedo.raw()[i] * specular.raw()[i];
      // Over the values that are finite (a NaN or Inf pixel, which the validation names, made the
      // share NaN and passed the check, or null and dropped it: a bad-input trial).
      const double residual = std::abs(double(emission.raw()[i]) - emitEnv.raw()[i]);
      if (!std::isfinite(residual) || !std::isfinite(color.raw()[i])) continue;
      emissionResidual += residual;
      combinedTotal += std::abs(double(color.raw()[i]));
    }
    const Image& depthPass = passes.get("Depth");
    const Image& vector = passes.get("Vector");
    Image depth(width, height, 1), motion(width, height, 2), meshId(width, height, 1), materialId(width, height, 1);
    for (size_t i = 0; i < depth.pixelCount(); ++i) {
      const float z = depthPass.raw()[i];
      // Cycles writes 1e10 where nothing was hit. Anything else is kept as written, a NaN or a
      // negative depth included, so the validation names it (nonFinite.depth, depth.positive)
      // instead of the import turning it into sky.
      const bool background = z == 0 || z >= clipEnd;
      depth.raw()[i] = background ? 0.0f : z;
      motion.plane(0)[i] = vector.plane(0)[i];
      motion.plane(1)[i] = -vector.plane(1)[i];
      meshId.raw()[i] = background ? -1.0f : passes.get("IndexOB").raw()[i];
      materialId.raw()[i] = background ? -1.0f : passes.get("IndexMA").raw()[i];
    }
    Image normal = passes.get("Normal");
    for (size_t i = 0; i < normal.pixelCount(); ++i) {
      if (depth.raw()[i] == 0) continue;  // the background: no surface, no normal
      surfacePixels += 1;
      float* n[3] = {&normal.plane(0)[i], &normal.plane(1)[i], &normal.plane(2)[i]};
      const float length = std::sqrt(*n[0] * *n[0] + *n[1] * *n[1] + *n[2] * *n[2]);
      // A zero or non-finite normal is kept as written: the validation names it.
      if (!(length > 0) || !std::isfinite(length)) continue;
      renormalised += std::abs(length - 1.0f) > 0.01f;
      for (float* c : n) *c /= length;
    }
    f.set("color", color);
    f.set("diffuse", diffuse);
    f.set("specular", specular);
    f.set("albedo", albedo);
    f.set("specAlbedo", specAlbedo);
    f.set("emission", std::move(emission));
    f.set("normal", std::move(normal));
    f.set("depth", std::move(depth));
    f.set("motion", std::move(motion));
    f.set("roughness", passes.get("roughness"));
    f.set("meshId", std::move(meshId));
    f.set("materialId", std::move(materialId));
    writer.frame(t, f);
    if (halves.empty()) continue;  // a capture without a reference
    // The reference: two independent halves rendered with different seeds (their mean, and the
    // first half for the noise floor), or the one folder there is (no noise floor).
    std::vector<Image> read;
    for (const std::string& half : halves) {
      const fs::path halfFile = existingFrame(source / half, t, frames);
      read.push_back(
          rgb(readPasses(halfFile, {framePasses()[0]}, layer, layerFrom).get("Combined")));
      if (read.back().width() != width || read.back().height() != height)
        throw Error(halfFile.string() + ": " + std::to_string(read.back().width()) + "x" +
                    std::to_string(read.back().height()) + ", expected " + std::to_string(width) +
                    "x" + std::to_string(height) + " (the noisy frames')");
    }
    LayerSet ref;
    if (read.size() == 2) {
      Image mean(width, height, 3);
      for (size_t i = 0; i < mean.raw().size(); ++i)
        mean.raw()[i] = 0.5f * (read[0].raw()[i] + read[1].raw()[i]);
      ref.set("color", std::move(mean));
      ref.set("colorHalf", read[0]);
    } else {
      ref.set("color", read[0]);
    }
    writer.reference(t, ref);
  }
  std::vector<int> ofFrame(static_cast<size_t>(frames));
  for (int t = 0; t < frames; ++t) ofFrame[size_t(t)] = t;
  json description = {
      {"format", kCaptureFormatName},
      {"version", kCaptureFormatVersion},
      {"name", name},
      {"purpose", "Blender Cycles capture"},
      {"width", width},
      {"height", height},
      {"frames", frames},
      {"frameRate", fps},
      {"units", "m"},
      {"near", clipStart},
      {"far", clipEnd},
      {"cameras", cameras},
      {"events", events},
      {"reference",
       {{"ofFrame", ofFrame}, {"samples", std::vector<int>(size_t(frames), referenceSamples)}}},
      {"source",
       {{"producer", producer},
        {"spp", spp},
        {"importer", "arena import blender"},
        // How much of the colour is neither the two lobes nor Emit + Env (transmission, volumes):
        // it is kept in `emission`, so the colour stays exact.
        {"emissionBeyondEmitEnv", combinedTotal > 0 ? emissionResidual / combinedTotal : 0.0},
        {"viewLayer", layer},
        // The share of surface pixels whose normal was renormalised (above).
        {"normalsRenormalised", surfacePixels > 0 ? renormalised / surfacePixels : 0.0}}}};
  if (halves.empty()) description.erase("reference");
  if (!renders.renders.empty()) {
    description["source"]["renders"] = renders.renders;
    description["source"]["renderDeviations"] = renders.deviations;
  }
  try {
    writer.commit(description);
  } catch (const Error& e) {
    // The capture's description is written from cameras.json: a field the reader refuses there
    // is one of the user's, under another name. (Any other error, a full disk, is as it is.)
    if (std::string(e.what()).find("the capture would not be valid") == std::string::npos) throw;
    throw Error(std::string(e.what()) + " (capture.json is written from " + camerasFile.string() +
                ": its cameras[i].view is the inverse of cameras[i].cameraToWorld there, and its "
                "events, frameRate and clip planes are that file's events, fps, clipStart and "
                "clipEnd)");
  }
}

}  // namespace arena
