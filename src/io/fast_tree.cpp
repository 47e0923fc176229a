// The fast front end of the model loader (model_tree.hpp): a scanner for the subset of YAML and
// JSON that model files are written in, filling the same Tree as libyaml's event parser.
//
// What it reads:
//  - printable ASCII (0x20-0x7e), LF and CRLF breaks, space indentation; other UTF-8
//    characters in comments and double-quoted scalars (not NEL, LS or PS, which libyaml
//    counts as breaks, nor a byte-order mark);
//  - block mappings whose keys are plain or double-quoted scalars on one line, followed by
//    ": " or ":" and a break; block sequences ("- "), also the entries of a mapping at its own
//    column ("key:\n- a"), and "- key: value" entries (a mapping starting after the dash);
//  - flow sequences and flow mappings ("[1, 2]", "{a: 1}", JSON's {"a":1}), over any number of
//    lines, every line of them indented past the block collection they stand in;
//  - plain scalars of the characters A-Z a-z 0-9 _ . + - / ~ ( ) with single spaces or runs
//    of spaces between words, on one line;
//  - double-quoted scalars on one line with the escapes \" \\ \/ \b \f \n \r \t;
//  - comments ('#' after a space or at the start of a line) anywhere a break may stand.
// Everything else (tabs, other bytes, non-ASCII text elsewhere, a BOM, directives and "---" / "..."
// lines, anchors, aliases, tags, single quotes, block scalars, "?" keys, multi-line scalars, empty
// flow entries, trailing commas, plain scalars with ':' or '#' or other indicators, other escapes,
// keys longer than libyaml's 1024-character limit for simple keys, nesting at libyaml's limit, an
// empty document) makes it decline, and libyaml reads the text instead. Within the subset each
// construct gives the events libyaml gives, at the marks libyaml gives them (YAML 1.1 and libyaml
// 0.2.5's scanner and parser):
//  - a block mapping starts at its first key, a block sequence at its first '-', a flow
//    collection at its bracket, a scalar at its first character (a quoted one at the quote);
//  - an empty value ("key:" then a break, "-" then a break) is the empty plain scalar, a
//    null, at the end of the ':' or '-' token;
//  - a position is a character index: the byte offset less the UTF-8 continuation bytes
//    before it (a CRLF break counts as two characters).
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "model_tree.hpp"

namespace kanedyn::io::detail {

namespace {

/// The text is outside the subset; thrown inside the scanner only.
struct Decline {};

/// libyaml forgets a simple key (one before ':') that starts more than 1024 characters
/// before its ':'; further than this is left to it.
constexpr size_t kMaxKeySpan = 1000;

/// The characters of plain scalars the scanner reads: none is a YAML indicator inside a
/// scalar, in block or flow context.
constexpr bool plain_char(unsigned char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '.' || c == '+' || c == '-' || c == '/' || c == '~' || c == '(' || c == ')';
}

struct PlainTable {
  bool t[256] = {};
  constexpr PlainTable() {
    for (int c = 0; c < 256; ++c) t[c] = plain_char(static_cast<unsigned char>(c));
  }
};
constexpr PlainTable kPlain;

inline bool is_plain(char c) { return kPlain.t[static_cast<unsigned char>(c)]; }

/// A scalar found but not yet added: its start, its text (a view of the input, or of the
/// scanner's buffer when escapes made it differ: one scalar is pending at a time), and
/// whether it was quoted.
struct Scalar {
  const char* start = nullptr;
  Pos pos = 0;
  std::string_view view;
  bool quoted = false;
  bool escaped = false;
};

class Scanner {
 public:
  Scanner(std::string_view text, Tree& tree)
      : b_(text.data()), e_(text.data() + text.size()), p_(b_), line_(b_), tree_(tree) {}

  void run() {
    tree_.text = std::string_view(b_, static_cast<size_t>(e_ - b_));
    const size_t n = static_cast<size_t>(e_ - b_);
    // As the libyaml builder does: at most one node per two bytes; address space, not memory.
    tree_.nodes.reserve(n / 4 + 16);
    tree_.kids.reserve(n / 4 + 16);
    pending_.reserve(256);
    marker_check();
    int col = next_content_line();
    if (col < 0) throw Decline{};  // empty: libyaml's message
    if (*p_ == '[' || *p_ == '{') {
      flow_collection(-1);
      rest_of_line();
      col = next_content_line();
    } else {
      col = block_node(col);
    }
    if (col >= 0) throw Decline{};
    tree_.root = 0;
  }

