// The capture importer under deterministic random mutation (always runs; the libFuzzer target
// tests/fuzz/capture_fuzzer.cpp explores further when clang is there). Every mutant of every file
// of the seed capture (capture.json, a frame, a reference, a gradient file, a stored output) must
// open, read and validate, or be rejected with an arena::Error; under ARENA_SANITIZE this also
// catches memory errors and undefined behaviour.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "tests/fuzz/capture_fuzz_target.hpp"
#include "tests/fuzz/mutations.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using fuzz::CaptureFile;

const char* kindName(CaptureFile kind) {
  switch (kind) {
    case CaptureFile::Description:
      return "capture.json";
    case CaptureFile::Frame:
      return "frame";
    case CaptureFile::Reference:
      return "reference";
    case CaptureFile::Gradients:
      return "gradients";
    case CaptureFile::Output:
      break;
  }
  return "output";
}

// An EXR mutant: half the time the edits fall in the header (the first 400 bytes: channel list,
// data window, compression), where a reader must check what it is told; else anywhere.
std::string mutateExr(const std::string& bytes, std::mt19937& rng) {
  if (std::uniform_int_distribution<int>(0, 1)(rng) == 0) return fuzz::mutateBytes(bytes, rng);
  const size_t head = std::min<size_t>(400, bytes.size());
  return fuzz::mutateBytes(bytes.substr(0, head), rng) + bytes.substr(head);
}

// Writes `bytes` into a copy of the seed capture as `kind`'s file and returns the error message
// ("" when it opened).
std::string openError(const fs::path& seed, const fs::path& work, CaptureFile kind, const std::string& bytes) {
  std::string message;
  fuzz::openMutatedCapture(seed, work, kind, bytes, &message);
  return message;
}

TEST(CaptureFuzz, TheSeedCaptureOpensAndValidates) {
  const fs::path dir = test::freshDir("capture_fuzz_seed");
  fuzz::writeSeedCapture(dir / "seed");
  EXPECT_TRUE(fuzz::openCapture(dir / "seed"));
  const Sequence seq = Sequence::open(dir / "seed");
  EXPECT_TRUE(seq.info().hasGradients);
  EXPECT_EQ(seq.capture().outputs.size(), 1u);
  // No check is at its limit: every check of the seed passes, so a mutant that fails one is news.
  for (const CaptureCheck& c : validateCapture(seq, readSequenceForEvaluation(seq)).checks)
    EXPECT_NE(c.status, CheckStatus::Fail) << c.name << ": " << c.detail;
}

// What the fuzzer found, each now an error naming the file.
TEST(CaptureFuzz, AnExrDeclaringAnImpossibleSizeIsRefusedNamingTheFile) {
  const fs::path dir = test::freshDir("capture_fuzz_size");
  fuzz::writeSeedCapture(dir / "seed");
  // The data window of a 6x4 image (min 0,0 max 5,3) rewritten to max.x = 99999: OpenEXR accepts
  // the header (its line-offset table is unchanged), and a wider window would ask for any memory.
  std::string frame = readText(fuzz::captureFileOf(CaptureFile::Frame, dir / "seed"));
  const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
  const size_t at = frame.find(key);
  ASSERT_NE(at, std::string::npos);
  const size_t values = at + key.size() + 4;  // after the attribute's size field
  const int32_t huge = 99999;
  std::memcpy(&frame[values + 8], &huge, 4);
  const std::string message = openError(dir / "seed", dir, CaptureFile::Frame, frame);
  EXPECT_NE(message.find("frame_0001.exr"), std::string::npos) << message;
  EXPECT_NE(message.find("100000x4"), std::string::npos) << message;
}

// A header attribute whose size field claims 2 GiB: OpenEXR 3.1 would allocate and zero-fill it
// before failing (seconds under the sanitizers); the size is checked against the file first.
TEST(CaptureFuzz, AnExrAttributeLargerThanItsFileIsRefusedNamingIt) {
  const fs::path dir = test::freshDir("capture_fuzz_attribute");
  fuzz::writeSeedCapture(dir / "seed");
  std::string frame = readText(fuzz::captureFileOf(CaptureFile::Frame, dir / "seed"));
  const std::string key = std::string("compression") + '\0' + "compression" + '\0';
  const size_t at = frame.find(key);
  ASSERT_NE(at, std::string::npos);
  const int32_t huge = 0x7fffffff;
  std::memcpy(&frame[at + key.size()], &huge, 4);
  const std::string message = openError(dir / "seed", dir, CaptureFile::Frame, frame);
  EXPECT_NE(message.find("frame_0001.exr: header attribute \"compression\" (\"compression\") "
                         "declares 2147483647 bytes"),
            std::string::npos)
      << message;
}

// Bytes that are no OpenEXR file (random, or another format renamed) are said to be none, naming
// the bytes found, where their garbage was read as header attributes named in control bytes.
TEST(CaptureFuzz, AFileThatIsNoOpenExrIsSaidToBeNone) {
  const fs::path dir = test::freshDir("capture_fuzz_magic");
  fuzz::writeSeedCapture(dir / "seed");
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + std::string(200, '\x1b');
  const std::string message = openError(dir / "seed", dir, CaptureFile::Frame, png);
  EXPECT_NE(message.find("frame_0001.exr: not an OpenEXR file (its first bytes are 89 50 4e 47; "
                         "an OpenEXR file starts 76 2f 31 01)"),
            std::string::npos)
      << message;
  EXPECT_NE(openError(dir / "seed", dir, CaptureFile::Frame, "v/").find("fewer than 4: 2 byte(s)"),
            std::string::npos);
}

TEST(CaptureFuzz, RandomMutationsOfEachFileOpenOrAreRejectedNamingAnError) {
  constexpr int kMutantsPerFile = 120;  // 5 files: 600 opens of a 6x4 capture, seconds in Release
  std::mt19937 rng(29);                 // fixed: the same mutants on every run
  const fs::path dir = test::freshDir("capture_fuzz");
  fuzz::writeSeedCapture(dir / "seed");
  int opened = 0, rejected = 0;
  for (int k = 0; k < fuzz::kCaptureFileKinds; ++k) {
    const auto kind = CaptureFile(k);
    const std::string seed = readText(fuzz::captureFileOf(kind, dir / "seed"));
    for (int i = 0; i < kMutantsPerFile; ++i) {
      const std::string mutant =
          kind == CaptureFile::Description
              ? (std::uniform_int_distribution<int>(0, 2)(rng) == 0 ? fuzz::mutateBytes(seed, rng)
                                                                    : fuzz::mutateJson(seed, rng))
              : mutateExr(seed, rng);
      try {
        std::string message;
        (fuzz::openMutatedCapture(dir / "seed", dir, kind, mutant, &message) ? opened : rejected)++;
        if (i < 3 && !message.empty()) std::printf("  %s: %s\n", kindName(kind), message.c_str());
      } catch (const std::exception& e) {
        ADD_FAILURE() << kindName(kind) << " mutant " << i << " escaped as a non-arena exception: " << e.what();
      }
    }
  }
  // Both outcomes must occur, or the mutator is not exercising the importer (most EXR mutants break
  // the compressed pixels, so fewer open).
  EXPECT_GT(opened, 20);
  EXPECT_GT(rejected, 150);
  RecordProperty("mutants", opened + rejected);
  std::printf("capture fuzz: %d mutants, %d opened, %d rejected\n", opened + rejected, opened, rejected);
}

}  // namespace
}  // namespace arena
