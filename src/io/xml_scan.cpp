// scan_xml (xml_scan.hpp): TinyXML 2.6's tokenizer (tinyxmlparser.cpp) followed step by step,
// with a depth counter in place of its recursion.
#include "xml_scan.hpp"

#include <string>

namespace kanedyn::io::detail {
namespace {

/// TinyXML's IsWhiteSpace in the C locale (isspace, '\n' and '\r').
bool is_space(unsigned char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}
bool is_ascii_alpha(unsigned char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool is_digit(unsigned char c) { return c >= '0' && c <= '9'; }
bool is_hex(unsigned char c) {
  return is_digit(c) || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}
/// TinyXML's IsAlpha and IsAlphaNum: every byte from 127 up is a letter.
bool is_alpha(unsigned char c) { return c >= 127 || is_ascii_alpha(c); }
bool is_alnum(unsigned char c) { return is_alpha(c) || is_digit(c); }

/// Where the text is not UTF-8 as the scan needs it, the offset and the problem.
bool check_encoding(std::string_view text, std::size_t& at, std::string& problem) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = byte(i);
    at = i;
    if (c == 0) {
      problem = "a NUL byte (a URDF file is text; the XML parser would stop reading here)";
      return false;
    }
    if (c < 0x80) {
      ++i;
      continue;
    }
    int length = 0;
    unsigned code = 0;
    if (c >= 0xc2 && c <= 0xdf) {
      length = 2;
      code = c & 0x1fu;
    } else if (c >= 0xe0 && c <= 0xef) {
      length = 3;
      code = c & 0x0fu;
    } else if (c >= 0xf0 && c <= 0xf4) {
      length = 4;
      code = c & 0x07u;
    }
    bool valid = length > 0 && i + static_cast<std::size_t>(length) <= text.size();
    for (int k = 1; valid && k < length; ++k) {
      const unsigned char d = byte(i + static_cast<std::size_t>(k));
      valid = (d & 0xc0u) == 0x80u;
      code = (code << 6) | (d & 0x3fu);
    }
    // Overlong forms, UTF-16 surrogates and code points above U+10FFFF are not UTF-8.
    if (valid)
      valid = !(length == 3 && code < 0x800) && !(length == 4 && code < 0x10000) &&
              !(code >= 0xd800 && code <= 0xdfff) && code <= 0x10ffff;
    if (!valid) {
      problem = "not valid UTF-8 (kanedyn reads a URDF file as UTF-8 text)";
      return false;
    }
    // TinyXML's UTF-8 mode skips these three as white space, its other mode does not.
    if ((code == 0xfeff && i != 0) || code == 0xfffe || code == 0xffff) {
      problem = code == 0xfeff
                    ? "U+FEFF (a byte order mark) after the start of the file"
                    : std::string("the noncharacter U+FFF") + (code == 0xfffe ? "E" : "F");
      return false;
    }
    i += static_cast<std::size_t>(length);
  }
  return true;
}

/// The 1-based line and column (in characters) of byte `offset`.
void position(std::string_view text, std::size_t offset, int& line, int& column) {
  line = 1;
  column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n' || (c == '\r' && (i + 1 == text.size() || text[i + 1] != '\n'))) {
      ++line;
      column = 1;
    } else if (c != '\r' && (static_cast<unsigned char>(c) & 0xc0u) != 0x80u) {
      ++column;
    }
  }
}

class Scanner {
 public:
  Scanner(std::string_view text, int limit) : text_(text), limit_(limit) {}

  /// The offset where the depth first exceeds the limit, or npos.
  std::size_t run() {
    // A byte order mark switches TinyXML to UTF-8 and is skipped.
    if (text_.substr(0, 3) == "\xef\xbb\xbf") i_ = 3;
    while (ok_) {
      skip_space();
      if (depth_ == 0) {
        // The document: nodes and white space; anything else ends TinyXML's parse.
        if (at(i_) != '<') return npos;
        node();
      } else {
        // An element's content: text, nodes, and its end tag.
        if (i_ >= text_.size()) return npos;  // no end tag: TinyXML's error
        if (at(i_) != '<') {
          text_content();
        } else if (at(i_ + 1) == '/') {
          // "</name>" ends the element; a different name is TinyXML's error, after which
          // nothing is read, so the name need not be compared.
          if (!skip_past('>', i_ + 2)) return npos;
          --depth_;
        } else {
          node();
        }
      }
      if (too_deep_ != npos) return too_deep_;
    }
    return npos;
  }

