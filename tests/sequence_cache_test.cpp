// The sequence cache: atomic writes, resume, stale-hash invalidation, corrupted-file detection,
// readability by standard tools.
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "core/sequence.hpp"
#include "metrics/evaluator.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;

struct Log {
  std::vector<std::string> lines;
  ProgressFn fn() {
    return [this](const std::string& l) { lines.push_back(l); };
  }
  int count(const std::string& needle) const {
    int n = 0;
    for (auto& l : lines) n += l.find(needle) != std::string::npos;
    return n;
  }
};

TEST(Cache, AtomicWriteLeavesNothingWhenInterrupted) {
  auto dir = test::freshDir("atomic");
  auto target = dir / "file.txt";
  EXPECT_THROW(writeAtomically(target, [](const fs::path& tmp) {
                 std::ofstream(tmp) << "half";
                 throw Error("interrupted");
               }),
               Error);
  EXPECT_FALSE(fs::exists(target));
  EXPECT_TRUE(fs::is_empty(dir)) << "temporary file left behind";
  writeTextAtomically(target, "whole");
  EXPECT_EQ(readText(target), "whole");
}

// Every channel of the layers `specs` names holds the same bits in a and b.
void expectSameBits(const LayerSet& a, const LayerSet& b, const std::vector<LayerSpec>& specs) {
  for (const LayerSpec& spec : specs) {
    const Image &x = a.get(spec.name), &y = b.get(spec.name);
    ASSERT_EQ(x.pixelCount(), y.pixelCount()) << spec.name;
    for (int ch = 0; ch < spec.channels(); ++ch)
      EXPECT_EQ(std::memcmp(x.plane(ch), y.plane(ch), x.pixelCount() * sizeof(float)), 0) << spec.name << " " << ch;
  }
}

