// The scene parser under deterministic random mutation (always runs; the libFuzzer target in
// tests/fuzz/ explores further when clang is there). Every mutant of every shipped scene must
// either parse into a scene that keeps the parser's invariants or be rejected with an arena::Error
// naming the file; under ARENA_SANITIZE this also catches memory errors and undefined behaviour.
#include <gtest/gtest.h>

#include <random>

#include "core/atomic_file.hpp"
#include "tests/fuzz/scene_fuzz_target.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

using nlohmann::json;

// Values that broke parsers before: wrapping integers, float overflow, zeros, wrong types, NaN
// spelled as text, deep nesting.
json nastyValue(std::mt19937& rng) {
  static const std::vector<json> values = {0,
                                           -1,
                                           1,
                                           2147483647LL,
                                           2147483648LL,
                                           4294967296LL,
                                           4294967300LL,
                                           -2147483649LL,
                                           18446744073709551615ULL,
                                           1e39,
                                           -1e39,
                                           1e30,
                                           1e-45,
                                           0.5,
                                           -0.0,
                                           16384,
                                           16385,
                                           100001,
                                           "",
                                           "NaN",
                                           "inf",
                                           true,
                                           nullptr,
                                           json::array(),
                                           json::object(),
                                           json::array({0, 0, 0}),
                                           json::array({1e39, 0, 0}),
                                           json::array({0, 1, 0}),
                                           json::array({0, -1, 0}),
                                           json::array({1, 2}),
                                           json::array({4294967300LL, 8}),
                                           "/dev/zero",
                                           "quad",
                                           "mesh",
                                           json::array({json::array({json::array({1})})})};
  return values[std::uniform_int_distribution<size_t>(0, values.size() - 1)(rng)];
}

// Every JSON pointer in the document (objects and arrays included).
void collectPointers(const json& j, const json::json_pointer& at,
                     std::vector<json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object())
    for (auto& [k, v] : j.items()) collectPointers(v, at / k, out);
  else if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) collectPointers(j[i], at / i, out);
}

// One structural mutation (replace a value, delete a member, duplicate an array element, add an
// unknown key) or one byte-level mutation of the serialised text.
std::string mutate(const json& scene, std::mt19937& rng) {
  std::uniform_int_distribution<int> kind(0, 5);
  json doc = scene;
  std::vector<json::json_pointer> pointers;
  collectPointers(doc, json::json_pointer(), pointers);
  auto pick = [&] {
    return pointers[std::uniform_int_distribution<size_t>(1, pointers.size() - 1)(rng)];
  };
  switch (kind(rng)) {
    case 0:
    case 1:
      doc[pick()] = nastyValue(rng);
      break;
    case 2: {
      json::json_pointer p = pick();
      json& parent = doc[p.parent_pointer()];
      if (parent.is_object())
        parent.erase(p.back());
      else if (parent.is_array() && !parent.empty())
        parent.erase(parent.begin());
      break;
    }
    case 3: {
      json::json_pointer p = pick();
      json& parent = doc[p.parent_pointer()];
      if (parent.is_array() && !parent.empty())
        parent.push_back(parent.front());
      else if (parent.is_object())
        parent["unexpected"] = 1;
      break;
    }
    default: {
      std::string text = doc.dump();
      const int edits = std::uniform_int_distribution<int>(1, 4)(rng);
      for (int e = 0; e < edits && !text.empty(); ++e) {
        size_t at = std::uniform_int_distribution<size_t>(0, text.size() - 1)(rng);
        static const std::string alphabet = "{}[]\":,0123456789.eE-+ntfaxyz\\\x01\xff";
        char c = alphabet[std::uniform_int_distribution<size_t>(0, alphabet.size() - 1)(rng)];
        switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
          case 0:
            text[at] = c;
            break;
          case 1:
            text.insert(at, 1, c);
            break;
          default:
            text.erase(at, 1);
        }
      }
      return text;
    }
  }
  return doc.dump();
}

TEST(SceneFuzz, RandomMutationsOfShippedScenesAreParsedOrRejectedCleanly) {
  constexpr int kMutantsPerScene =
      400;  // per shipped scene (12 today: 4800 mutants), well under a second in Release
  std::mt19937 rng(16);  // fixed: the same mutants on every run
  int parsed = 0, rejected = 0;
  for (const std::string& file : listSceneFiles(defaultScenesDir())) {
    const json scene = json::parse(readText(file));
    for (int i = 0; i < kMutantsPerScene; ++i) {
      const std::string text = mutate(scene, rng);
      try {
        (fuzz::parseSceneOrReject(text) ? parsed : rejected)++;
      } catch (const std::exception& e) {
        ADD_FAILURE() << file << " mutant " << i
                      << " escaped as a non-arena exception: " << e.what() << "\n"
                      << text.substr(0, 2000);
      }
    }
  }
  // Both outcomes must occur, or the mutator is not exercising the parser.
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 1000);
  RecordProperty("mutants", parsed + rejected);
  std::printf("scene fuzz: %d mutants, %d parsed, %d rejected\n", parsed + rejected, parsed,
              rejected);
}

// Scenes that parse must also render: a 4x4 frame of a sample of accepted mutants through Embree
// (the camera, transform and radiance bounds exist so that nothing accepted reaches Embree's
// abort).
TEST(SceneFuzz, AcceptedMutantsRender) {
  std::mt19937 rng(1616);
  int rendered = 0;
  for (const std::string& file : listSceneFiles(defaultScenesDir())) {
    const json scene = json::parse(readText(file));
    int renderedHere = 0;
    for (int i = 0; i < 200 && renderedHere < 4; ++i) {
      const std::string text = mutate(scene, rng);
      Scene s;
      try {
        s = parseScene(text, file);
      } catch (const Error&) {
        continue;
      }
      RenderSettings settings;
      settings.width = settings.height = 4;
      settings.frames = 2;
      try {
        SequenceRenderer renderer(s, settings);
        auto frame = renderer.renderFrame(1);
        EXPECT_EQ(frame.frame.width(), 4);
      } catch (const Error&) {
        // A clear rejection (e.g. an unreadable mesh) is fine.
      }
      ++renderedHere;
      ++rendered;
    }
  }
  EXPECT_GT(rendered, 20);
}

}  // namespace
}  // namespace arena