 private:
  // ---- Characters and lines ----

  /// libyaml's mark of p_: its character index (the bytes before it less the continuation
  /// bytes of UTF-8 characters, which stand in comments and quoted scalars only).
  Pos pos() const {
    const auto at = static_cast<size_t>(p_ - b_) - continuation_;
    return static_cast<Pos>(at < kMaxNodePos ? at : kMaxNodePos);
  }

  /// The length of the UTF-8 character at q (its first byte >= 0x80) if libyaml reads it as
  /// printable text, not a break (NEL, LS, PS) and not a byte-order mark; 0 otherwise (not
  /// UTF-8, an overlong form, a surrogate, a C1 control, U+FFFE, U+FFFF).
  size_t utf8_char(const char* q) const {
    const auto at = [&](size_t i) { return q + i < e_ ? static_cast<unsigned char>(q[i]) : 0u; };
    const auto tail = [&](size_t i) { return (at(i) & 0xc0) == 0x80; };
    const unsigned c = at(0);
    if (c >= 0xc2 && c <= 0xdf) return tail(1) && (c > 0xc2 || at(1) >= 0xa0) ? 2 : 0;
    if (c >= 0xe0 && c <= 0xef) {
      if (!tail(1) || !tail(2)) return 0;
      const unsigned cp = ((c & 0x0f) << 12) | ((at(1) & 0x3f) << 6) | (at(2) & 0x3f);
      if (cp < 0x800 || (cp >= 0xd800 && cp <= 0xdfff) || cp == 0x2028 || cp == 0x2029 ||
          cp == 0xfeff || cp >= 0xfffe)
        return 0;
      return 3;
    }
    if (c >= 0xf0 && c <= 0xf4) {
      if (!tail(1) || !tail(2) || !tail(3)) return 0;
      const unsigned cp =
          ((c & 0x07) << 18) | ((at(1) & 0x3f) << 12) | ((at(2) & 0x3f) << 6) | (at(3) & 0x3f);
      return cp >= 0x10000 && cp <= 0x10ffff ? 4 : 0;
    }
    return 0;
  }

  /// Past the printable character at p_ in a comment or a quoted scalar; Decline if it is
  /// none. Returns its length.
  size_t text_char() {
    const auto c = static_cast<unsigned char>(*p_);
    if (c >= 0x20 && c <= 0x7e) {
      ++p_;
      return 1;
    }
    const size_t n = c >= 0x80 ? utf8_char(p_) : 0;
    if (n == 0) throw Decline{};
    continuation_ += n - 1;
    p_ += n;
    return n;
  }
  int column() const { return static_cast<int>(p_ - line_); }
  bool is_break(const char* q) const {
    return q < e_ && (*q == '\n' || (*q == '\r' && q + 1 < e_ && q[1] == '\n'));
  }
  /// A blank after an indicator: a space, a break or the end.
  bool blank_at(const char* q) const { return q == e_ || *q == ' ' || is_break(q); }
  bool is_entry() const { return p_ < e_ && *p_ == '-' && blank_at(p_ + 1); }
  bool plain_start() const {
    if (p_ >= e_) return false;
    if (*p_ == '-') return p_ + 1 < e_ && is_plain(p_[1]);
    return is_plain(*p_);
  }

  /// "---" and "..." at the start of a line are document markers (and at least suspicious).
  void marker_check() const {
    if (e_ - p_ >= 3 && (std::memcmp(p_, "---", 3) == 0 || std::memcmp(p_, "...", 3) == 0))
      throw Decline{};
  }

  void consume_break() {
    p_ += *p_ == '\r' ? 2 : 1;
    line_ = p_;
    marker_check();
  }

  void skip_spaces() {
    while (p_ < e_ && *p_ == ' ') ++p_;
  }

  /// A comment from '#' to the end of the line (not its break); '#' must follow a blank.
  void comment() {
    if (p_ != b_ && p_[-1] != ' ' && p_[-1] != '\n') throw Decline{};
    while (p_ < e_ && *p_ != '\n' && *p_ != '\r') text_char();
  }