class CacheRender : public ::testing::Test {
 protected:
  void SetUp() override {
    cache = test::freshDir("cache_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    scene = test::shippedScene("light_switch");
    settings = test::tinySettings(24, 14, 14, 4);
  }
  fs::path cache;
  Scene scene;
  RenderSettings settings;
};

TEST_F(CacheRender, WritesAReadableSequenceAndSharesReferences) {
  Log log;
  auto dir = renderSequence(scene, settings, cache, log.fn());
  Sequence seq = Sequence::open(dir);
  EXPECT_EQ(seq.info().frames, 14);
  EXPECT_EQ(seq.info().width, 24);
  // The light goes off at frame 12: two distinct animation states, two references.
  EXPECT_EQ(seq.info().referenceOfFrame[0], 0);
  EXPECT_EQ(seq.info().referenceOfFrame[11], 0);
  EXPECT_EQ(seq.info().referenceOfFrame[12], 1);
  EXPECT_EQ(log.count("reference"), 2);
  EXPECT_EQ(seq.info().events.size(), 1u);  // light_on at 24 lies beyond the 14 rendered frames
  LayerSet f = seq.frame(3);
  for (auto& spec : channels::frameLayers()) EXPECT_TRUE(f.has(spec.name)) << spec.name;
  LayerSet ref = seq.reference(12);
  EXPECT_TRUE(ref.has("colorVar"));
  EXPECT_EQ(seq.gradients(1).get("gradient").width(), 8);
  // Standard tools: OpenCV reads the plain RGB channels of a frame.
  setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 1);
  cv::Mat m = cv::imread(Sequence::framePath(dir, 3).string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(m.empty());
  EXPECT_EQ(m.cols, 24);
  EXPECT_NEAR(m.at<cv::Vec3f>(7, 12)[2], f.get("color").at(12, 7, 0), 1e-6);
  if (fs::exists("/usr/bin/exrheader")) {
    std::string cmd = "/usr/bin/exrheader " + Sequence::framePath(dir, 3).string() + " > /dev/null";
    EXPECT_EQ(std::system(cmd.c_str()), 0);
  }
}

// The cache's files are stored uncompressed (ZIP shrinks a reference's noise-like floats by 14% at
// seven times the write time, a frame 2.8x at ten times); both kinds read back bit for bit, and a
// frame an older version wrote under ZIP is still taken as it is.
TEST_F(CacheRender, FilesAreStoredUncompressedAndBothCompressionsReadBackExactly) {
  auto dir = renderSequence(scene, settings, cache, nullptr);
  auto compressionOf = [](const fs::path& p) {
    return Imf::InputFile(p.c_str()).header().compression();
  };
  EXPECT_EQ(compressionOf(Sequence::referencePath(dir, 0)), Imf::NO_COMPRESSION);
  EXPECT_EQ(compressionOf(Sequence::framePath(dir, 0)), Imf::NO_COMPRESSION);
  EXPECT_EQ(compressionOf(Sequence::gradientPath(dir, 1)), Imf::NO_COMPRESSION);
  {
    const fs::path frame = Sequence::framePath(dir, 0);
    const LayerSet before = Sequence::open(dir).frame(0);
    const ExrContents contents = readExr(frame, channels::frameLayers());
    writeExr(frame, contents.layers, channels::frameLayers(), contents.attributes,
             ExrCompression::Zip);
    ASSERT_EQ(compressionOf(frame), Imf::ZIP_COMPRESSION);
    Log log;
    renderSequence(scene, settings, cache, log.fn());
    EXPECT_EQ(log.lines.size(), 0u) << log.lines.front();  // not rendered again
    expectSameBits(before, Sequence::open(dir).frame(0), channels::frameLayers());
  }
  const LayerSet ref = Sequence::open(dir).reference(0);
  const std::vector<LayerSpec>& specs = channels::referenceLayers();
  for (ExrCompression c : {ExrCompression::None, ExrCompression::Zip}) {
    const fs::path copy = cache / (c == ExrCompression::None ? "none.exr" : "zip.exr");
    writeExr(copy, ref, specs, {}, c);
    expectSameBits(ref, readExr(copy, specs).layers, specs);
  }
  EXPECT_EQ(compressionOf(cache / "none.exr"), Imf::NO_COMPRESSION);
}

TEST_F(CacheRender, TheEvaluationReadsItsFilesTogetherAndNamesTheFirstItCannot) {
  // The evaluation reads a sequence's files several at a time; what it reads is what reading them
  // one by one gives, and of two unreadable frames the error names the earlier.
  auto dir = renderSequence(scene, settings, cache, nullptr);
  const Sequence sequence = Sequence::open(dir);
  const EvaluationInput in = readSequenceForEvaluation(sequence);
  ASSERT_EQ(in.frames.size(), 14u);
  ASSERT_EQ(in.references.size(), 2u);
  for (int t : {0, 7, 13}) expectSameBits(in.frames[size_t(t)], sequence.frame(t), channels::frameLayers());
  expectSameBits(in.references[1], sequence.referenceByIndex(1), channels::referenceLayers());
  for (int t : {9, 4})
    fs::resize_file(Sequence::framePath(dir, t), fs::file_size(Sequence::framePath(dir, t)) / 2);
  const std::string error = test::errorOf([&] { readSequenceForEvaluation(Sequence::open(dir)); });
  EXPECT_NE(error.find("frame_0004.exr"), std::string::npos) << error;
  EXPECT_EQ(error.find("frame_0009.exr"), std::string::npos) << error;
}

TEST_F(CacheRender, RerunReusesEverything) {
  auto dir = renderSequence(scene, settings, cache, nullptr);
  Log log;
  EXPECT_EQ(renderSequence(scene, settings, cache, log.fn()), dir);
  EXPECT_EQ(log.lines.size(), 0u) << log.lines.front();
}

TEST_F(CacheRender, TruncatedAndForeignFilesAreDetectedAndRerendered) {
  auto dir = renderSequence(scene, settings, cache, nullptr);
  const auto f5 = Sequence::framePath(dir, 5), f6 = Sequence::framePath(dir, 6);
  const auto originalSize = fs::file_size(f5);
  fs::resize_file(f5, originalSize / 2);     // an interrupted copy
  fs::copy_file(Sequence::framePath(dir, 2), f6, fs::copy_options::overwrite_existing);  // foreign
  std::ofstream(Sequence::referencePath(dir, 1), std::ios::trunc) << "not an exr";
  Log log;
  renderSequence(scene, settings, cache, log.fn());
  EXPECT_EQ(log.count("re-rendering frame_0005.exr"), 1);
  EXPECT_EQ(log.count("re-rendering frame_0006.exr"), 1);
  EXPECT_EQ(log.count("re-rendering reference_001.exr"), 1);
  EXPECT_EQ(log.count("(foreign or stale)"), 1);
  EXPECT_EQ(fs::file_size(f5), originalSize);
  Sequence seq = Sequence::open(dir);
  EXPECT_NO_THROW(seq.frame(5));
  EXPECT_NO_THROW(seq.reference(13));
}

TEST_F(CacheRender, ChangingAnySettingChangesTheHash) {
  auto dir = sequenceDir(scene, settings, cache);
  RenderSettings other = settings;
  other.referenceSpp = 8;
  EXPECT_NE(sequenceDir(scene, other, cache), dir);
  other = settings;
  other.maxBounces = 2;
  EXPECT_NE(sequenceDir(scene, other, cache), dir);
  Scene edited = scene;
  edited.contentHash = "changed";
  EXPECT_NE(sequenceDir(edited, settings, cache), dir);
}

TEST_F(CacheRender, ReadingAMissingOrIncompleteSequenceIsAClearError) {
  try {
    Sequence::open(cache / "nothing-here");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no sequence.json"), std::string::npos);
  }
  auto dir = renderSequence(scene, settings, cache, nullptr);
  fs::resize_file(Sequence::framePath(dir, 4), 100);
  try {
    Sequence::open(dir).frame(4);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame_0004.exr"), std::string::npos) << e.what();
  }
}


// ---- Contract: bad input and state ------------------------------------------------------------

namespace fs = std::filesystem;
using nlohmann::json;

// Every entry under `root` (directories included) with its inode, size and mtime: a file written
// in place changes its mtime, an atomic replace its inode, and a temporary created, renamed or
// removed changes its directory's mtime.
std::map<std::string, std::string> treeSnapshot(const fs::path& root) {
  std::map<std::string, std::string> out;
  auto add = [&](const fs::path& p) {
    struct stat st {};
    if (lstat(p.c_str(), &st) != 0) return;
    out[p.string()] = std::to_string(st.st_ino) + " " + std::to_string(st.st_size) + " " +
                      std::to_string(st.st_mtim.tv_sec) + "." + std::to_string(st.st_mtim.tv_nsec);
  };
  add(root);
  for (auto& e : fs::recursive_directory_iterator(root)) add(e.path());
  return out;
}

TEST(SequenceCacheContract, ACompleteCacheIsReadWithoutWriting) {
  fs::path cache = test::freshDir("readonly_cache");
  Scene scene = test::shippedScene("cornell_static");
  RenderSettings settings = test::tinySettings(16, 8, 2, 2);
  fs::path dir = renderSequence(scene, settings, cache, nullptr);
  // Back-date every entry by an hour, so that a write within the same clock tick still shows
  // (permissions cannot show it: root writes through them).
  const auto past = fs::file_time_type::clock::now() - std::chrono::hours(1);
  fs::last_write_time(cache, past);
  for (auto& e : fs::recursive_directory_iterator(cache)) fs::last_write_time(e.path(), past);
  const auto before = treeSnapshot(cache);
  ASSERT_GT(before.size(), 4u);
  EXPECT_EQ(renderSequence(scene, settings, cache, nullptr), dir);
  EXPECT_NO_THROW(Sequence::open(dir).frame(1));
  EXPECT_EQ(treeSnapshot(cache), before)
      << "the complete cache was written to although nothing changed";
  // A read-only cache directory (enforced for normal users only): rendering and opening still work.
  fs::permissions(dir, fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  EXPECT_NO_THROW(renderSequence(scene, settings, cache, nullptr));
  EXPECT_NO_THROW(Sequence::open(dir).frame(1));
  fs::permissions(dir, fs::perms::owner_write, fs::perm_options::add);
  EXPECT_EQ(treeSnapshot(cache), before);
}

// A cached file's damaged pixels (uncompressed: nothing else notices a flipped byte) are an error
// naming the file and channel, never measured; so are damaged reference sums.
TEST(SequenceCacheContract, DamagedPixelsOrSumsAreRefusedNamingTheFile) {
  fs::path cache = test::freshDir("damaged_cache");
  Scene scene = test::shippedScene("cornell_static");
  fs::path dir = renderSequence(scene, test::tinySettings(16, 8, 3, 4), cache, nullptr);
  ASSERT_NO_THROW(Sequence::open(dir).frame(1));
  auto flipLastBytes = [](const fs::path& file, size_t fromEnd) {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(0, std::ios::end);
    const std::streamoff at = f.tellg() - std::streamoff(fromEnd);
    f.seekg(at);
    char b[4];
    f.read(b, 4);
    for (char& c : b) c = char(~c);
    f.seekp(at);
    f.write(b, 4);
  };
  flipLastBytes(Sequence::framePath(dir, 1), 40);  // inside the last scanline's pixels
  const std::string frame = test::errorOf([&] { Sequence::open(dir).frame(1); });
  EXPECT_NE(frame.find("frame_0001.exr: channel '"), std::string::npos) << frame;
  EXPECT_NE(frame.find("do not match the checksum"), std::string::npos) << frame;
  EXPECT_NO_THROW(Sequence::open(dir).frame(2));
  const fs::path sums = fs::path(Sequence::referencePath(dir, 0)).replace_extension(".sums");
  ASSERT_TRUE(fs::exists(sums));
  flipLastBytes(sums, 16);
  const std::string summed = test::errorOf(
      [&] { refineSequence(scene, test::tinySettings(16, 8, 3, 4), cache, 1e-9, 8, nullptr, 0); });
  EXPECT_NE(summed.find("reference_000.sums: its sums do not match the checksum"),
            std::string::npos)
      << summed;
}

TEST(SequenceCacheContract, ADeadWritersTemporaryOnThisMachineIsCleanedAtAnyAge) {
  fs::path dir = test::freshDir("stale_tmp_host");
  const std::string own = temporaryPathFor(dir / "x.json").filename().string();
  const size_t at = own.find('@'), underscore = own.find('_', at);
  ASSERT_NE(at, std::string::npos) << own;
  const std::string host = own.substr(at + 1, underscore - at - 1);
  const std::string dead = "999999999";
  writeTextAtomically(dir / ("frame_0003.tmp" + dead + "@" + host + "_4.exr"), "partial");
  writeTextAtomically(dir / ("frame_0004.tmp" + dead + "@otherhost_5.exr"), "partial");
  EXPECT_EQ(removeStaleTemporaries(dir), 1);
  EXPECT_FALSE(fs::exists(dir / ("frame_0003.tmp" + dead + "@" + host + "_4.exr")));
  EXPECT_TRUE(fs::exists(dir / ("frame_0004.tmp" + dead + "@otherhost_5.exr")))
      << "a young temporary of another machine may be a live write";
  // A render killed mid-write and rerun at once: the rerun leaves no temporary behind.
  fs::path cache = test::freshDir("stale_tmp_cache");
  Scene scene = test::shippedScene("cornell_static");
  RenderSettings settings = test::tinySettings(8, 8, 2, 1);
  fs::path seq = renderSequence(scene, settings, cache, nullptr);
  fs::path frame;
  for (auto& e : fs::directory_iterator(seq))
    if (e.path().filename().string().rfind("frame_", 0) == 0 && e.path().extension() == ".exr")
      frame = e.path();
  ASSERT_FALSE(frame.empty());
  const fs::path leftover = seq / (frame.stem().string() + ".tmp" + dead + "@" + host + "_7.exr");
  fs::copy_file(frame, leftover);
  fs::remove(seq / "sequence.json");  // the kill came before the sequence was complete
  renderSequence(scene, settings, cache, nullptr);
  EXPECT_FALSE(fs::exists(leftover));
  EXPECT_NO_THROW(Sequence::open(seq).frame(1));
  // Below the top of a directory (a run's images/<scene>/<label>/, a report's tiles/) as well.
  fs::create_directories(dir / "images" / "scene" / "svgf");
  const fs::path deep = dir / "images" / "scene" / "svgf" / ("flip_0002.tmp" + dead + "@" + host + "_9.png");
  writeTextAtomically(deep, "partial");
  EXPECT_EQ(removeStaleTemporaries(dir), 0);
  EXPECT_EQ(removeStaleTemporariesBelow(dir), 1);
  EXPECT_FALSE(fs::exists(deep));
  // A run clears them when it starts in its directory.
  writeTextAtomically(deep, "partial");
  (void)checkRunOutputs(dir);
  EXPECT_FALSE(fs::exists(deep));
}

}  // namespace
}  // namespace arena
