// The realistic scenes of issue 18 (scenes/living_room.json, scenes/foliage_window.json) and the
// script that extracts their furniture from Debian's sweethome3d-furniture package
// (scripts/extract_assets.py): its contract (clear errors, nothing half-extracted, idempotent)
// and tiny end-to-end renders of both scenes.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <set>

#include "core/atomic_file.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kScript = std::string(ARENA_SOURCE_DIR) + "/scripts/extract_assets.py";
const std::string kArchive = "/usr/share/sweethome3d/furniture/BlendSwap-CC-0.sh3f";

using Result = test::CommandResult;

// Runs the script with the archive and asset cache given through its environment variables.
Result extract(const std::string& archive, const fs::path& assetDir, const std::string& models) {
  return test::runCommand("ARENA_SH3F_ARCHIVE='" + archive + "' ARENA_ASSET_DIR='" + assetDir.string() +
                          "' python3 " + kScript + " " + models);
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> out;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  return out;
}

// A zip holding blendswap-cc-0/<model>/ with two stored files, written by Python's zipfile;
// `corruptSecond` flips a byte of the second file's data, so its CRC check fails mid-extraction.
fs::path writeZip(const fs::path& dir, const std::string& model, bool corruptSecond,
                  const std::string& secondName = "b.mtl") {
  const fs::path zip = dir / "test.sh3f";
  const std::string py =
      "import zipfile,sys\n"
      "p,m,second,corrupt=sys.argv[1],sys.argv[2],sys.argv[3],sys.argv[4]=='1'\n"
      "with zipfile.ZipFile(p,'w',zipfile.ZIP_STORED) as z:\n"
      "  z.writestr('blendswap-cc-0/'+m+'/a.obj','v 0 0 0\\n'*64)\n"
      "  z.writestr('blendswap-cc-0/'+m+'/'+second,'SECOND-MEMBER-DATA'*16)\n"
      "if corrupt:\n"
      "  d=bytearray(open(p,'rb').read()); i=d.index(b'SECOND-MEMBER-DATA'); d[i]^=0xff\n"
      "  open(p,'wb').write(bytes(d))\n";
  std::ofstream(dir / "make_zip.py") << py;
  const std::string cmd = "python3 '" + (dir / "make_zip.py").string() + "' '" + zip.string() +
                          "' " + model + " '" + secondName + "' " + (corruptSecond ? "1" : "0");
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return zip;
}

TEST(ExtractAssets, MissingArchiveIsAClearErrorAndExtractsNothing) {
  const fs::path dir = test::freshDir("extract_missing");
  const std::string missing = (dir / "no-such.sh3f").string();
  Result r = extract(missing, dir / "assets", "sofa2");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("archive not found: " + missing), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("sweethome3d-furniture"), std::string::npos) << r.output;
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());
}

TEST(ExtractAssets, ACorruptMemberLeavesNoHalfExtractedModel) {
  const fs::path dir = test::freshDir("extract_corrupt");
  const fs::path zip = writeZip(dir, "model", true);
  Result r = extract(zip.string(), dir / "assets", "model");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("extract_assets: error:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("b.mtl"), std::string::npos) << "names the bad member: " << r.output;
  // The first member was written before the second failed: only a temporary held it.
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());

  // The same archive intact: the model appears whole, and a second run leaves it alone.
  const fs::path good = writeZip(dir, "model", false);
  r = extract(good.string(), dir / "assets", "model");
  ASSERT_EQ(r.status, 0) << r.output;
  const fs::path model = dir / "assets" / "sweethome3d" / "model";
  EXPECT_EQ(fs::file_size(model / "a.obj"), 64u * 8u);
  EXPECT_EQ(fs::file_size(model / "b.mtl"), 18u * 16u);
  const auto written = fs::last_write_time(model / "a.obj");
  fs::remove(good);  // an extracted model needs no archive
  r = extract(good.string(), dir / "assets", "model");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output, "");
  EXPECT_EQ(fs::last_write_time(model / "a.obj"), written);
}

