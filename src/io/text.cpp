#include "kanedyn/io/text.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

namespace kanedyn::io {

namespace {

/// Code points that move no cursor and show nothing, or turn the text's direction: a byte
/// order mark, zero-width spaces and joiners, the line and paragraph separators, and the
/// bidirectional embeddings, overrides and isolates. Shown escaped, a message cannot hide
/// them (a BOM before a key) or reorder what follows.
bool invisible(unsigned cp) {
  return cp == 0xfeff || (cp >= 0x200b && cp <= 0x200f) || cp == 0x2028 || cp == 0x2029 ||
         (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2060 && cp <= 0x2064) ||
         (cp >= 0x2066 && cp <= 0x2069);
}

}  // namespace

std::string printable(std::string_view s, std::size_t max_chars) {
  const std::size_t max = max_chars == 0 ? s.size() : max_chars;
  static const char* hex = "0123456789abcdef";
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(s[i]); };
  std::string out;
  std::size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = byte(i);
    std::size_t width = c < 0x80 ? 1 : c >= 0xf0 ? 4 : c >= 0xe0 ? 3 : c >= 0xc0 ? 2 : 0;
    for (std::size_t k = 1; k < width; ++k)
      if (i + k >= s.size() || (byte(i + k) & 0xc0) != 0x80) width = 0;
    if (i + std::max<std::size_t>(width, 1) > max) break;
    if (width == 0) {
      out += std::string("\\x") + hex[c >> 4] + hex[c & 15];
      ++i;
      continue;
    }
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c < 0x20 || c == 0x7f) {
      out += std::string("\\x") + hex[c >> 4] + hex[c & 15];
    } else if (c == 0xc2 && byte(i + 1) <= 0x9f) {  // U+0080..U+009F
      out += std::string("\\u00") + hex[byte(i + 1) >> 4] + hex[byte(i + 1) & 15];
    } else if (const unsigned cp = width == 3 ? ((c & 0x0fu) << 12) | ((byte(i + 1) & 0x3fu) << 6) |
                                                    (byte(i + 2) & 0x3fu)
                                              : 0u;
               invisible(cp)) {
      out += std::string("\\u") + hex[cp >> 12] + hex[(cp >> 8) & 15] + hex[(cp >> 4) & 15] +
             hex[cp & 15];
    } else {
      out.append(s.data() + i, width);
    }
    i += width;
  }
  if (i < s.size()) out += "...";
  return out;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string closest_word(std::string_view word, const std::vector<std::string>& choices,
                         std::size_t max_distance) {
  std::string best;
  std::size_t best_distance = max_distance + 1;
  for (const std::string& choice : choices)
    if (const std::size_t d = edit_distance(word, choice); d < best_distance) {
      best = choice;
      best_distance = d;
    }
  return best;
}

namespace {

/// The decimal exponent of the first nonzero digit of a plain decimal number (1 for 12.5,
/// -3 for 0.00125): the value lies in [10^(e-1), 10^e). Saturates far beyond any double.
long long decimal_magnitude(std::string_view s) {
  std::size_t i = (!s.empty() && (s[0] == '+' || s[0] == '-')) ? 1 : 0;
  long long before_point = 0, leading_zeros_after = 0;
  bool point = false, nonzero = false;
  for (; i < s.size() && (std::isdigit(static_cast<unsigned char>(s[i])) || s[i] == '.'); ++i) {
    if (s[i] == '.') {
      point = true;
      continue;
    }
    if (s[i] != '0') nonzero = true;
    if (!point && nonzero) ++before_point;
    if (point && !nonzero) ++leading_zeros_after;
  }
  long long exponent = 0;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    const bool negative = i < s.size() && s[i] == '-';
    if (i < s.size() && (s[i] == '-' || s[i] == '+')) ++i;
    for (; i < s.size() && std::isdigit(static_cast<unsigned char>(s[i])); ++i)
      exponent = std::min(exponent * 10 + (s[i] - '0'), 1000000000LL);
    if (negative) exponent = -exponent;
  }
  return (before_point > 0 ? before_point : -leading_zeros_after) + exponent;
}

}  // namespace

std::string read_decimal(std::string_view text, double& value) {
  const char* first = text.data() + (!text.empty() && text[0] == '+' ? 1 : 0);
  const char* last = text.data() + text.size();
  const bool signed_after_plus = first != text.data() && first != last && *first == '-';
  if (first == last || signed_after_plus ||
      !(std::isdigit(static_cast<unsigned char>(*first)) || *first == '-' || *first == '.'))
    return "is not a decimal number";
  const auto [end, error] = std::from_chars(first, last, value, std::chars_format::general);
  if (error == std::errc::result_out_of_range && end == last)
    return decimal_magnitude(text) < 0 ? "is too small for a double (it underflows)"
                                       : "overflows a double";
  if (error != std::errc() || end != last || !std::isfinite(value))
    return "is not a decimal number";
  return "";
}

}  // namespace kanedyn::io
