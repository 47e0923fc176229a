// A check of XML text before it reaches TinyXML 2.6, the parser under liburdfdom: TinyXML
// recurses once per element level (and its destructor once more), so a deeply nested file
// overflows the stack, and its parse is quadratic in the depth. scan_xml() finds the nesting
// depth in one pass, without recursion, so that the text can be refused before it is parsed
// (and an element's attributes, whose duplicate check is quadratic too).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace kanedyn::io::detail {

/// The most attributes one element may have: TinyXML compares each attribute's name with the
/// element's others, quadratic in their number. A URDF element has at most 6 (an inertia).
inline constexpr int kMaxXmlAttributes = 100;

/// What scan_xml() found. The depth counts elements: the root element is at depth 1, a child
/// of it at 2 (a self-closing one too).
struct XmlScan {
  int max_depth = 0;       ///< the deepest element seen, at most the limit + 1
  std::string problem;     ///< why the text is refused; empty when it may go to the parser
  int line = 0;            ///< where the problem is: 1-based line ...
  int column = 0;          ///< ... and column, in characters
  std::size_t offset = 0;  ///< ... and byte offset
};

/// Scans `text` as TinyXML 2.6 tokenizes it and refuses it (problem set) when an element is
/// nested deeper than `limit` or has more than kMaxXmlAttributes attributes, or when the text holds
/// a NUL byte, is not valid UTF-8, or holds U+FEFF after its start or U+FFFE or U+FFFF.
///
/// The depth must never be less than the depth TinyXML's recursion reaches, so the scan follows
/// TinyXML's own reading, quirks included, and not XML's: a comment ends at the first "-->", a
/// CDATA section at the first "]]>"; `<!...`, `<?...` (but `<?xml`, read like a tag's
/// attributes), and `<` followed by anything but a letter, '_', a byte >= 127 or '/' are skipped
/// to the first '>'; quoted attribute values may hold '>' and "/>"; a numeric character
/// reference (`&#...;`, `&#x...;`) runs to the next ';' whatever lies between, as long as the
/// characters just before the ';' are digits back to a '#' or 'x'. The encoding checks make
/// TinyXML's two modes (UTF-8, which steps over a multi-byte character as a whole and skips
/// byte order marks as white space, and single byte) read the text the same way, and a NUL
/// would end TinyXML's text early. Where TinyXML stops with an error, the scan stops too (what
/// follows is never parsed): the depth up to there is TinyXML's. Linear in the text's length.
XmlScan scan_xml(std::string_view text, int limit);

}  // namespace kanedyn::io::detail
