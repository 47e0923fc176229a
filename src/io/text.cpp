#include "kanedyn/io/text.hpp"

#include <algorithm>

namespace kanedyn::io {

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
    } else if (c == 0xe2 && byte(i + 1) == 0x80 && (byte(i + 2) == 0xa8 || byte(i + 2) == 0xa9)) {
      out += byte(i + 2) == 0xa8 ? "\\u2028" : "\\u2029";
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

}  // namespace kanedyn::io