TEST(ExtractAssets, UnknownModelsAndEscapingMembersAreRejected) {
  const fs::path dir = test::freshDir("extract_bad");
  const fs::path zip = writeZip(dir, "model", false, "../../escaped.txt");
  Result r = extract(zip.string(), dir / "assets", "model");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("escapes the model folder"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "escaped.txt"));
  EXPECT_FALSE(fs::exists(dir / "assets" / "escaped.txt"));
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());

  r = extract(zip.string(), dir / "assets", "sofa");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no model 'sofa'"), std::string::npos) << r.output;
  r = extract(zip.string(), dir / "assets", "'../model'");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("model name '../model'"), std::string::npos) << r.output;
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());
}

// Leftovers of a killed run (a .partial-* folder) are removed and the model extracted whole.
TEST(ExtractAssets, ATemporaryOfAKilledRunIsReplaced) {
  const fs::path dir = test::freshDir("extract_stale");
  const fs::path zip = writeZip(dir, "model", false);
  const fs::path stale = dir / "assets" / "sweethome3d" / ".partial-model-99999";
  fs::create_directories(stale);
  std::ofstream(stale / "a.obj") << "half";
  Result r = extract(zip.string(), dir / "assets", "model");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(entries(dir / "assets" / "sweethome3d"), std::vector<std::string>{"model"});
}

// The furniture models a shipped scene names ("assets:sweethome3d/<model>/...") that are not in the
// asset cache; empty when the scene can render.
std::vector<std::string> missingModels(const std::string& scene) {
  const std::string text = readText(defaultScenesDir() + "/" + scene + ".json");
  const fs::path root = fs::path(assetCacheDir()) / "sweethome3d";
  std::vector<std::string> missing;
  const std::regex ref("assets:sweethome3d/([A-Za-z0-9_]+)/");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), ref); it != std::sregex_iterator();
       ++it)
    if (!fs::is_directory(root / (*it)[1].str())) missing.push_back((*it)[1].str());
  return missing;
}

#define SKIP_WITHOUT_ASSETS(scene)                                                                 \
  if (auto missing = missingModels(scene); !missing.empty())                                       \
  GTEST_SKIP() << scene << ": furniture not extracted (" << missing.front()                        \
               << " and others missing): run python3 scripts/extract_assets.py (scripts/setup.sh " \
                  "does)"

bool allFinite(const Image& img) {
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < img.channels(); ++c)
        if (!std::isfinite(img.at(x, y, c))) return false;
  return true;
}

// The object index (= meshId) of the object named `name`.
int objectIndex(const Scene& s, const std::string& name) {
  for (size_t i = 0; i < s.objects.size(); ++i)
    if (s.objects[i].name == name) return int(i);
  ADD_FAILURE() << "no object " << name << " in " << s.file;
  return -1;
}

TEST(RealisticScenes, LivingRoomShowsItsFurnitureAndTheLampSwitchesOff) {
  SKIP_WITHOUT_ASSETS("living_room");
  const Scene scene = test::shippedScene("living_room");
  ASSERT_EQ(scene.events.size(), 1u);
  EXPECT_EQ(scene.events[0].kind, arena::EventKind::LightOff);
  EXPECT_EQ(scene.events[0].what, "lamp");
  SequenceRenderer renderer(scene, test::tinySettings(64, 36, 0, 16));
  const auto frame = renderer.renderFrame(0);
  for (const auto& [name, image] : frame.frame.all()) EXPECT_TRUE(allFinite(image)) << name;
  const Image& meshId = frame.frame.get("meshId");
  std::set<int> visible;
  for (int y = 0; y < meshId.height(); ++y)
    for (int x = 0; x < meshId.width(); ++x) visible.insert(int(meshId.at(x, y)));
  for (const char* name : {"couch", "table", "chair_front", "chair_side", "plant", "armchair",
                           "pendant", "tatami_10", "wall_back_left"})
    EXPECT_TRUE(visible.count(objectIndex(scene, name))) << name << " not in view at frame 0";

  // At the event the pendant lamp goes dark and with it a good part of the room's light (the
  // window still lights the rest).
  const int event = scene.events[0].frame;
  auto meanLuminance = [&](int t) {
    const ReferenceResult ref = renderer.renderReference(t);
    const Image& c = ref.layers.get("color");
    EXPECT_TRUE(allFinite(c));
    double sum = 0;
    for (int y = 0; y < c.height(); ++y)
      for (int x = 0; x < c.width(); ++x)
        sum += 0.2126 * c.at(x, y, 0) + 0.7152 * c.at(x, y, 1) + 0.0722 * c.at(x, y, 2);
    return sum / (double(c.width()) * c.height());
  };
  const double before = meanLuminance(event - 1), after = meanLuminance(event);
  std::printf("living_room 64x36: mean luminance %.4f before the event, %.4f after\n", before,
              after);
  EXPECT_GT(after, 0.0);
  EXPECT_LT(after, 0.75 * before);
}

