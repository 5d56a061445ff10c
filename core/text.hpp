#pragma once
// Text that comes from outside (an external denoiser's messages and output, a plugin's error
// buffer) made safe to store: results.json is UTF-8, and one stray byte must not lose a run.
#include <string>
#include <string_view>
#include <vector>

namespace arena {

// `text` with every byte that does not belong to a well-formed UTF-8 sequence (a stray or cut
// continuation byte, an overlong form, a surrogate, a code point beyond U+10FFFF) replaced by
// U+FFFD, and NUL too (it would end the text wherever it passes as a C string, an error's what()
// first of all); well-formed text without NUL is returned unchanged.
std::string validUtf8(std::string_view text);

// At most `maxBytes` bytes of `text`'s end (or start: `fromEnd` false), cut at a character
// boundary, as validUtf8.
std::string utf8Excerpt(std::string_view text, size_t maxBytes, bool fromEnd);

// The shortest decimal that reads back as `x` ("2" for 2.0, "0.05", "1e-05"), -0 written as "0":
// one text per number, whatever was typed (a parameter's value in a label).
std::string shortestText(double x);

// The characters of UTF-8 `text` (its code points; continuation bytes not counted): the columns
// it takes in a console, for the Latin, Greek and Cyrillic text of labels and names.
size_t displayWidth(std::string_view text);
// `text` followed by spaces up to `width` characters (displayWidth), unchanged if as wide or wider:
// what std::setw does for bytes.
std::string paddedText(std::string_view text, size_t width);

// The number of single-character insertions, deletions, substitutions and swaps of two neighbours
// that turn `a` into `b` (optimal string alignment: Levenshtein with transpositions, each
// substring edited once): how an error message finds the misspelling of a name it expected
// ("veiw" is one swap from "view").
size_t editDistance(std::string_view a, std::string_view b);

// `text` without the spaces and tabs around it (a writer's layout, as in "[2, 4]").
std::string trimmed(const std::string& text);

// Of `names`, the one closest to `name` (case aside) if within one edit of a name of three or four
// letters, two of a longer one, or differing only in case from a shorter one; else empty: what a
// user who typed `name` most likely meant. (One edit of a one- or two-letter name is another name:
// "a" and "b" are both fields of a results pair.) Bytes are compared: a slip in a non-ASCII name
// counts as the bytes of its character.
std::string closestName(const std::string& name, const std::vector<std::string>& names);

// `word` as one word of a POSIX shell command line: unchanged when it holds only letters, digits
// and `_-./:=,+@%`, else in single quotes with each `'` written '\'' (a suggested command a user
// pastes must name the same path, whatever characters it holds).
std::string shellWord(const std::string& word);

}  // namespace arena
