// Text from files and users, made fit for a one-line message.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace kanedyn::io {

/// `text` made safe to print on one line: control bytes escaped (\n, \r, \t, \xNN for the
/// rest and DEL), likewise the C1 controls (\u0080..\u009f), the line and paragraph
/// separators (\u2028, \u2029), the byte order mark (\ufeff), zero-width characters and the
/// bidirectional controls, and bytes that are not UTF-8 as \xNN; so printing it cannot move
/// the cursor, change colours, end a line, hide a character or reorder the text. Cut after
/// max_chars bytes of input, at a character boundary, with "..." appended (0: no limit).
std::string printable(std::string_view text, std::size_t max_chars = 0);

/// Reads `text`, a plain decimal number (an optional sign, digits with an optional point, an
/// optional exponent; no hex, inf or nan), into `value`. Returns "" when it is one and fits a
/// double, else why not, to follow the quoted text in a message: "is not a decimal number",
/// "overflows a double" or "is too small for a double (it underflows)". Which of the last two is
/// told by the number's decimal magnitude, so 0.000...01 with 400 zeros underflows whether or
/// not it has an exponent.
std::string read_decimal(std::string_view text, double& value);

/// Levenshtein distance (insertions, deletions, substitutions), for "did you mean" hints.
std::size_t edit_distance(std::string_view a, std::string_view b);

/// The word of `choices` nearest to `word` within max_distance edits (the first of equals),
/// or "" when none is that near.
std::string closest_word(std::string_view word, const std::vector<std::string>& choices,
                         std::size_t max_distance = 2);

}  // namespace kanedyn::io