  int max_depth() const { return max_depth_; }
  /// Whether run()'s offset is an element's attribute past kMaxXmlAttributes (else too deep).
  bool too_many_attributes() const { return too_many_attributes_; }

 private:
  static constexpr std::size_t npos = std::string_view::npos;

  /// The byte at i, 0 past the end (TinyXML reads a C string).
  unsigned char at(std::size_t i) const {
    return i < text_.size() ? static_cast<unsigned char>(text_[i]) : 0;
  }
  bool starts(std::size_t i, std::string_view s) const { return text_.substr(i, s.size()) == s; }
  bool starts_ignoring_case(std::size_t i, std::string_view s) const {
    for (std::size_t k = 0; k < s.size(); ++k) {
      unsigned char c = at(i + k);
      if (c >= 'A' && c <= 'Z') c = static_cast<unsigned char>(c - 'A' + 'a');
      if (c != static_cast<unsigned char>(s[k])) return false;
    }
    return true;
  }
  void skip_space() {
    while (is_space(at(i_))) ++i_;
  }
  /// i_ just past the first `c` at or after `from`; false (TinyXML's end of input) if none.
  bool skip_past(char c, std::size_t from) {
    const std::size_t k = text_.find(c, from);
    if (k == npos) return stop();
    i_ = k + 1;
    return true;
  }
  bool skip_past(std::string_view s, std::size_t from) {
    const std::size_t k = text_.find(s, from);
    if (k == npos) return stop();
    i_ = k + s.size();
    return true;
  }
  /// TinyXML stops here (an error, or the end of the text): so does the scan.
  bool stop() {
    ok_ = false;
    return false;
  }

  /// TinyXML's Identify and the node's Parse, at a '<' (not "</" inside an element).
  void node() {
    if (starts_ignoring_case(i_, "<?xml")) {
      declaration();
    } else if (starts(i_, "<!--")) {
      skip_past("-->", i_ + 4);
    } else if (starts(i_, "<![CDATA[")) {
      skip_past("]]>", i_ + 9);
    } else if (is_alpha(at(i_ + 1)) || at(i_ + 1) == '_') {
      element();
    } else {
      // TiXmlUnknown: "<!DOCTYPE ...>", "<?pi ...>", "</x>" outside any element, "<1", ...
      skip_past('>', i_ + 1);
    }
  }

  /// TinyXML's ReadName at i_: false if no name starts there.
  bool name() {
    if (!(is_alpha(at(i_)) || at(i_) == '_')) return false;
    while (is_alnum(at(i_)) || at(i_) == '_' || at(i_) == '-' || at(i_) == '.' || at(i_) == ':')
      ++i_;
    return true;
  }

  /// TinyXML's GetChar on an '&' (GetEntity), in text and quoted values. A numeric reference
  /// runs to the next ';': the characters before it must be digits back to the '#' (hex digits
  /// back to an 'x'), and what lies between the reference's start and those is skipped
  /// unread. Named and unknown references take no markup with them.
  bool reference() {
    if (at(i_ + 1) != '#' || at(i_ + 2) == 0) {
      ++i_;
      return true;
    }
    const bool hex = at(i_ + 2) == 'x';
    if (hex && at(i_ + 3) == 0) return stop();
    const std::size_t semicolon = text_.find(';', i_ + (hex ? 3 : 2));
    if (semicolon == npos) return stop();
    std::size_t k = semicolon - 1;
    while (hex ? at(k) != 'x' : at(k) != '#') {
      if (!(hex ? is_hex(at(k)) : is_digit(at(k)))) return stop();
      --k;
    }
    i_ = semicolon + 1;
    return true;
  }