  /// After a value or an indicator: spaces, a comment, then a break or the end of the text.
  void rest_of_line() {
    skip_spaces();
    if (p_ < e_ && *p_ == '#') comment();
    if (p_ == e_) return;
    if (!is_break(p_)) throw Decline{};
    consume_break();
  }

  /// From the start of a line, past blank and comment lines: the column of the next content
  /// (p_ on it), or -1 at the end of the text.
  int next_content_line() {
    for (;;) {
      skip_spaces();
      if (p_ == e_) return -1;
      if (*p_ == '#') comment();
      if (p_ == e_) return -1;
      if (is_break(p_)) {
        consume_break();
        continue;
      }
      if (*p_ == '\r' || *p_ == '\n') throw Decline{};
      return column();
    }
  }

  // ---- Scalars ----

  Scalar plain() {
    Scalar s;
    s.start = p_;
    s.pos = pos();
    for (;;) {
      while (e_ - p_ >= 4 && is_plain(p_[0]) && is_plain(p_[1]) && is_plain(p_[2]) &&
             is_plain(p_[3]))
        p_ += 4;
      while (p_ < e_ && is_plain(*p_)) ++p_;
      const char* q = p_;
      while (q < e_ && *q == ' ') ++q;
      if (q == p_ || q == e_ || !is_plain(*q)) break;
      p_ = q;  // spaces inside the scalar
    }
    s.view = std::string_view(s.start, static_cast<size_t>(p_ - s.start));
    return s;
  }

  Scalar quoted() {
    Scalar s;
    s.start = p_;
    s.pos = pos();
    s.quoted = true;
    const char* first = ++p_;
    while (p_ < e_) {
      const auto c = static_cast<unsigned char>(*p_);
      if (c == '"' || c == '\\') break;
      if (c >= 0x20 && c <= 0x7e) {
        ++p_;  // the common case, inline
      } else {
        text_char();
      }
    }
    if (p_ == e_) throw Decline{};
    if (*p_ == '"') {
      s.view = std::string_view(first, static_cast<size_t>(p_ - first));
      ++p_;
      return s;
    }
    s.escaped = true;
    own_.assign(first, static_cast<size_t>(p_ - first));
    for (;;) {
      if (p_ == e_) throw Decline{};
      const auto c = static_cast<unsigned char>(*p_);
      if (c == '"') break;
      if (c == '\\') {
        if (p_ + 1 == e_) throw Decline{};
        char out = 0;
        switch (p_[1]) {
          case '"':
            out = '"';
            break;
          case '\\':
            out = '\\';
            break;
          case '/':
            out = '/';
            break;
          case 'b':
            out = '\b';
            break;
          case 'f':
            out = '\f';
            break;
          case 'n':
            out = '\n';
            break;
          case 'r':
            out = '\r';
            break;
          case 't':
            out = '\t';
            break;
          default:
            throw Decline{};
        }
        own_ += out;
        p_ += 2;
        continue;
      }
      const char* from = p_;
      own_.append(from, text_char());
    }
    ++p_;
    s.view = own_;
    return s;
  }

  /// A key or value scalar where one starts, or Decline.
  Scalar scalar() {
    if (p_ < e_ && *p_ == '"') return quoted();
    if (plain_start()) return plain();
    throw Decline{};
  }

  // ---- Nodes ----

  uint32_t add(Kind kind, Pos at, bool string) {
    const auto index = static_cast<uint32_t>(tree_.nodes.size());
    tree_.nodes.push_back({at, static_cast<uint32_t>(kind), string, 0, 0, 0});
    if (depth_ > 0) pending_.push_back(index);
    return index;
  }

  void emit(const Scalar& s) {
    if (!s.quoted && s.view.size() <= 4 && is_null_word(s.view)) {
      add(Kind::null, s.pos, false);
      return;
    }
    const uint32_t i = add(Kind::scalar, s.pos, s.quoted);
    TreeNode& n = tree_.nodes[i];
    n.count = static_cast<uint32_t>(s.view.size());
    // As the libyaml builder decides: the value is used in place where the text after the
    // opening quote (if any) spells it, which an escaped value may happen to do.
    const auto at = static_cast<size_t>(s.start - b_) + (s.quoted ? 1 : 0);
    if (!s.escaped ||
        (at <= static_cast<size_t>(e_ - b_) && tree_.text.substr(at, s.view.size()) == s.view)) {
      n.in_text = 1;
      n.first = static_cast<uint32_t>(at);
    } else {
      n.first = static_cast<uint32_t>(tree_.chars.size());
      tree_.chars += s.view;
    }
  }

