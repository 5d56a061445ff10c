// core/text.hpp: text from outside made valid UTF-8, and cut at character boundaries.
#include "core/text.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <stdexcept>

namespace arena {
namespace {

const std::string kFffd = "\xEF\xBF\xBD";

TEST(Text, WellFormedTextIsUnchangedAndEveryMalformedByteIsReplaced) {
  for (const std::string ok :
       {"", "plain", "caf\xC3\xA9", "\xE2\x82\xAC 5", "\xF0\x9F\x98\x80", "\xF4\x8F\xBF\xBF"})
    EXPECT_EQ(validUtf8(ok), ok);
  EXPECT_EQ(validUtf8("a\xFF"
                      "b"),
            "a" + kFffd + "b");
  EXPECT_EQ(validUtf8("\x80"), kFffd);                          // a stray continuation byte
  EXPECT_EQ(validUtf8("\xC3"), kFffd);                          // a cut two-byte character
  EXPECT_EQ(validUtf8("\xC0\xAF"), kFffd + kFffd);              // an overlong '/'
  EXPECT_EQ(validUtf8("\xE0\x80\xAF"), kFffd + kFffd + kFffd);  // an overlong three-byte form
  EXPECT_EQ(validUtf8("\xED\xA0\x80"), kFffd + kFffd + kFffd);  // a surrogate (U+D800)
  EXPECT_EQ(validUtf8("\xF4\x90\x80\x80"), kFffd + kFffd + kFffd + kFffd);  // beyond U+10FFFF
  // NUL is well-formed UTF-8 but ends a C string: an error's what() lost everything after it.
  const std::string nul("a\0b", 3);
  EXPECT_EQ(validUtf8(nul), "a" + kFffd + "b");
  EXPECT_EQ(std::string(std::runtime_error(validUtf8(nul)).what()), "a" + kFffd + "b");
  // Whatever the bytes, the result is text a JSON writer accepts.
  std::string every;
  for (int b = 0; b < 256; ++b) every += char(b);
  EXPECT_NO_THROW(static_cast<void>(nlohmann::json(validUtf8(every + every)).dump()));
}

TEST(Text, AnExcerptIsCutBetweenCharacters) {
  const std::string e = "\xC3\xA9";    // two bytes
  const std::string text = e + e + e;  // six bytes
  EXPECT_EQ(utf8Excerpt(text, 6, true), text);
  EXPECT_EQ(utf8Excerpt(text, 5, true), e + e);   // the cut would split the first: it is left out
  EXPECT_EQ(utf8Excerpt(text, 5, false), e + e);  // and from the start, the last
  EXPECT_EQ(utf8Excerpt("abcdef", 3, true), "def");
  EXPECT_EQ(utf8Excerpt("abcdef", 3, false), "abc");
  EXPECT_EQ(utf8Excerpt("ab\xFF", 8, true), "ab" + kFffd);
}

TEST(Text, DisplayWidthCountsCharactersAndPaddingUsesIt) {
  EXPECT_EQ(displayWidth(""), 0u);
  EXPECT_EQ(displayWidth("svgf"), 4u);
  EXPECT_EQ(displayWidth("σ=2"), 3u);           // a two-byte character counts once
  EXPECT_EQ(displayWidth("\xE2\x80\x93"), 1u);  // the missing value's dash, three bytes
  EXPECT_EQ(paddedText("σ", 3), "σ  ");
  EXPECT_EQ(paddedText("abcd", 2), "abcd");  // never cut
}

TEST(Text, ClosestNameIsWithinAFewEditsAndNeverBetweenShortNames) {
  EXPECT_EQ(closestName("color.r", {"color.R", "color.G", "normal.X"}), "color.R");  // case aside
  EXPECT_EQ(closestName("roughnes.X", {"roughness", "depth.Z"}), "roughness");       // two edits
  EXPECT_EQ(closestName("camra", {"camera", "frames"}), "camera");
  EXPECT_EQ(closestName("albedo", {"camera", "frames"}), "");  // nothing close
  EXPECT_EQ(closestName("a", {"b"}), "");  // one letter: another name, not a slip
  EXPECT_EQ(closestName("A", {"a"}), "a");
}

TEST(Text, ShellWordQuotesWhatAShellWouldSplitOrExpand) {
  EXPECT_EQ(shellWord("runs/cache-2.1"), "runs/cache-2.1");
  EXPECT_EQ(shellWord("/tmp/my cache"), "'/tmp/my cache'");
  EXPECT_EQ(shellWord("Ann's"), "'Ann'\\''s'");
  EXPECT_EQ(shellWord("$HOME/*"), "'$HOME/*'");
  EXPECT_EQ(shellWord("~/cache"), "'~/cache'");
  EXPECT_EQ(shellWord(""), "''");
}

TEST(Text, EditDistanceCountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(editDistance("", ""), 0u);
  EXPECT_EQ(editDistance("camera", "camera"), 0u);
  EXPECT_EQ(editDistance("camra", "camera"), 1u);    // one insertion
  EXPECT_EQ(editDistance("camera", "camra"), 1u);    // symmetric
  EXPECT_EQ(editDistance("kitten", "sitting"), 3u);  // two substitutions, one insertion
  EXPECT_EQ(editDistance("", "abc"), 3u);
  EXPECT_EQ(editDistance("ab", "ba"), 1u);      // a swap of neighbours is one edit
  EXPECT_EQ(editDistance("veiw", "view"), 1u);  // the commonest typo
  EXPECT_EQ(editDistance("fsp", "fps"), 1u);
  EXPECT_EQ(editDistance("ca", "abc"), 3u);  // optimal string alignment: no substring edited twice
  EXPECT_EQ(closestName("veiw", {"projection", "view", "jitter"}), "view");
}

}  // namespace
}  // namespace arena