  /// TinyXML's ReadText up to the delimiter `end` (a quote, or '<' for text), references
  /// read as above; i_ at the delimiter.
  bool read_text(unsigned char end) {
    while (at(i_) != 0 && at(i_) != end) {
      if (at(i_) == '&') {
        if (!reference()) return false;
      } else {
        ++i_;
      }
    }
    return at(i_) != 0 || stop();
  }

  /// Text in an element's content, up to the next '<'.
  void text_content() { read_text('<'); }

  /// TiXmlAttribute::Parse: name, '=', and a quoted or bare value.
  bool attribute() {
    skip_space();
    if (!name()) return stop();
    skip_space();
    if (at(i_) != '=') return stop();
    ++i_;
    skip_space();
    const unsigned char q = at(i_);
    if (q == '"' || q == '\'') {
      ++i_;
      if (!read_text(q)) return false;
      ++i_;
      return true;
    }
    // A bare value runs to white space, '/' or '>'; a quote in it is an error.
    while (at(i_) != 0 && !is_space(at(i_)) && at(i_) != '/' && at(i_) != '>') {
      if (at(i_) == '"' || at(i_) == '\'') return stop();
      ++i_;
    }
    return true;
  }

  /// TiXmlElement::Parse from its '<': the tag, then (after '>') the content, whose end tag the
  /// main loop reads.
  void element() {
    ++depth_;
    if (depth_ > max_depth_) max_depth_ = depth_;
    if (depth_ > limit_) {
      too_deep_ = i_;
      return;
    }
    ++i_;
    if (!name() || at(i_) == 0) {
      stop();
      return;
    }
    int attributes = 0;
    for (;;) {
      skip_space();
      const unsigned char c = at(i_);
      if (c == 0) {
        stop();
        return;
      }
      if (c == '/') {
        if (at(i_ + 1) != '>') {
          stop();
          return;
        }
        i_ += 2;
        --depth_;  // self-closing: no content
        return;
      }
      if (c == '>') {
        ++i_;
        return;  // the content follows, at depth_
      }
      // TinyXML checks each attribute's name against the element's others: quadratic in
      // their number (60,000 of them took 11 s).
      if (++attributes > kMaxXmlAttributes) {
        too_deep_ = i_;
        too_many_attributes_ = true;
        return;
      }
      if (!attribute()) return;
      if (at(i_) == 0) {
        stop();
        return;
      }
    }
  }

  /// TiXmlDeclaration::Parse from "<?xml": its known attributes read as a tag's, other words
  /// skipped, up to the first '>' outside them.
  void declaration() {
    i_ += 5;
    while (at(i_) != 0) {
      if (at(i_) == '>') {
        ++i_;
        return;
      }
      skip_space();
      if (starts_ignoring_case(i_, "version") || starts_ignoring_case(i_, "encoding") ||
          starts_ignoring_case(i_, "standalone")) {
        if (!attribute()) return;
      } else {
        while (at(i_) != 0 && at(i_) != '>' && !is_space(at(i_))) ++i_;
      }
    }
    stop();
  }

  std::string_view text_;
  int limit_;
  std::size_t i_ = 0;
  int depth_ = 0;
  int max_depth_ = 0;
  bool ok_ = true;
  std::size_t too_deep_ = npos;  ///< where the text is refused: too deep, or too many attributes
  bool too_many_attributes_ = false;
};

}  // namespace

XmlScan scan_xml(std::string_view text, int limit) {
  XmlScan scan;
  std::size_t at = 0;
  if (!check_encoding(text, at, scan.problem)) {
    scan.offset = at;
    position(text, at, scan.line, scan.column);
    return scan;
  }
  Scanner scanner(text, limit);
  const std::size_t too_deep = scanner.run();
  scan.max_depth = scanner.max_depth();
  if (too_deep != std::string_view::npos) {
    scan.offset = too_deep;
    position(text, too_deep, scan.line, scan.column);
    scan.problem = scanner.too_many_attributes()
                       ? "an element with more than " + std::to_string(kMaxXmlAttributes) +
                             " attributes, the limit for a URDF file (an element needs at most 6)"
                       : "elements nested deeper than " + std::to_string(limit) +
                             " levels, the limit for a URDF file (a robot needs under 20)";
  }
  return scan;
}

}  // namespace kanedyn::io::detail