  /// An empty value: libyaml's empty plain scalar at the end of its ':' or '-'.
  void add_null(Pos at) { add(Kind::null, at, false); }

  struct Open {
    uint32_t node;
    size_t pending;
  };

  Open open(Kind kind) {
    if (depth_ >= kMaxDepth) throw Decline{};  // libyaml's builder refuses it
    const uint32_t i = add(kind, pos(), false);
    ++depth_;
    return {i, pending_.size()};
  }

  void close(const Open& o) {
    --depth_;
    TreeNode& n = tree_.nodes[o.node];
    n.first = static_cast<uint32_t>(tree_.kids.size());
    n.count = static_cast<uint32_t>(pending_.size() - o.pending);
    tree_.kids.insert(tree_.kids.end(), pending_.begin() + static_cast<std::ptrdiff_t>(o.pending),
                      pending_.end());
    pending_.resize(o.pending);
  }

  // ---- Block context ----

  /// A block collection starting at p_, the first content of a line, at column `col`.
  /// Returns the column of the next content line after it (-1 at the end).
  int block_node(int col) { return is_entry() ? block_sequence(col, false) : block_mapping(col); }

  int block_mapping(int col) {
    const Open o = open(Kind::mapping);
    int next = -1;
    for (;;) {
      const Scalar key = scalar();
      skip_spaces();
      if (p_ == e_ || *p_ != ':' || static_cast<size_t>(p_ - key.start) > kMaxKeySpan)
        throw Decline{};
      ++p_;
      const Pos after_colon = pos();
      if (!blank_at(p_)) throw Decline{};
      emit(key);
      next = block_value(col, after_colon);
      if (next == col && !is_entry()) continue;
      if (next < col) break;
      throw Decline{};
    }
    close(o);
    return next;
  }

  /// The value after "key:" in a mapping at column `col`.
  int block_value(int col, Pos after_colon) {
    skip_spaces();
    if (p_ == e_ || is_break(p_) || *p_ == '#') {
      rest_of_line();
      const int next = next_content_line();
      if (next > col) return block_node(next);
      if (next == col && is_entry()) return block_sequence(col, true);
      add_null(after_colon);
      return next;
    }
    inline_value(col);
    rest_of_line();
    return next_content_line();
  }

  /// A block sequence at column `col`; `indentless`: the entries of a mapping value standing
  /// at the mapping's own column, ended by its next key.
  int block_sequence(int col, bool indentless) {
    const Open o = open(Kind::sequence);
    int next = -1;
    for (;;) {
      ++p_;
      const Pos after_dash = pos();
      skip_spaces();
      if (p_ == e_ || is_break(p_) || *p_ == '#') {
        rest_of_line();
        next = next_content_line();
        if (next > col) {
          next = block_node(next);
        } else {
          add_null(after_dash);
        }
      } else if (*p_ == '"' || plain_start()) {
        // A scalar, or the first key of a mapping that starts here ("- name: a").
        const char* start = p_;
        const size_t continuation = continuation_;
        const int key_col = column();
        Scalar s = scalar();
        skip_spaces();
        if (p_ < e_ && *p_ == ':' && blank_at(p_ + 1)) {
          p_ = start;  // read again as the mapping's first key
          continuation_ = continuation;
          next = block_mapping(key_col);
        } else {
          emit(s);
          rest_of_line();
          next = next_content_line();
        }
      } else {
        if (is_entry()) throw Decline{};  // "- - a"
        inline_value(col);
        rest_of_line();
        next = next_content_line();
      }
      if (next == col && is_entry()) continue;
      if (next < col || (next == col && indentless)) break;
      throw Decline{};
    }
    close(o);
    return next;
  }

  /// A value on the line of its key or dash, in a block collection at column `col`.
  void inline_value(int col) {
    if (*p_ == '[' || *p_ == '{') {
      flow_collection(col);
    } else {
      emit(scalar());
    }
  }

  // ---- Flow context ----