TEST(RealisticScenes, FoliageWindowIsThinGeometryAgainstABrightBackground) {
  SKIP_WITHOUT_ASSETS("foliage_window");
  const Scene scene = test::shippedScene("foliage_window");
  SequenceRenderer renderer(scene, test::tinySettings(64, 36, 0, 16));
  const auto frame = renderer.renderFrame(0);
  for (const auto& [name, image] : frame.frame.all()) EXPECT_TRUE(allFinite(image)) << name;
  const ReferenceResult ref = renderer.renderReference(0);
  const Image& color = ref.layers.get("color");
  const Image& meshId = frame.frame.get("meshId");
  const int plant = objectIndex(scene, "plant");
  auto isPlant = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < meshId.width() && y < meshId.height() &&
           int(meshId.at(x, y)) == plant;
  };
  // Thin: the window shows through the crown (sky pixels with plant on both sides in their row),
  // and much of the plant is silhouette. Bright: the window outshines the plant.
  int plantPixels = 0, silhouette = 0, skyPixels = 0, holes = 0;
  double plantLum = 0, skyLum = 0;
  for (int y = 0; y < meshId.height(); ++y) {
    int firstPlant = meshId.width(), lastPlant = -1;
    for (int x = 0; x < meshId.width(); ++x)
      if (isPlant(x, y)) firstPlant = std::min(firstPlant, x), lastPlant = x;
    for (int x = 0; x < meshId.width(); ++x) {
      const double lum =
          0.2126 * color.at(x, y, 0) + 0.7152 * color.at(x, y, 1) + 0.0722 * color.at(x, y, 2);
      if (isPlant(x, y)) {
        ++plantPixels;
        plantLum += lum;
        if (!isPlant(x - 1, y) || !isPlant(x + 1, y) || !isPlant(x, y - 1) || !isPlant(x, y + 1))
          ++silhouette;
      } else if (meshId.at(x, y) < 0) {
        ++skyPixels;
        skyLum += lum;
        if (x > firstPlant && x < lastPlant) ++holes;
      }
    }
  }
  const double pixels = double(meshId.width()) * meshId.height();
  std::printf(
      "foliage_window 64x36: plant %.3f, sky %.3f of the frame; silhouette %.3f, holes %.3f "
      "of the plant; sky/plant luminance %.1f\n",
      plantPixels / pixels, skyPixels / pixels, double(silhouette) / plantPixels,
      double(holes) / plantPixels, (skyLum / skyPixels) / (plantLum / plantPixels));
  EXPECT_GT(plantPixels / pixels, 0.1);
  EXPECT_GT(skyPixels / pixels, 0.3);
  EXPECT_GT(double(silhouette) / plantPixels, 0.25);
  EXPECT_GT(double(holes) / plantPixels, 0.04);
  EXPECT_GT(skyLum / skyPixels, 5.0 * plantLum / plantPixels);
}

}  // namespace
}  // namespace arena