  /// Spaces, breaks and comments inside a flow collection; a line's first content must stand
  /// right of `indent`, the column of the block collection around (libyaml does not ask it,
  /// YAML does).
  void flow_space(int indent) {
    bool new_line = false;
    for (;;) {
      skip_spaces();
      if (p_ == e_) throw Decline{};
      if (*p_ == '#') comment();
      if (p_ == e_) throw Decline{};
      if (is_break(p_)) {
        consume_break();
        new_line = true;
        continue;
      }
      if (*p_ == '\r' || *p_ == '\n') throw Decline{};
      if (new_line && column() <= indent) throw Decline{};
      return;
    }
  }

  void flow_value(int indent) {
    if (*p_ == '[' || *p_ == '{') {
      flow_collection(indent);
    } else {
      emit(scalar());
    }
  }

  void flow_collection(int indent) {
    const bool sequence = *p_ == '[';
    const char closer = sequence ? ']' : '}';
    const Open o = open(sequence ? Kind::sequence : Kind::mapping);
    ++p_;
    flow_space(indent);
    if (*p_ == closer) {
      ++p_;
      close(o);
      return;
    }
    for (;;) {
      if (sequence) {
        flow_value(indent);
      } else {
        const Scalar key = scalar();
        skip_spaces();
        if (p_ == e_ || *p_ != ':' || static_cast<size_t>(p_ - key.start) > kMaxKeySpan)
          throw Decline{};
        ++p_;
        // After a plain key ':' needs a blank; after a quoted one (JSON's "a":1) not.
        if (!key.quoted && !blank_at(p_)) throw Decline{};
        emit(key);
        flow_space(indent);
        flow_value(indent);
      }
      flow_space(indent);
      if (*p_ == ',') {
        ++p_;
        flow_space(indent);
        if (*p_ == closer) throw Decline{};  // a trailing comma
        continue;
      }
      if (*p_ == closer) {
        ++p_;
        break;
      }
      throw Decline{};
    }
    close(o);
  }

  const char* const b_;
  const char* const e_;
  const char* p_;
  const char* line_;  // start of the current line
  Tree& tree_;
  std::vector<uint32_t> pending_;  // children of the open collections, in order
  std::string own_;                // the text of an escaped scalar
  size_t continuation_ = 0;        // UTF-8 continuation bytes before p_
  size_t depth_ = 0;
};

}  // namespace

bool build_fast_tree(std::string_view text, Tree& tree) {
  tree = Tree{};
  if (text.size() > kMaxFileBytes) return false;
  try {
    Scanner(text, tree).run();
    return true;
  } catch (const Decline&) {
    tree = Tree{};
    return false;
  }
}

std::string tree_difference(const Tree& a, const Tree& b) {
  if (a.nodes.size() != b.nodes.size())
    return std::to_string(a.nodes.size()) + " nodes against " + std::to_string(b.nodes.size());
  if (a.root != b.root)
    return "root " + std::to_string(a.root) + " against " + std::to_string(b.root);
  const auto scalar = [](const Tree& t, const TreeNode& n) {
    return std::string((n.in_text ? t.text : std::string_view(t.chars)).substr(n.first, n.count));
  };
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    const TreeNode& x = a.nodes[i];
    const TreeNode& y = b.nodes[i];
    const std::string at = "node " + std::to_string(i) + ": ";
    if (x.pos != y.pos)
      return at + "position " + std::to_string(x.pos) + " against " + std::to_string(y.pos);
    if (x.kind != y.kind)
      return at + "kind " + std::to_string(x.kind) + " against " + std::to_string(y.kind);
    if (x.string != y.string) return at + "quoted " + std::to_string(x.string);
    if (x.in_text != y.in_text) return at + "in the text " + std::to_string(x.in_text);
    if (x.first != y.first || x.count != y.count)
      return at + "first/count " + std::to_string(x.first) + "/" + std::to_string(x.count) +
             " against " + std::to_string(y.first) + "/" + std::to_string(y.count);
    if (static_cast<Kind>(x.kind) == Kind::scalar && scalar(a, x) != scalar(b, y))
      return at + "text '" + scalar(a, x) + "' against '" + scalar(b, y) + "'";
  }
  if (a.kids != b.kids) return "the children lists differ";
  if (a.chars != b.chars) return "the copied scalar texts differ";
  return "";
}

}  // namespace kanedyn::io::detail
