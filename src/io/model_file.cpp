// Model files, format kanedyn-model/1 (docs/model-format.md). The fast scanner (fast_tree.cpp)
// or, for what it declines, libyaml's event parser builds a compact tree (Tree, model_tree.hpp);
// every value is then checked where it is read, so that an error can name the file, the line
// and column and the key path; the Model constructor then validates again (it is the library's
// own guard). A load the fast scanner's tree fails is read again with libyaml alone, so that
// every message is that path's.
#include "kanedyn/io/model_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <memory>
#include <new>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "kanedyn/constraint.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/direction.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/urdf.hpp"
#include "kanedyn/rotation.hpp"
#include "model_tree.hpp"
#include "parameters.hpp"
#include "urdf_convert.hpp"

namespace kanedyn::io {

namespace {

std::string format_error(const std::string& file, int line, int column, const std::string& key_path,
                         const std::string& problem) {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line) + ":" + std::to_string(column);
  s += ": ";
  if (!key_path.empty()) s += key_path + ": ";
  return s + problem;
}

}  // namespace

ModelFileError::ModelFileError(const std::string& file, int line, int column,
                               const std::string& key_path, const std::string& problem)
    : std::runtime_error(format_error(file, line, column, key_path, problem)),
      file_(file),
      key_path_(key_path),
      problem_(problem),
      line_(line),
      column_(column) {}

namespace {

using detail::is_null_word;
using detail::Kind;
using detail::kMaxDepth;
using detail::kMaxFileBytes;
using detail::kMaxNodePos;
using detail::kNoPos;
using detail::Pos;
using detail::Tree;
using detail::TreeNode;

constexpr const char* kFormat = "kanedyn-model/1";
constexpr double kEulerNormTolerance = 1e-6;
/// a == b, the first characters first: most keys of a mapping differ there, and memcmp is a
/// call.
inline bool same(std::string_view a, std::string_view b) {
  return a.size() == b.size() && (a.empty() || (a[0] == b[0] && a == b));
}

/// kMaxFileBytes as a message says it.
constexpr const char* kMaxFileText = "256 MiB";
/// Mappings with more entries than this look keys up by hash; smaller ones by a linear scan.
constexpr size_t kHashedMapping = 16;
/// The depth of parameters evaluated within one another's expressions (a stack each).
constexpr size_t kMaxParameterDepth = 256;

// ---- Messages -----------------------------------------------------------------------------

/// Text from the file fit for a one-line message: control characters (C0, DEL, C1, and the
/// Unicode line and paragraph separators) and bytes that are not UTF-8 escaped, text longer
/// than `max` bytes shortened at a character boundary.
/// User text for a message: escaped (io::printable), at most 60 bytes of it.
std::string printable(std::string_view s, size_t max = 60) { return io::printable(s, max); }

std::string quote(std::string_view s) { return "'" + printable(s, 200) + "'"; }

/// The words, comma-separated, each cut after 60 bytes and the list after about 400: names come
/// from the file, and a message stays one short line however long they are.
std::string join(const std::vector<std::string>& words) {
  std::string s;
  for (const auto& w : words) {
    if (s.size() > 400) return s + ", ...";
    s += (s.empty() ? "" : ", ") + printable(w, 60);
  }
  return s;
}

std::string child_path(const std::string& parent, std::string_view key) {
  std::string s = parent;
  if (!s.empty()) s += '.';
  s += key;
  return s;
}

std::string index_path(const std::string& parent, size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

/// The first of `names` nearest to `word` by edit distance, if it is near (at most 2 edits,
/// or a third of the word); "" otherwise. For error messages only.
std::string nearest(std::string_view word, const std::vector<std::string>& names, size_t count) {
  const size_t limit = std::max<size_t>(2, word.size() / 3);
  size_t best = limit + 1;
  std::string found;
  for (size_t i = 0; i < count && i < names.size(); ++i) {
    const std::string& n = names[i];
    const size_t gap = n.size() > word.size() ? n.size() - word.size() : word.size() - n.size();
    if (gap >= best) continue;
    if (const size_t d = edit_distance(word, n); d < best) {
      best = d;
      found = n;
    }
  }
  return found;
}

/// Names for a message: all of them when there are at most 20, else a did-you-mean.
std::string name_hint(std::string_view word, const std::vector<std::string>& names, size_t count,
                      const std::string& lead) {
  count = std::min(count, names.size());
  if (count == 0) return "";
  if (count <= 20)
    return lead + join(std::vector<std::string>(names.begin(), names.begin() + count));
  const std::string n = nearest(word, names, count);
  return n.empty() ? "" : " (did you mean " + quote(n) + "?)";
}

// ---- Text positions -----------------------------------------------------------------------

/// A 1-based line and column (column in characters, as libyaml counts); 0 when unknown.
struct Mark {
  uint32_t line = 0, column = 0;
  bool known() const { return line > 0; }
};

/// The width of the line break at s[i] (CRLF, CR, LF, and NEL, LS, PS as libyaml counts them),
/// 0 if none.
size_t break_width(std::string_view s, size_t i) {
  if (s[i] == '\r') return i + 1 < s.size() && s[i + 1] == '\n' ? 2 : 1;
  if (s[i] == '\n') return 1;
  if (s.compare(i, 2, "\xc2\x85") == 0) return 2;
  if (s.compare(i, 3, "\xe2\x80\xa8") == 0 || s.compare(i, 3, "\xe2\x80\xa9") == 0) return 3;
  return 0;
}

/// The line and column of character `pos` of `text`, counting breaks as libyaml does.
Mark mark_of_pos(std::string_view text, Pos pos) {
  if (pos == kNoPos) return {};
  Mark m{1, 1};
  size_t chars = 0;
  for (size_t i = 0; i < text.size() && chars < pos;) {
    if (const size_t w = break_width(text, i)) {
      ++m.line;
      m.column = 1;
      chars += text[i] == '\r' && w == 2 ? 2 : 1;
      i += w;
      continue;
    }
    ++m.column;
    ++chars;
    ++i;
    while (i < text.size() && (static_cast<unsigned char>(text[i]) & 0xc0) == 0x80) ++i;
  }
  return m;
}

/// The mark of byte `offset` of `text`.
Mark mark_of_offset(std::string_view text, size_t offset) {
  Mark m{1, 1};
  for (size_t i = 0; i < offset && i < text.size();) {
    if (const size_t w = break_width(text, i)) {
      ++m.line;
      m.column = 1;
      i += w;
      continue;
    }
    if ((static_cast<unsigned char>(text[i]) & 0xc0) != 0x80) ++m.column;
    ++i;
  }
  return m;
}

/// The byte offset of libyaml's character index (it counts characters of the UTF-8 input).
size_t offset_of_index(std::string_view text, size_t index) {
  size_t chars = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    if ((static_cast<unsigned char>(text[i]) & 0xc0) == 0x80) continue;
    if (chars++ == index) return i;
  }
  return text.size();
}

/// The character at byte `offset` for a message: quoted, or "end of file".
std::string character_at(std::string_view text, size_t offset) {
  if (offset >= text.size()) return "end of file";
  const auto c = static_cast<unsigned char>(text[offset]);
  const size_t width = c >= 0xf0 ? 4 : c >= 0xe0 ? 3 : c >= 0xc0 ? 2 : 1;
  return quote(text.substr(offset, width));
}

// ---- The tree -----------------------------------------------------------------------------

/// A node of a Tree, with the accessors the readers below need.
class Node {
 public:
  Node() = default;
  Node(const Tree* tree, uint32_t index) : tree_(tree), index_(index) {}
  Kind kind() const { return static_cast<Kind>(node().kind); }
  bool IsNull() const { return kind() == Kind::null; }
  bool IsScalar() const { return kind() == Kind::scalar; }
  bool IsSequence() const { return kind() == Kind::sequence; }
  bool IsMap() const { return kind() == Kind::mapping; }
  bool IsString() const { return node().string; }
  /// Elements of a sequence, entries of a mapping.
  size_t size() const {
    const TreeNode& n = node();
    return kind() == Kind::mapping ? n.count / 2 : kind() == Kind::sequence ? n.count : 0;
  }
  Node operator[](size_t i) const { return kid(i); }
  Node key(size_t i) const { return kid(2 * i); }
  Node value(size_t i) const { return kid(2 * i + 1); }
  std::string_view Scalar() const {
    const TreeNode& n = node();
    if (kind() != Kind::scalar) return {};
    return (n.in_text ? tree_->text : std::string_view(tree_->chars)).substr(n.first, n.count);
  }
  Pos mark() const { return node().pos; }
  uint32_t index() const { return index_; }  ///< in Tree::nodes
  /// The byte offset of a scalar's text in the file, when it stands there as it is.
  std::optional<size_t> text_offset() const {
    if (kind() != Kind::scalar || !node().in_text) return std::nullopt;
    return node().first;
  }

 private:
  const TreeNode& node() const { return tree_->nodes[index_]; }
  Node kid(size_t i) const { return {tree_, tree_->kids[node().first + i]}; }
  const Tree* tree_ = nullptr;
  uint32_t index_ = 0;
};

/// A value in the file: its node, its key path and where to point at it. For a null value
/// (`key:` with nothing after it) the key's mark is used.
/// A key path ("bodies[3].initial.translation") spelt out only when a message needs it: the
/// part up to the last list index, then up to two keys (literals of the readers: views).
class KeyPath {
 public:
  KeyPath() = default;
  explicit KeyPath(std::string base) : base_(std::move(base)) {}
  std::string str() const {
    std::string s = base_;
    for (size_t i = 0; i < keys_; ++i) {
      if (!s.empty()) s += '.';
      s += key_[i];
    }
    return s;
  }
  /// This path and `key`, which must outlive the result.
  KeyPath child(std::string_view key) const {
    KeyPath p;
    if (keys_ == 2) {
      p.base_ = str();
    } else {
      p = *this;
    }
    p.key_[p.keys_++] = key;
    return p;
  }

 private:
  std::string base_;
  std::string_view key_[2];
  size_t keys_ = 0;
};

struct Field {
  Node node;
  KeyPath path;
  Pos mark;
  Pos key_mark;  ///< of its key (of the value itself for a list element)
};

std::string describe(const Node& node) {
  if (node.IsNull()) return "nothing (null)";
  if (node.IsSequence()) return "a list of " + std::to_string(node.size());
  if (node.IsMap()) return "a mapping";
  return quote(node.Scalar());
}

/// A strict YAML 1.2 / JSON decimal: [-+]? (digits [. digits?] | . digits) ([eE] [-+]? digits)?
bool is_decimal(std::string_view s) {
  size_t i = 0;
  const auto digits = [&] {
    const size_t start = i;
    while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
    return i - start;
  };
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  size_t mantissa = digits();
  if (i < s.size() && s[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  return i == s.size();
}

bool is_yaml_inf_or_nan(std::string_view t) {
  if (!t.empty() && (t[0] == '+' || t[0] == '-')) t.remove_prefix(1);
  for (const char* w : {".inf", ".Inf", ".INF", ".nan", ".NaN", ".NAN"})
    if (t == w) return true;
  return false;
}

/// Owns a libyaml parser, or an event, for the time of a scope.
struct ParserGuard {
  yaml_parser_t* p;
  ~ParserGuard() { yaml_parser_delete(p); }
};
struct EventGuard {
  yaml_event_t* e;
  ~EventGuard() { yaml_event_delete(e); }
};

class Reader;

/// A short list of numbers, on the stack.
using Numbers = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;

/// The entries of one mapping, checked for duplicate and non-scalar keys.
class Mapping {
 public:
  Mapping(const Reader& reader, const Field& field);
  /// Refuses keys not in `allowed`, naming the key and listing the allowed ones.
  void allow(std::initializer_list<std::string_view> allowed) const;
  bool has(std::string_view key) const { return find(key) != kNone; }
  /// The field of `key` (a literal: its path keeps a view of it).
  std::optional<Field> get(std::string_view key) const;
  Field require(std::string_view key) const;
  const Field& field() const { return field_; }

 private:
  static constexpr size_t kNone = static_cast<size_t>(-1);
  // Entry i is the tree's key and value i of the mapping: nothing is copied.
  std::string_view key(size_t i) const { return field_.node.key(i).Scalar(); }
  Pos key_mark(size_t i) const { return field_.node.key(i).mark(); }
  /// The entry of `key` among the first `count` entries, kNone if none.
  size_t find(std::string_view key, size_t count) const;
  size_t find(std::string_view key) const { return find(key, size_); }

  const Reader* reader_;
  Field field_;
  size_t size_ = 0;
  std::unordered_map<std::string_view, uint32_t> index_;  // for large mappings only
};

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail_at(const Mark& mark, const std::string& path,
                            const std::string& problem) const {
    throw ModelFileError(file_, static_cast<int>(mark.line),
                         mark.known() ? static_cast<int>(mark.column) : 0, path, problem);
  }
  [[noreturn]] void fail(Pos pos, const std::string& path, const std::string& problem) const {
    fail_at(mark_of_pos(tree_.text, pos), path, problem);
  }
  Mark mark(Pos pos) const { return mark_of_pos(tree_.text, pos); }
  [[noreturn]] void fail(const Field& f, const std::string& problem) const {
    fail(f.mark, f.path.str(), problem);
  }

  /// Parses the one YAML document of `text` into tree_: with the fast scanner when `fast`
  /// and it reads the text (then fast_used() is true), else with libyaml.
  const Tree& tree_of(std::string_view text, bool fast) {
    if (text.size() > kMaxFileBytes) fail(kNoPos, "", too_large());
    if (const void* nul = std::memchr(text.data(), 0, text.size()))
      fail_at(
          mark_of_offset(text, static_cast<size_t>(static_cast<const char*>(nul) - text.data())),
          "", "a NUL byte (\\x00) is not allowed; a model file is UTF-8 text");
    if (fast && detail::build_fast_tree(text, tree_)) {
      fast_used_ = true;
      return tree_;
    }
    owned_text_ = json_leading_tabs(text);
    if (!owned_text_.empty()) text = owned_text_;
    tree_.text = text;
    build(text);
    return tree_;
  }

  bool fast_used() const { return fast_used_; }

  /// Takes the tree of a text read before (whose text must outlive the reader) instead of
  /// parsing: a model built again with some numbers changed (ModelDocument).
  Node adopt(Tree tree) {
    tree_ = std::move(tree);
    return Node(&tree_, tree_.root);
  }
  /// The tree read by tree_of(), taken out of the reader.
  Tree take_tree() { return std::move(tree_); }

  /// The document's root, which must be a mapping.
  Node load(std::string_view text, bool fast) {
    tree_of(text, fast);
    if (tree_.nodes.empty() || Node(&tree_, tree_.root).IsNull())
      fail(kNoPos, "",
           "the file is empty; a model file is a mapping starting with 'format: " +
               std::string(kFormat) + "'");
    const Node root(&tree_, tree_.root);
    // A file that is no mapping is no model file: what it holds is not quoted (it may be any
    // file the user named by mistake).
    if (!root.IsMap())
      fail(root.mark(), "",
           "a model file must be a mapping (key: value lines), got " +
               (root.IsSequence() ? describe(root)
                                  : std::string("plain text (not shown: this is no model file)")));
    return root;
  }

  static std::string too_large() {
    return std::string("the file is larger than ") + kMaxFileText + ", the limit for a model file";
  }

  Field element(const Field& list, size_t i) const {
    const Node node = list.node[i];
    const Pos mark = node.IsNull() ? list.mark : node.mark();
    return {node, KeyPath(index_path(list.path.str(), i)), mark, mark};
  }

  std::vector<Field> list(const Field& f, const std::string& what) const {
    if (!f.node.IsSequence()) fail(f, "expected a list of " + what + ", got " + describe(f.node));
    std::vector<Field> items;
    items.reserve(f.node.size());
    for (size_t i = 0; i < f.node.size(); ++i) items.push_back(element(f, i));
    return items;
  }

  /// The value of a plain scalar that is a finite decimal; nothing for anything else, which
  /// number() then explains. The common case without building a Field.
  static std::optional<double> plain_number(const Node& n) {
    if (!n.IsScalar() || n.IsString()) return std::nullopt;
    const std::string_view s = n.Scalar();
    if (!is_decimal(s)) return std::nullopt;
    double value = 0.0;
    const char* first = s.data() + (s[0] == '+' ? 1 : 0);
    const auto [end, error] = std::from_chars(first, s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size() || !std::isfinite(value))
      return std::nullopt;
    return value;
  }

  double number(const Field& f) const {
    if (const auto v = plain_number(f.node)) return *v;
    if (!f.node.IsScalar()) fail(f, "expected a number, got " + describe(f.node));
    if (const auto v = expression_number(f)) return *v;
    const std::string_view s = f.node.Scalar();
    if (f.node.IsString()) fail(f, "expected a number, got the quoted string " + quote(s));
    if (is_yaml_inf_or_nan(s))
      fail(f, "non-finite number " + quote(s) + "; numbers must be finite");
    if (!is_decimal(s)) fail(f, "expected a number, got " + quote(s));
    double value = 0.0;
    const std::string problem = read_decimal(s, value);
    if (problem.starts_with("is too small")) fail(f, quote(s) + " " + problem);
    if (problem.starts_with("overflows")) fail(f, "non-finite number: " + quote(s) + " " + problem);
    if (!problem.empty()) fail(f, "expected a number, got " + quote(s));
    return value;
  }

  double positive(const Field& f) const {
    const double v = number(f);
    if (!(v > 0.0)) fail(f, "must be > 0, got " + got(f, v));
    return v;
  }

  double non_negative(const Field& f) const {
    const double v = number(f);
    if (v < 0.0) fail(f, "must be >= 0, got " + got(f, v));
    return v;
  }

  /// A number read from `f` for a message: as the file gives it, and an expression's value too.
  std::string got(const Field& f, double v) const {
    if (!is_expression(f.node)) return printable(f.node.Scalar());
    char buf[32];
    const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
    return quote(f.node.Scalar()) + " = " + std::string(buf, end);
  }

  // ---- Parameters and expressions (docs/model-format.md, "Parameters") --------------------

  /// A scalar whose text starts with '=' (after blanks): an expression.
  static bool is_expression(const Node& n) {
    if (!n.IsScalar()) return false;
    const std::string_view s = n.Scalar();
    const size_t p = s.find_first_not_of(" \t");
    return p != std::string_view::npos && s[p] == '=';
  }

  /// Reads the `parameters` section: every name checked, then every value evaluated (a
  /// parameter may use earlier or later ones), each once.
  void read_parameters(const Field& f) const {
    mapping(f);  // a mapping, its keys checked
    for (size_t i = 0; i < f.node.size(); ++i) {
      const Node key = f.node.key(i);
      const std::string_view name = key.Scalar();
      const std::string path = child_path(f.path.str(), printable(name));
      if (!detail::is_parameter_name(name))
        fail(key.mark(), path,
             "parameter name " + quote(name) +
                 " must start with a letter or '_' and use only [A-Za-z0-9_]");
      if (detail::is_reserved_name(name))
        fail(key.mark(), path,
             quote(name) +
                 " is reserved in expressions (pi and the functions); choose another "
                 "parameter name");
      const Node value = f.node.value(i);
      params_.push_back({name, Field{value, KeyPath(path),
                                     value.IsNull() ? key.mark() : value.mark(), key.mark()}});
      param_index_.emplace(name, i);  // the keys are unique: Mapping checked them
    }
    for (size_t i = 0; i < params_.size(); ++i) parameter(i);
    for (const ParameterEntry& p : params_) {
      std::string text;
      if (!plain_number(p.field.node)) text = std::string(expression_text(p.field.node).first);
      record_.parameters.push_back({std::string(p.name), text, p.value, p.field.node.index()});
    }
  }

  /// The file's parameters and expressions read so far.
  const Parameters& parameters() const { return record_; }

 private:
  struct ParameterEntry {
    std::string_view name;
    Field field;
    int state = 0;  // 0 not yet evaluated, 1 being evaluated, 2 done
    double value = 0.0;
  };

  /// The expression of a scalar (a leading '=' and blanks left out; a parameter's value may
  /// leave the '=' out) and its byte offset in the scalar.
  static std::pair<std::string_view, size_t> expression_text(const Node& n) {
    std::string_view s = n.Scalar();
    size_t at = s.find_first_not_of(" \t");
    if (at == std::string_view::npos) at = s.size();
    if (at < s.size() && s[at] == '=') ++at;
    while (at < s.size() && (s[at] == ' ' || s[at] == '\t')) ++at;
    size_t end = s.size();
    while (end > at && (s[end - 1] == ' ' || s[end - 1] == '\t')) --end;
    return {s.substr(at, end - at), at};
  }

  /// Parameter i's value, evaluated on first use.
  double parameter(size_t i) const {
    ParameterEntry& p = params_[i];
    if (p.state == 2) return p.value;
    const Field& f = p.field;
    if (const auto v = plain_number(f.node)) {
      p.value = *v;
    } else {
      if (!f.node.IsScalar())
        fail(f, "expected a number or an expression, got " + describe(f.node));
      if (is_yaml_inf_or_nan(f.node.Scalar()))
        fail(f, "non-finite number " + quote(f.node.Scalar()) + "; numbers must be finite");
      // A chain of parameters each using the next is evaluated by recursion: bounded.
      if (evaluating_.size() >= kMaxParameterDepth)
        fail(f, "parameters refer to parameters more than " + std::to_string(kMaxParameterDepth) +
                    " deep");
      p.state = 1;
      evaluating_.push_back(i);
      p.value = evaluate(f);
      evaluating_.pop_back();
    }
    p.state = 2;
    return p.value;
  }

  /// The value of the expression in `f`'s scalar; an error points at the character it is about
  /// (when the scalar stands in the file as it is) and names it.
  double evaluate(const Field& f) const {
    const auto [text, start] = expression_text(f.node);
    // The scalar up to the expression's end (trailing blanks left out), read from `start`: the
    // parser's offsets and "character N" are the scalar's.
    const std::string_view scalar = f.node.Scalar().substr(0, start + text.size());
    try {
      return detail::evaluate_expression(
          scalar, [this](std::string_view name, size_t at) { return lookup(name, at); }, start);
    } catch (const detail::ExpressionError& e) {
      const size_t column = e.at;
      Mark mark = this->mark(f.mark);
      if (const auto offset = f.node.text_offset())
        mark = mark_of_offset(tree_.text, *offset + column);
      fail_at(mark, f.path.str(),
              "in the expression " + quote(f.node.Scalar()) + ", at its character " +
                  std::to_string(column + 1) + ": " + printable(e.problem, 300));
    }
  }

  /// A parameter's value for an expression: refused when unknown (with the closest name) or
  /// being evaluated (a cycle, named member by member).
  double lookup(std::string_view name, size_t at) const {
    if (const auto it = param_index_.find(name); it != param_index_.end()) {
      const size_t j = it->second;
      if (params_[j].state == 1) {
        std::string cycle;
        const auto from = std::find(evaluating_.begin(), evaluating_.end(), j);
        for (auto k = from; k != evaluating_.end(); ++k)
          cycle += std::string(params_[*k].name) + " -> ";
        throw detail::ExpressionError{
            at, "the parameters form a cycle: " + printable(cycle, 300) + std::string(name)};
      }
      return parameter(j);
    }
    std::string problem = "unknown name " + quote(name);
    if (params_.empty()) {
      problem += "; the file has no 'parameters' section to define it";
    } else {
      std::string best;
      size_t best_distance = std::numeric_limits<size_t>::max();
      for (const ParameterEntry& p : params_)
        if (const size_t d = edit_distance(name, p.name); d < best_distance) {
          best_distance = d;
          best = std::string(p.name);
        }
      problem += " (closest parameter: " + quote(best) + ")";
    }
    throw detail::ExpressionError{at, problem};
  }

  /// The value of an expression `= ...` in a number's place, recorded for the writer; nothing
  /// for any other scalar.
  std::optional<double> expression_number(const Field& f) const {
    if (!is_expression(f.node)) return std::nullopt;
    const double v = evaluate(f);
    record_.numbers.push_back(
        {f.path.str(), std::string(expression_text(f.node).first), v, f.node.index()});
    return v;
  }

  mutable std::vector<ParameterEntry> params_;
  mutable std::unordered_map<std::string_view, size_t> param_index_;  // name -> params_
  mutable std::vector<size_t> evaluating_;  // the parameters being evaluated, innermost last
  mutable Parameters record_;

 public:
  /// A list of exactly `n` numbers (at most 6: no allocation).
  Numbers numbers(const Field& f, int n) const {
    if (!f.node.IsSequence() || f.node.size() != static_cast<size_t>(n))
      fail(f, "expected a list of " + std::to_string(n) + " numbers, got " + describe(f.node));
    Numbers v(n);
    const size_t recorded = record_.numbers.size();
    for (int i = 0; i < n; ++i) {
      const auto value = plain_number(f.node[static_cast<size_t>(i)]);
      v[i] = value ? *value : number(element(f, static_cast<size_t>(i)));
    }
    if (record_.numbers.size() > recorded) {
      // Every component of a list that holds an expression, in order: a direction is
      // written back from all of them (model_writer.cpp).
      std::vector<Parameters::Number> list;
      for (int i = 0; i < n; ++i) {
        const Node node = f.node[static_cast<size_t>(i)];
        const auto it = std::find_if(
            record_.numbers.begin() + static_cast<std::ptrdiff_t>(recorded), record_.numbers.end(),
            [&](const Parameters::Number& r) { return r.node == node.index(); });
        if (it != record_.numbers.end())
          list.push_back(*it);
        else
          list.push_back({element(f, static_cast<size_t>(i)).path.str(), "", v[i], node.index()});
      }
      record_.numbers.resize(recorded);
      record_.numbers.insert(record_.numbers.end(), list.begin(), list.end());
    }
    return v;
  }

  Vector3 vector3(const Field& f) const { return numbers(f, 3); }

  /// A list of 3 numbers, or one number standing for three equal ones.
  Vector3 vector3_or_scalar(const Field& f) const {
    if (f.node.IsScalar()) return Vector3::Constant(number(f));
    if (!f.node.IsSequence())
      fail(f, "expected a number or a list of 3 numbers, got " + describe(f.node));
    return vector3(f);
  }

  std::string text(const Field& f) const { return std::string(text_view(f)); }

  /// The same in the tree (which outlives the reader's work).
  std::string_view text_view(const Field& f) const {
    if (!f.node.IsScalar()) fail(f, "expected a text value, got " + describe(f.node));
    return f.node.Scalar();
  }

  /// A text value that must be one of `choices`.
  std::string choice(const Field& f, std::initializer_list<std::string_view> choices,
                     const std::string& what) const {
    return choice(f, std::vector<std::string_view>(choices), what);
  }
  std::string choice(const Field& f, const std::vector<std::string_view>& choices,
                     const std::string& what) const {
    const std::string_view s = text_view(f);
    if (std::none_of(choices.begin(), choices.end(),
                     [&](std::string_view c) { return same(c, s); }))
      fail(f, "unknown " + what + " " + quote(s) +
                  "; allowed: " + join(std::vector<std::string>(choices.begin(), choices.end())));
    return std::string(s);
  }

  Mapping mapping(const Field& f) const { return Mapping(*this, f); }

 private:
  /// libyaml refuses a tab before the first token in block context, which is where a
  /// tab-indented JSON document's opening bracket stands. A copy of the text with those tabs
  /// (only those) made spaces, which changes no line or column; "" when there are none.
  static std::string json_leading_tabs(std::string_view text) {
    size_t i = text.compare(0, 3, "\xef\xbb\xbf") == 0 ? 3 : 0;
    bool tab = false;
    for (; i < text.size(); ++i) {
      if (text[i] == '\t') {
        tab = true;
      } else if (text[i] != ' ' && text[i] != '\r' && text[i] != '\n') {
        break;
      }
    }
    if (!tab || i == text.size() || (text[i] != '{' && text[i] != '[')) return "";
    std::string copy(text);
    std::replace(copy.begin(), copy.begin() + static_cast<std::ptrdiff_t>(i), '\t', ' ');
    return copy;
  }

  static Mark mark_of(const yaml_mark_t& m) {
    return {static_cast<uint32_t>(m.line + 1), static_cast<uint32_t>(m.column + 1)};
  }

  [[noreturn]] void syntax_error(const yaml_parser_t& p, std::string_view text) const {
    if (p.error == YAML_MEMORY_ERROR) throw std::bad_alloc();
    const std::string problem = p.problem ? printable(p.problem, 200) : "unknown problem";
    if (p.error == YAML_READER_ERROR) {
      // Bytes that are not UTF-8, or a control character; its offset is in bytes.
      std::string what = "unreadable text: " + problem;
      if (p.problem_value != -1) {
        char value[16];
        std::snprintf(value, sizeof value, p.problem_value < 0x100 ? " (\\x%02x)" : " (U+%04X)",
                      static_cast<unsigned>(p.problem_value));
        what += value;
      }
      fail_at(mark_of_offset(text, p.problem_offset), "",
              what + "; a model file is UTF-8 text with no control characters but tab and breaks");
    }
    std::string what = "YAML syntax error: " + problem + " at " +
                       character_at(text, offset_of_index(text, p.problem_mark.index));
    if (p.context) {
      what += " (" + printable(p.context, 200);
      if (p.context_mark.line != p.problem_mark.line ||
          p.context_mark.column != p.problem_mark.column)
        what += " that starts at line " + std::to_string(p.context_mark.line + 1) + ", column " +
                std::to_string(p.context_mark.column + 1);
      what += ")";
    }
    fail_at(mark_of(p.problem_mark), "", what);
  }

  /// The event loop: nodes in document order, children collected on a stack of open
  /// collections (no recursion), scalars pointing into the text or copied into one buffer.
  void build(std::string_view text) {
    yaml_parser_t parser;
    if (!yaml_parser_initialize(&parser)) throw std::bad_alloc();
    const ParserGuard parser_guard{&parser};
    yaml_parser_set_encoding(&parser, YAML_UTF8_ENCODING);
    yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()),
                                 text.size());
    // At most one node per two bytes ("[1,1,..."); reserving for a node per four costs
    // address space, not memory (untouched pages), and spares the copies of regrowth.
    tree_.nodes.reserve(text.size() / 4 + 16);
    tree_.kids.reserve(text.size() / 4 + 16);
    // libyaml's character index to a byte offset, walking forward: scalars come in text order.
    size_t walk_index = 0, walk_byte = 0;
    const auto byte_of = [&](size_t index) {
      if (index < walk_index) return text.size() + 1;  // not in order: not in the text
      while (walk_index < index && walk_byte < text.size()) {
        ++walk_byte;
        while (walk_byte < text.size() &&
               (static_cast<unsigned char>(text[walk_byte]) & 0xc0) == 0x80)
          ++walk_byte;
        ++walk_index;
      }
      return walk_byte;
    };
    struct Open {
      uint32_t node;
      size_t pending;  // where its children start in `pending`
    };
    std::vector<Open> open;
    std::vector<uint32_t> pending;
    // Anchors: an alias stands for the anchored node itself (shared in the tree, never copied),
    // so no input expands into more than it spells out. `closed` marks finished collections:
    // an alias inside the value it names would make the tree a cycle.
    std::unordered_map<std::string, uint32_t> anchors;
    std::vector<bool> closed;
    int documents = 0;
    for (;;) {
      yaml_event_t event;
      if (!yaml_parser_parse(&parser, &event)) syntax_error(parser, text);
      const EventGuard event_guard{&event};
      const Pos at = static_cast<Pos>(std::min<size_t>(event.start_mark.index, kMaxNodePos));
      const auto add = [&](Kind kind, bool string) {
        if (tree_.nodes.size() >= std::numeric_limits<uint32_t>::max()) throw std::bad_alloc();
        const auto index = static_cast<uint32_t>(tree_.nodes.size());
        tree_.nodes.push_back({at, static_cast<uint32_t>(kind), string, 0, 0, 0});
        if (open.empty()) {
          tree_.root = index;
        } else {
          pending.push_back(index);
        }
        return index;
      };
      const auto anchor = [&](const yaml_char_t* name, uint32_t index) {
        // A later anchor of the same name takes over from there on, as YAML says.
        if (name) anchors[std::string(reinterpret_cast<const char*>(name))] = index;
      };
      const auto check_tag = [&](const yaml_char_t* tag) {
        // Standard tags (tag:yaml.org,2002:...) are accepted; !!str makes a scalar text.
        if (!tag) return false;
        const std::string_view t(reinterpret_cast<const char*>(tag));
        if (t == "!" || t == "tag:yaml.org,2002:str") return true;
        if (t.substr(0, 18) == "tag:yaml.org,2002:") return false;
        fail(at, "", "unsupported tag " + quote(t) + "; a model file needs no tags");
      };
      switch (event.type) {
        case YAML_STREAM_END_EVENT:
          return;
        case YAML_DOCUMENT_START_EVENT:
          if (++documents > 1)
            fail(at, "", "the file holds more than one YAML document; a model file is exactly one");
          break;
        case YAML_ALIAS_EVENT: {
          const std::string name(reinterpret_cast<const char*>(event.data.alias.anchor));
          const auto it = anchors.find(name);
          if (it == anchors.end())
            fail(at, "",
                 "alias " + quote("*" + name) + " names no anchor before it (&" + printable(name) +
                     ")");
          if (it->second < closed.size() && !closed[it->second])
            fail(at, "", "alias " + quote("*" + name) + " stands inside the value it names");
          pending.push_back(it->second);  // the root is never an alias: an anchor came first
          break;
        }
        case YAML_SCALAR_EVENT: {
          const auto& s = event.data.scalar;
          const bool tagged_string = check_tag(s.tag);
          const std::string_view value(reinterpret_cast<const char*>(s.value), s.length);
          const bool plain = s.style == YAML_PLAIN_SCALAR_STYLE || s.style == YAML_ANY_SCALAR_STYLE;
          if (plain && !tagged_string && is_null_word(value)) {
            anchor(s.anchor, add(Kind::null, false));
          } else {
            const uint32_t i = add(Kind::scalar, !plain || tagged_string);
            anchor(s.anchor, i);
            TreeNode& n = tree_.nodes[i];
            n.count = static_cast<uint32_t>(value.size());
            // Most scalars stand in the text as they are (after the quote, if quoted): point
            // there. Others (escapes, folded lines) are copied.
            const size_t at_byte =
                byte_of(event.start_mark.index) + (s.style == YAML_SINGLE_QUOTED_SCALAR_STYLE ||
                                                   s.style == YAML_DOUBLE_QUOTED_SCALAR_STYLE);
            if (at_byte <= text.size() && text.substr(at_byte, value.size()) == value) {
              n.in_text = 1;
              n.first = static_cast<uint32_t>(at_byte);
            } else {
              n.first = static_cast<uint32_t>(tree_.chars.size());
              tree_.chars += value;
            }
          }
          break;
        }
        case YAML_SEQUENCE_START_EVENT:
        case YAML_MAPPING_START_EVENT: {
          check_tag(event.type == YAML_SEQUENCE_START_EVENT ? event.data.sequence_start.tag
                                                            : event.data.mapping_start.tag);
          if (open.size() >= kMaxDepth)
            fail(at, "",
                 "nesting deeper than " + std::to_string(kMaxDepth) +
                     " levels; a model file needs fewer than 10");
          const uint32_t i =
              add(event.type == YAML_SEQUENCE_START_EVENT ? Kind::sequence : Kind::mapping, false);
          open.push_back({i, pending.size()});
          if (closed.size() <= i) closed.resize(i + 1, true);
          closed[i] = false;
          anchor(event.type == YAML_SEQUENCE_START_EVENT ? event.data.sequence_start.anchor
                                                         : event.data.mapping_start.anchor,
                 i);
          break;
        }
        case YAML_SEQUENCE_END_EVENT:
        case YAML_MAPPING_END_EVENT: {
          const Open o = open.back();
          open.pop_back();
          closed[o.node] = true;
          TreeNode& n = tree_.nodes[o.node];
          n.first = static_cast<uint32_t>(tree_.kids.size());
          n.count = static_cast<uint32_t>(pending.size() - o.pending);
          tree_.kids.insert(tree_.kids.end(),
                            pending.begin() + static_cast<std::ptrdiff_t>(o.pending),
                            pending.end());
          pending.resize(o.pending);
          break;
        }
        default:
          break;
      }
    }
  }

  std::string file_;
  std::string owned_text_;  // the text when it had to be changed
  Tree tree_;
  bool fast_used_ = false;
};

Mapping::Mapping(const Reader& reader, const Field& field) : reader_(&reader), field_(field) {
  if (!field.node.IsMap()) reader.fail(field, "expected a mapping, got " + describe(field.node));
  const size_t n = field.node.size();
  const bool hashed = n > kHashedMapping;
  if (hashed) index_.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const Node key = field.node.key(i);
    if (!key.IsScalar())
      reader.fail(key.mark(), field.path.str(), "keys must be plain words, got " + describe(key));
    const std::string_view k = key.Scalar();
    size_t previous = kNone;
    if (hashed) {
      const auto [it, inserted] = index_.emplace(k, static_cast<uint32_t>(i));
      if (!inserted) previous = it->second;
    } else {
      previous = find(k, i);
    }
    if (previous != kNone)
      reader.fail(key.mark(), child_path(field.path.str(), printable(k)),
                  "duplicate key " + quote(k) + " (first given on line " +
                      std::to_string(reader.mark(key_mark(previous)).line) + ")");
  }
  size_ = n;
}

void Mapping::allow(std::initializer_list<std::string_view> allowed) const {
  for (size_t i = 0; i < size_; ++i) {
    const std::string_view k = key(i);
    if (std::any_of(allowed.begin(), allowed.end(), [&](std::string_view a) { return same(a, k); }))
      continue;
    const std::vector<std::string> words(allowed.begin(), allowed.end());
    std::string problem = "unknown key " + quote(k);
    for (const std::string& w : words)
      if (edit_distance(k, w) <= 2) {
        problem += " (did you mean " + quote(w) + "?)";
        break;
      }
    reader_->fail(key_mark(i), child_path(field_.path.str(), printable(k)),
                  problem + "; allowed keys: " + join(words));
  }
}

size_t Mapping::find(std::string_view key, size_t count) const {
  if (!index_.empty() && count == size_) {
    const auto it = index_.find(key);
    return it == index_.end() ? kNone : it->second;
  }
  for (size_t i = 0; i < count; ++i) {
    const std::string_view k = this->key(i);
    if (same(k, key)) return i;
  }
  return kNone;
}

std::optional<Field> Mapping::get(std::string_view key) const {
  const size_t i = find(key);
  if (i == kNone) return std::nullopt;
  const Node value = field_.node.value(i);
  const Pos mark = key_mark(i);
  return Field{value, field_.path.child(key), value.IsNull() ? mark : value.mark(), mark};
}

Field Mapping::require(std::string_view key) const {
  if (auto f = get(key)) return *f;
  reader_->fail(field_.mark, child_path(field_.path.str(), key),
                "missing required key " + quote(key));
}

// ---- Sections -----------------------------------------------------------------------------

bool valid_body_name(std::string_view name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

/// Inertia [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]; products are the tensor's
/// off-diagonal entries.
Matrix3 read_inertia(const Reader& r, const Field& f) {
  const size_t n = f.node.IsSequence() ? f.node.size() : 0;
  if (n != 3 && n != 6)
    r.fail(f,
           "expected a list of 3 numbers [Ixx, Iyy, Izz] or 6 numbers "
           "[Ixx, Iyy, Izz, Ixy, Ixz, Iyz], got " +
               describe(f.node));
  const Numbers v = r.numbers(f, static_cast<int>(n));
  Matrix3 inertia = v.head<3>().asDiagonal();
  if (n == 6) {
    inertia(0, 1) = inertia(1, 0) = v[3];
    inertia(0, 2) = inertia(2, 0) = v[4];
    inertia(1, 2) = inertia(2, 1) = v[5];
  }
  if (const std::string problem = check_inertia(inertia); !problem.empty()) r.fail(f, problem);
  return inertia;
}

/// `rotation: {axis, angle | angle_deg}` as Euler parameters (absolute orientation).
Vector4 read_rotation(const Reader& r, const Field& f) {
  const Mapping m = r.mapping(f);
  m.allow({"axis", "angle", "angle_deg"});
  const Field axis_field = m.require("axis");
  // Any non-zero axis is a direction, however large or small its components
  // (kanedyn/direction.hpp).
  const std::optional<Vector3> axis = scaled_direction(r.vector3(axis_field));
  if (!axis) r.fail(axis_field, "the rotation axis must not be zero");
  const auto angle = m.get("angle");
  const auto angle_deg = m.get("angle_deg");
  if (angle && angle_deg)
    r.fail(angle_deg->key_mark, f.path.str(),
           "give either 'angle' (radians) or 'angle_deg', not both");
  if (!angle && !angle_deg)
    r.fail(f.mark, child_path(f.path.str(), "angle"),
           "missing required key 'angle' (radians) or 'angle_deg' (degrees)");
  const double theta = angle ? r.number(*angle) : r.number(*angle_deg) * (std::numbers::pi / 180.0);
  return euler_parameters_from_axis_angle(*axis, theta);
}

Vector4 read_euler_parameters(const Reader& r, const Field& f) {
  const Vector4 eps = r.numbers(f, 4);
  const double norm = eps.norm();
  if (!(std::abs(norm - 1.0) <= kEulerNormTolerance)) {
    std::ostringstream s;
    s << "Euler parameters (e1, e2, e3, e4; e4 scalar) must have norm 1 within "
      << kEulerNormTolerance;
    s.precision(12);
    s << ", got norm " << norm;
    r.fail(f, s.str());
  }
  return eps / norm;
}

/// Every joint type's name (kJointTypes), in the order of the enum.
const std::vector<std::string_view>& joint_type_names() {
  static const std::vector<std::string_view> names = [] {
    std::vector<std::string_view> v;
    for (const JointType type : kJointTypes) v.emplace_back(to_string(type));
    return v;
  }();
  return names;
}

JointType joint_type_of(std::string_view name) {
  JointType t = JointType::free;
  for (const JointType type : kJointTypes)
    if (to_string(type) == name) t = type;
  return t;
}

/// A direction: three numbers, not all zero, scaled by the largest (so that its norm neither
/// overflows nor underflows); `what` names it in the message.
Vector3 read_direction(const Reader& r, const Field& f, const std::string& what) {
  const std::optional<Vector3> v = scaled_direction(r.vector3(f));
  if (!v) r.fail(f, what + " must not be zero");
  return *v;
}

/// The mapping form of `joint` (docs/model-format.md, "Joints"); its `at` goes to `at`.
Joint read_joint(const Reader& r, const Field& f, Vector3& at) {
  const Mapping m = r.mapping(f);
  m.allow({"at", "type", "frame", "axis", "axes", "pitch"});
  Joint joint;
  const std::string type = r.choice(m.require("type"), joint_type_names(), "joint type");
  joint.type = joint_type_of(type);
  // The keys a type takes are its row of the joint table (JointTypeInfo).
  const JointTypeInfo& info = joint_type_info(joint.type);
  const auto types_taking = [](bool JointTypeInfo::*key) {
    std::vector<std::string> names;
    for (const JointType t : kJointTypes)
      if (joint_type_info(t).*key) names.emplace_back(to_string(t));
    std::string s;
    for (size_t i = 0; i < names.size(); ++i)
      s += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
    return s + " joints";
  };
  if (auto v = m.get("at")) at = r.vector3(*v);
  const auto refuse = [&](const std::optional<Field>& v, const std::string& why) {
    if (v) r.fail(v->key_mark, v->path.str(), why);
  };
  const auto require = [&](const std::optional<Field>& v, const char* key,
                           const std::string& what) {
    if (!v)
      r.fail(
          f.mark, child_path(f.path.str(), key),
          "missing required key '" + std::string(key) + "' (" + what + ") of a " + type + " joint");
  };
  const auto frame = m.get("frame");
  if (!info.takes_frame)
    refuse(frame, "'frame' is refused on a " + type + " joint, where it would mean nothing");
  if (frame) joint.frame = read_rotation(r, *frame);
  const auto axis = m.get("axis");
  if (!info.takes_axis)
    refuse(axis, "'axis' is refused on a " + type + " joint; it is for " +
                     types_taking(&JointTypeInfo::takes_axis) +
                     (info.takes_axes ? " (a " + type + " joint takes 'axes')"
                      : info.slides && info.turns && !info.absolute
                          ? " (orient a " + type +
                                " joint's plane with 'frame': the plane is F's "
                                "x-y plane)"
                          : std::string()));
  const auto axes = m.get("axes");
  if (!info.takes_axes)
    refuse(axes, "'axes' is refused on a " + type + " joint; it is for " +
                     types_taking(&JointTypeInfo::takes_axes) +
                     (info.slides && info.turns && !info.takes_axis && !info.absolute
                          ? " (orient a " + type +
                                " joint's plane with 'frame': the plane is F's "
                                "x-y plane)"
                          : ""));
  const auto pitch = m.get("pitch");
  if (!info.takes_pitch)
    refuse(pitch, "'pitch' is refused on a " + type + " joint; it is for " +
                      types_taking(&JointTypeInfo::takes_pitch));
  if (info.takes_axis) {
    require(axis, "axis", "F components");
    joint.axis = read_direction(r, *axis, "the joint axis");
  }
  if (info.takes_pitch) {
    require(pitch, "pitch", "translation along the axis per radian");
    joint.pitch = r.number(*pitch);
  }
  if (info.takes_axes) {
    if (!axes)
      r.fail(f.mark, child_path(f.path.str(), "axes"),
             "missing required key 'axes' ([a1, a2], F components) of a universal joint");
    if (!axes->node.IsSequence() || axes->node.size() != 2)
      r.fail(*axes, "expected a list of two axes [[a1], [a2]], got " + describe(axes->node));
    for (size_t i = 0; i < 2; ++i)
      joint.axes[i] =
          read_direction(r, r.element(*axes, i), "a universal joint's axis").normalized();
    const double c = joint.axes[0].dot(joint.axes[1]);
    if (!(std::abs(c) <= 1e-9)) {
      char buf[48];
      std::snprintf(buf, sizeof buf, "%.3g", c);
      r.fail(*axes, std::string("the axes of a universal joint must be perpendicular "
                                "(|a1 . a2| <= 1e-9), got a1 . a2 = ") +
                        buf);
    }
  }
  return joint;
}

/// A body's initial values: the v1 keys into `state` for a free joint (and `translation` into
/// the joint of a weld); `joint` and `joint_rate` into q and z for the other joints.
void read_initial(const Reader& r, const Field& f, int k, State& state, Joint& joint, VectorX& q,
                  VectorX& z) {
  const Mapping m = r.mapping(f);
  m.allow({"euler_parameters", "rotation", "translation", "angular_velocity", "translation_rate",
           "joint", "joint_rate"});
  const std::string type = to_string(joint.type);
  const JointTypeInfo& info = joint_type_info(joint.type);
  if (!info.absolute) {
    for (const char* key :
         {"euler_parameters", "rotation", "translation", "angular_velocity", "translation_rate"}) {
      const auto v = m.get(key);
      if (!v || (info.fixed_translation && std::string_view(key) == "translation")) continue;
      r.fail(v->key_mark, v->path.str(),
             "'" + std::string(key) + "' is refused on a body with a " + type +
                 " joint: its motion follows from the joint and from its parent" +
                 (info.fixed_translation ? " (a " + type + " joint takes only 'translation')"
                                         : "; give 'joint' and 'joint_rate'"));
    }
  }
  if (info.coordinates == 0 || info.absolute) {
    for (const char* key : {"joint", "joint_rate"})
      if (const auto v = m.get(key))
        r.fail(
            v->key_mark, v->path.str(),
            "'" + std::string(key) + "' is refused on a " + type + " joint" +
                (info.absolute ? ", whose initial state is given by the keys euler_parameters (or "
                                 "rotation), translation, angular_velocity and translation_rate"
                               : ", which has no coordinates"));
  }
  if (info.fixed_translation) {
    if (auto v = m.get("translation")) joint.translation = r.vector3(*v);
    return;
  }
  if (!info.absolute) {
    const auto list = [&](const Field& v, int count, const char* what) {
      if (!v.node.IsSequence() || v.node.size() != static_cast<size_t>(count)) {
        const std::string got =
            v.node.IsSequence() ? std::to_string(v.node.size()) + " numbers" : describe(v.node);
        r.fail(v, "a " + type + " joint has " + std::to_string(count) + " " + what +
                      (count == 1 ? "" : "s") + ", got " + got);
      }
      return VectorX(r.numbers(v, count));
    };
    if (auto v = m.get("joint")) {
      q = list(*v, coordinate_count(joint.type), "coordinate");
      if (info.euler) q = read_euler_parameters(r, *v);
    }
    if (auto v = m.get("joint_rate")) z = list(*v, speed_count(joint.type), "rate");
    return;
  }
  const auto eps = m.get("euler_parameters");
  const auto rotation = m.get("rotation");
  if (eps && rotation)
    r.fail(rotation->key_mark, f.path.str(),
           "give either 'euler_parameters' or 'rotation', not both");
  if (eps) state.euler_parameters(k) = read_euler_parameters(r, *eps);
  if (rotation) state.euler_parameters(k) = read_rotation(r, *rotation);
  if (auto v = m.get("translation")) state.translation(k) = r.vector3(*v);
  if (auto v = m.get("angular_velocity")) state.angular_velocity(k) = r.vector3(*v);
  if (auto v = m.get("translation_rate")) state.translation_rate(k) = r.vector3(*v);
}

/// Names to body indices: open addressing with linear probing in a table at most half full,
/// so that loading stays O(N) with one or two cache misses a lookup; the keys are the names'
/// texts in the tree, the bodies numbered in order of insertion.
class NameIndex {
 public:
  void reserve(size_t n) {
    size_t capacity = 16;
    while (capacity < 2 * n) capacity *= 2;
    slots_.assign(capacity, Slot{});
    mask_ = capacity - 1;
    keys_.reserve(n);
  }
  /// The index of `name`, or -1.
  int find(std::string_view name) const {
    if (slots_.empty()) return -1;
    const size_t h = std::hash<std::string_view>{}(name);
    for (size_t i = h & mask_;; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.body == 0) return -1;
      if (s.hash == static_cast<uint32_t>(h) && keys_[s.body - 1] == name)
        return static_cast<int>(s.body - 1);
    }
  }
  /// Adds `name` as the next body unless it is there: then returns its index, else -1.
  int insert(std::string_view name) {
    if (2 * (keys_.size() + 1) > slots_.size()) grow();
    const size_t h = std::hash<std::string_view>{}(name);
    for (size_t i = h & mask_;; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.body == 0) {
        keys_.push_back(name);
        s = {static_cast<uint32_t>(h), static_cast<uint32_t>(keys_.size())};
        return -1;
      }
      if (s.hash == static_cast<uint32_t>(h) && keys_[s.body - 1] == name)
        return static_cast<int>(s.body - 1);
    }
  }

 private:
  struct Slot {
    uint32_t hash = 0;  // its low bits, to skip most comparisons
    uint32_t body = 0;  // index + 1; 0: empty
  };
  void grow() {
    std::vector<std::string_view> keys = std::move(keys_);
    keys_.clear();
    reserve(std::max<size_t>(8, keys.size() * 2));
    for (const std::string_view k : keys) insert(k);
  }
  std::vector<Slot> slots_;
  std::vector<std::string_view> keys_;
  size_t mask_ = 0;
};

/// Body names in numbering order, with their index.
struct BodyNames {
  std::vector<std::string> names;
  NameIndex index;
};

/// Index of the body named by `f`, which must be one of `bodies`.
int body_reference(const Reader& r, const Field& f, const BodyNames& bodies) {
  const std::string_view name = r.text_view(f);
  const int index = bodies.index.find(name);
  if (index < 0) {
    // List the bodies when there are few; a long list helps nobody.
    r.fail(f, "unknown body " + quote(name) +
                  name_hint(name, bodies.names, bodies.names.size(), "; bodies: "));
  }
  return index;
}

struct BodiesSection {
  BodyNames names;
  std::vector<BodySpec> specs;
  std::vector<std::optional<Field>> initial;  // the `initial:` entries, where given
  std::vector<Joint> joints;                  // free unless the mapping form says otherwise
};

BodiesSection read_bodies(const Reader& r, const Field& f) {
  const std::vector<Field> items = r.list(f, "bodies");
  if (items.empty()) r.fail(f, "a model needs at least one body");
  // First pass: mappings and names, so that a parent can be looked up (and a later one
  // recognised as such).
  std::vector<Mapping> maps;
  BodiesSection section;
  std::vector<std::string>& names = section.names.names;
  auto& index_of = section.names.index;  // name -> list index: O(N) loading
  maps.reserve(items.size());
  names.reserve(items.size());
  index_of.reserve(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping& m = maps.emplace_back(r.mapping(items[i]));
    m.allow({"name", "parent", "mass", "inertia", "com", "joint", "initial"});
    const Field name_field = m.require("name");
    const std::string_view name = r.text_view(name_field);
    if (!valid_body_name(name))
      r.fail(name_field,
             "body name " + quote(name) + " must be non-empty and use only [A-Za-z0-9_-]");
    if (name == "ground")
      r.fail(name_field, "'ground' is reserved for the inertial frame; choose another body name");
    if (const int previous = index_of.insert(name); previous >= 0)
      r.fail(name_field, "duplicate body name " + quote(name) + " (already used by " +
                             index_path("bodies", static_cast<size_t>(previous)) + ")");
    names.emplace_back(name);
  }
  section.specs.reserve(items.size());
  section.initial.reserve(items.size());
  section.joints.reserve(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping& m = maps[i];
    const int k = static_cast<int>(i);
    BodySpec b;
    b.name = names[i];
    const Field parent_field = m.require("parent");
    const std::string_view parent = r.text_view(parent_field);
    if (parent == "ground") {
      b.lower_body = kGround;
    } else {
      // A chain's parent is the body before: that comparison spares most lookups.
      const int found = i > 0 && names[i - 1] == parent ? k - 1 : index_of.find(parent);
      const int j = found < 0 ? static_cast<int>(names.size()) : found;
      if (found < 0)
        r.fail(parent_field,
               "unknown parent " + quote(parent) + "; expected 'ground'" +
                   (i == 0 ? "" : " or an earlier body" + name_hint(parent, names, i, ": ")));
      if (j == k) r.fail(parent_field, "a body cannot be its own parent");
      if (j > k)
        r.fail(parent_field, "parent " + quote(parent) + " is " +
                                 index_path("bodies", static_cast<size_t>(j)) +
                                 ", a later body; a parent must be 'ground' or an earlier body " +
                                 "(L(K) < K): reorder the list");
      b.lower_body = j;
    }
    b.mass = r.positive(m.require("mass"));
    b.inertia = read_inertia(r, m.require("inertia"));
    if (auto v = m.get("com")) b.com = r.vector3(*v);
    Joint joint;
    if (auto v = m.get("joint")) {
      if (v->node.IsMap()) {
        joint = read_joint(r, *v, b.joint);
      } else {
        b.joint = r.vector3(*v);
      }
    }
    section.joints.push_back(joint);
    section.specs.push_back(std::move(b));
    section.initial.push_back(m.get("initial"));
  }
  return section;
}

/// A joint_spring or joint_force entry: each parameter a number (the same for every
/// coordinate) or one number per coordinate of the body's joint.
std::shared_ptr<const JointLoad> read_joint_load(const Reader& r, const Mapping& m,
                                                 const std::string& type, const Field& body_field,
                                                 int body, const std::vector<Joint>& joints) {
  const JointType jt = joints[static_cast<size_t>(body)].type;
  if (!speeds_are_coordinate_rates(jt)) {
    // "revolute, prismatic, ... and planar": the types whose rates are the coordinates'.
    std::vector<std::string> loadable;
    for (const JointType t : kJointTypes)
      if (speeds_are_coordinate_rates(t)) loadable.emplace_back(to_string(t));
    std::string names = loadable.back();
    if (loadable.size() > 1) {
      loadable.pop_back();
      names = join(loadable) + " and " + names;
    }
    r.fail(body_field, type + " acts on joint coordinates, and body '" +
                           std::string(r.text_view(body_field)) + "' has a " + to_string(jt) +
                           " joint; " + type + " is for " + names + " joints");
  }
  const int n = coordinate_count(jt);
  const auto read = [&](const char* key, bool non_negative) -> VectorX {
    const auto v = m.get(key);
    if (!v) return VectorX::Zero(n);
    VectorX value;
    if (v->node.IsScalar()) {
      value = VectorX::Constant(n, r.number(*v));
    } else {
      if (!v->node.IsSequence() || v->node.size() != static_cast<size_t>(n))
        r.fail(*v, "expected a number or a list of " + std::to_string(n) +
                       " numbers (one per coordinate of the " + to_string(jt) + " joint), got " +
                       describe(v->node));
      value = r.numbers(*v, n);
    }
    if (non_negative && (value.array() < 0.0).any()) r.fail(*v, std::string(key) + " must be >= 0");
    return value;
  };
  VectorX stiffness = read("stiffness", true), damping = read("damping", true);
  VectorX rest = read("rest", false), value = read("value", false);
  return std::make_shared<const JointLoad>(body, std::move(stiffness), std::move(damping),
                                           std::move(rest), std::move(value), type);
}

void read_force(const Reader& r, const Field& f, const BodyNames& names,
                const std::vector<Joint>& joints,
                std::vector<std::shared_ptr<const ForceElement>>& forces) {
  const Mapping m = r.mapping(f);
  // Keys no type knows first, so that a misspelt `type` is named as such.
  m.allow({"type", "body", "stiffness", "damping", "rotational_stiffness", "rotational_damping",
           "value", "rest", "at", "other", "other_at", "rest_length"});
  const std::string type = r.choice(
      m.require("type"), {"bushing", "force", "torque", "spring", "joint_spring", "joint_force"},
      "force type");
  if (type == "spring") {
    m.allow({"type", "body", "at", "other", "other_at", "stiffness", "damping", "rest_length"});
  } else if (type == "bushing") {
    m.allow({"type", "body", "stiffness", "damping", "rotational_stiffness", "rotational_damping"});
  } else if (type == "joint_spring") {
    m.allow({"type", "body", "stiffness", "damping", "rest"});
  } else {
    m.allow({"type", "body", "value"});
  }
  const Field body_field = m.require("body");
  const int body = body_reference(r, body_field, names);
  if (type == "joint_spring" || type == "joint_force") {
    // A joint_force is its value: one left out is a mistake, not a zero (docs/model-format.md).
    if (type == "joint_force") (void)m.require("value");
    forces.push_back(read_joint_load(r, m, type, body_field, body, joints));
    return;
  }
  if (type == "spring") {
    Vector3 at = Vector3::Zero(), other_at = Vector3::Zero();
    int other = kGround;
    if (const auto v = m.get("at")) at = r.vector3(*v);
    if (const auto v = m.get("other")) {
      other = r.text_view(*v) == "ground" ? kGround : body_reference(r, *v, names);
      if (other == body)
        r.fail(*v, "other is the spring's own body " + quote(r.text_view(*v)) +
                       "; a spring joins two bodies, or a body and ground");
    }
    if (const auto v = m.get("other_at")) other_at = r.vector3(*v);
    const double stiffness = r.non_negative(m.require("stiffness"));
    const auto optional = [&](const char* key) {
      const auto v = m.get(key);
      return v ? r.non_negative(*v) : 0.0;
    };
    forces.push_back(std::make_shared<Spring>(body, at, other, other_at, stiffness,
                                              optional("damping"), optional("rest_length")));
    return;
  }
  if (type == "bushing") {
    const auto non_negative3 = [&](const char* key) -> Vector3 {
      const auto v = m.get(key);
      if (!v) return Vector3::Zero();
      const Vector3 value = r.vector3_or_scalar(*v);
      if ((value.array() < 0.0).any()) r.fail(*v, std::string(key) + " must be >= 0");
      return value;
    };
    const auto non_negative1 = [&](const char* key) {
      const auto v = m.get(key);
      return v ? r.non_negative(*v) : 0.0;
    };
    forces.push_back(std::make_shared<Bushing>(
        body, non_negative3("stiffness"), non_negative3("damping"),
        non_negative1("rotational_stiffness"), non_negative1("rotational_damping")));
    return;
  }
  const Vector3 value = r.vector3(m.require("value"));
  if (type == "force")
    forces.push_back(std::make_shared<ConstantForce>(body, value));
  else
    forces.push_back(std::make_shared<ConstantTorque>(body, value));
}

/// The `frames` section (docs/model-format.md, "Frames"): each a name unique among frames and
/// bodies, a body (or ground), an origin and axes.
std::vector<Frame> read_frames(const Reader& r, const Field& f, const BodyNames& bodies) {
  std::vector<Frame> frames;
  std::vector<std::string> seen;
  const std::vector<Field> items = r.list(f, "frame entries");
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping m = r.mapping(items[i]);
    m.allow({"name", "body", "at", "rotation"});
    Frame frame;
    const Field name_field = m.require("name");
    const std::string_view name = r.text_view(name_field);
    if (!valid_body_name(name))
      r.fail(name_field,
             "frame name " + quote(name) + " must be non-empty and use only [A-Za-z0-9_-]");
    if (name == "ground")
      r.fail(name_field, "'ground' is reserved for the inertial frame; choose another name");
    if (bodies.index.find(name) >= 0)
      r.fail(name_field,
             "frame name " + quote(name) + " is a body's name; a frame needs a name of its own");
    for (size_t j = 0; j < seen.size(); ++j)
      if (seen[j] == name)
        r.fail(name_field, "duplicate frame name " + quote(name) + " (already used by " +
                               index_path("frames", j) + ")");
    frame.name = std::string(name);
    seen.push_back(frame.name);
    const Field body_field = m.require("body");
    frame.body =
        r.text_view(body_field) == "ground" ? kGround : body_reference(r, body_field, bodies);
    if (const auto v = m.get("at")) frame.at = r.vector3(*v);
    if (const auto v = m.get("rotation")) frame.rotation = read_rotation(r, *v);
    frames.push_back(std::move(frame));
  }
  return frames;
}

/// The `inputs` section (docs/model-format.md, "Inputs"): u_1 .. u_m in the order given, each
/// checked against its body's joint here, where the place in the file is known.
std::vector<Input> read_inputs(const Reader& r, const Field& f, const BodiesSection& bodies) {
  std::vector<Input> inputs;
  const std::vector<Field> items = r.list(f, "input entries");
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping m = r.mapping(items[i]);
    m.allow({"name", "type", "body", "speed", "direction", "point", "axis", "reaction"});
    Input in;
    const Field name_field = m.require("name");
    const std::string_view name = r.text_view(name_field);
    if (!valid_body_name(name))
      r.fail(name_field,
             "input name " + quote(name) + " must be non-empty and use only [A-Za-z0-9_-]");
    if (name == "t")
      r.fail(name_field,
             "input name 't' is the time column of inputs tables, so no table could drive it; "
             "choose another name");
    for (size_t j = 0; j < inputs.size(); ++j)
      if (inputs[j].name == name)
        r.fail(name_field, "duplicate input name " + quote(name) + " (already used by " +
                               index_path("inputs", j) + ")");
    in.name = std::string(name);
    const std::string type =
        r.choice(m.require("type"), {"joint", "force", "torque"}, "input type");
    if (type == "joint")
      m.allow({"name", "type", "body", "speed"});
    else if (type == "force")
      m.allow({"name", "type", "body", "direction", "point"});
    else
      m.allow({"name", "type", "body", "axis", "reaction"});
    const Field body_field = m.require("body");
    in.body = body_reference(r, body_field, bodies.names);
    const BodySpec& body = bodies.specs[static_cast<size_t>(in.body)];
    const JointType jt = bodies.joints[static_cast<size_t>(in.body)].type;
    if (type == "joint") {
      in.type = InputType::joint;
      const int speeds = speed_count(jt);
      if (speeds == 0)
        r.fail(body_field, "a joint input drives one of the body's speeds, and body '" + body.name +
                               "' has a " + to_string(jt) + " joint, which has none");
      if (const auto v = m.get("speed")) {
        const double s = r.number(*v);
        if (s != std::floor(s) || s < 1 || s > speeds)
          r.fail(*v, "speed must be a whole number from 1 to " + std::to_string(speeds) +
                         " (body '" + body.name + "' has a " + to_string(jt) + " joint with " +
                         std::to_string(speeds) + " speed" + (speeds == 1 ? "" : "s") + "), got " +
                         r.got(*v, s));
        in.speed = static_cast<int>(s) - 1;
      }
    } else if (type == "force") {
      in.type = InputType::force;
      const Field d = m.require("direction");
      in.direction = r.vector3(d);
      if (!scaled_direction(in.direction)) r.fail(d, "direction: a zero vector has no direction");
      in.point = body.com;  // the mass centre unless given
      if (const auto v = m.get("point")) in.point = r.vector3(*v);
    } else {
      in.type = InputType::torque;
      const Field a = m.require("axis");
      in.axis = r.vector3(a);
      if (!scaled_direction(in.axis)) r.fail(a, "axis: a zero vector has no direction");
      if (const auto v = m.get("reaction")) {
        const std::string b = r.choice(*v, {"true", "false"}, "value for reaction");
        in.reaction = b == "true";
      }
    }
    inputs.push_back(std::move(in));
  }
  return inputs;
}

/// The speeds' names in z's order, as the linearization names them (docs/model-format.md,
/// "Linearization output"; tangent_state_names gives the same from a Model): derived from the
/// bodies section here, where there is no Model yet.
std::vector<std::string> speed_names(const BodiesSection& bodies) {
  std::vector<std::string> names;
  for (size_t k = 0; k < bodies.joints.size(); ++k) {
    const std::string& body = bodies.names.names[k];
    const JointType type = bodies.joints[k].type;
    for (int c = 0; c < speed_count(type); ++c) {
      if (joint_type_info(type).absolute)
        names.push_back(body + (c < 3 ? ".w" : ".sd") + std::to_string(c % 3 + 1));
      else if (joint_type_info(type).euler)
        names.push_back(body + ".w" + std::to_string(c + 1));
      else
        names.push_back(body + ".jd" + std::to_string(c + 1));
    }
  }
  return names;
}

/// The keys of a constraint of `type`: the common three, then the type's own.
std::span<const std::string_view> constraint_keys(ConstraintType type) {
  static constexpr std::string_view disc[] = {"name", "type",   "body", "center",
                                              "axis", "radius", "plane"};
  static constexpr std::string_view ball[] = {"name", "type", "body", "at", "other", "other_at"};
  static constexpr std::string_view hinge[] = {"name", "type",  "body",     "at",
                                               "axis", "other", "other_at", "other_axis"};
  static constexpr std::string_view distance[] = {"name",  "type",     "body",  "at",
                                                  "other", "other_at", "length"};
  switch (type) {
    case ConstraintType::rolling_disc:
      return disc;
    case ConstraintType::ball:
      return ball;
    case ConstraintType::hinge:
      return hinge;
    case ConstraintType::distance:
      return distance;
  }
  return {};
}

/// The `constraints` section (docs/model-format.md, "Constraints"): each entry checked here,
/// where the place in the file is known, before the Model checks it again.
std::vector<Constraint> read_constraints(const Reader& r, const Field& f, const BodyNames& bodies,
                                         std::vector<Field>& items) {
  static constexpr ConstraintType kTypes[] = {ConstraintType::rolling_disc, ConstraintType::ball,
                                              ConstraintType::hinge, ConstraintType::distance};
  std::vector<Constraint> constraints;
  items = r.list(f, "constraint entries");
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping m = r.mapping(items[i]);
    // Every type's keys first, so that a misspelt `type` is reported as the unknown key.
    m.allow({"name", "type", "body", "center", "axis", "radius", "plane", "at", "other", "other_at",
             "other_axis", "length"});
    Constraint c;
    const Field name_field = m.require("name");
    const std::string_view name = r.text_view(name_field);
    if (!valid_body_name(name))
      r.fail(name_field,
             "constraint name " + quote(name) + " must be non-empty and use only [A-Za-z0-9_-]");
    for (size_t j = 0; j < constraints.size(); ++j)
      if (constraints[j].name == name)
        r.fail(name_field, "duplicate constraint name " + quote(name) + " (already used by " +
                               index_path("constraints", j) + ")");
    c.name = std::string(name);
    const std::string type = r.choice(
        m.require("type"), {"rolling_disc", "ball", "hinge", "distance"}, "constraint type");
    for (const ConstraintType t : kTypes)
      if (type == to_string(t)) c.type = t;
    const auto allowed = constraint_keys(c.type);
    for (const std::string_view key :
         {"center", "axis", "radius", "plane", "at", "other", "other_at", "other_axis", "length"}) {
      const auto v = m.get(key);
      if (!v || std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      std::vector<std::string> owners;
      for (const ConstraintType t : kTypes) {
        const auto keys = constraint_keys(t);
        if (std::find(keys.begin(), keys.end(), key) != keys.end()) owners.push_back(to_string(t));
      }
      r.fail(v->key_mark, v->path.str(),
             "'" + std::string(key) + "' is refused on a " + type + " constraint; it is for " +
                 join(owners) + "; allowed keys: " +
                 join(std::vector<std::string>(allowed.begin(), allowed.end())));
    }
    const auto required = [&](std::string_view key, const std::string& what) {
      if (const auto v = m.get(key)) return *v;
      r.fail(items[i].mark, child_path(items[i].path.str(), key),
             "missing required key '" + std::string(key) + "' (" + what + ") of a " + type +
                 " constraint");
    };
    const Field body_field = m.require("body");
    if (r.text_view(body_field) == "ground")
      r.fail(body_field,
             "a constraint acts on a body, not on the ground; name the body, and ground as "
             "'other'");
    c.body = body_reference(r, body_field, bodies);
    if (c.type == ConstraintType::rolling_disc) {
      if (const auto v = m.get("center")) c.at = r.vector3(*v);
      c.axis = read_direction(r, required("axis", "the disc's axle, body-K components"),
                              "the disc's axle");
      c.radius = r.positive(required("radius", "the disc's radius, > 0"));
      if (const auto v = m.get("plane")) {
        const Mapping plane = r.mapping(*v);
        plane.allow({"normal", "offset"});
        if (const auto n = plane.get("normal"))
          c.plane_normal = read_direction(r, *n, "the plane's normal");
        if (const auto o = plane.get("offset")) c.plane_offset = r.number(*o);
      }
    } else {
      if (const auto v = m.get("at")) c.at = r.vector3(*v);
      if (const auto v = m.get("other")) {
        c.other = r.text_view(*v) == "ground" ? kGround : body_reference(r, *v, bodies);
        if (c.other == c.body)
          r.fail(*v, "other is the constraint's own body " + quote(r.text_view(*v)) +
                         "; name another body, or ground");
      }
      if (const auto v = m.get("other_at")) c.other_at = r.vector3(*v);
      if (c.type == ConstraintType::hinge) {
        c.axis = read_direction(r, required("axis", "body-K components"), "the hinge axis");
        c.other_axis =
            read_direction(r, required("other_axis", "in other's components, ground's inertial"),
                           "the hinge's other_axis");
      }
      if (c.type == ConstraintType::distance)
        c.length = r.positive(required("length", "the points' distance, > 0"));
    }
    constraints.push_back(std::move(c));
  }
  return constraints;
}

/// The `independent_speeds` section: speed names (speed_names) to indices into z, in the
/// order given (the Model sorts them: the choice is a set).
std::vector<int> read_independent_speeds(const Reader& r, const Field& f,
                                         const BodiesSection& bodies, bool constrained) {
  if (!constrained)
    r.fail(f.key_mark, f.path.str(),
           "independent speeds are chosen among the speeds that constraints tie together, and "
           "the model has no constraints");
  const std::vector<Field> items = r.list(f, "speed names");
  if (items.empty())
    r.fail(f,
           "an empty list names no speed; leave 'independent_speeds' out to have them chosen at "
           "the initial state");
  const std::vector<std::string> names = speed_names(bodies);
  std::vector<int> speeds;
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string_view name = r.text_view(items[i]);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
      r.fail(items[i],
             "unknown speed " + quote(name) + name_hint(name, names, names.size(), "; speeds: "));
    const int index = static_cast<int>(it - names.begin());
    for (size_t j = 0; j < speeds.size(); ++j)
      if (speeds[j] == index)
        r.fail(items[i], "speed " + quote(name) + " is named twice (already independent_speeds[" +
                             std::to_string(j) + "])");
    speeds.push_back(index);
  }
  return speeds;
}

SimulationSection read_simulation(const Reader& r, const Field& f) {
  const Mapping m = r.mapping(f);
  m.allow({"t_end", "dt_out", "integrator", "rtol", "atol", "step", "route", "method"});
  SimulationSection s;
  if (auto v = m.get("t_end")) s.t_end = r.positive(*v);
  if (auto v = m.get("dt_out")) s.dt_out = r.positive(*v);
  if (auto v = m.get("integrator")) s.integrator = r.choice(*v, {"dopri5", "rk4"}, "integrator");
  if (auto v = m.get("rtol")) s.rtol = r.positive(*v);
  if (auto v = m.get("atol")) s.atol = r.positive(*v);
  if (auto v = m.get("step")) s.step = r.positive(*v);
  if (auto v = m.get("route")) s.route = r.choice(*v, {"recursive", "assembled"}, "route");
  // The older spelling: `method: kane` is the assembled route.
  if (auto v = m.get("method")) {
    if (s.route) r.fail(*v, "give `route` or its older spelling `method`, not both");
    s.route = r.choice(*v, {"recursive", "assembled", "kane"}, "method");
  }
  return s;
}

/// Reads `text`; the fast scanner is tried first when `fast`, and `fast_used` tells whether it
/// read the text (set before any check can throw).
ModelFile read_model(const Reader& r, const Node& root_node, const std::string& source_name);

ModelFile parse(const std::string& text, const std::string& source_name, bool fast,
                bool& fast_used) {
  Reader r(source_name);
  struct Report {
    const Reader& r;
    bool& used;
    ~Report() { used = r.fast_used(); }
  } report{r, fast_used};
  return read_model(r, r.load(text, fast), source_name);
}

/// The model of a document whose root is root_node (a mapping), checked key by key.
ModelFile read_model(const Reader& r, const Node& root_node, const std::string& source_name) {
  const Field root{root_node, KeyPath(), root_node.mark(), root_node.mark()};
  const Mapping top = r.mapping(root);

  // The format first: a file of some other kind should be told so, not about its keys.
  const auto format_field = top.get("format");
  if (!format_field)
    r.fail(root.mark, "format",
           "missing required key 'format'; a model file starts with 'format: " +
               std::string(kFormat) + "'");
  const Field& format = *format_field;
  if (const std::string f = r.text(format); f != kFormat)
    r.fail(format, "unsupported format " + quote(f) +
                       "; this version reads 'format: " + std::string(kFormat) + "'");
  top.allow({"format", "name", "parameters", "gravity", "bodies", "forces", "frames", "inputs",
             "constraints", "independent_speeds", "simulation"});
  // The parameters before any number that may use them.
  if (const auto v = top.get("parameters")) r.read_parameters(*v);

  const std::string name = top.has("name") ? r.text(*top.get("name")) : "";
  const Vector3 gravity = top.has("gravity") ? r.vector3(*top.get("gravity")) : Vector3::Zero();
  const Field bodies_field = top.require("bodies");
  BodiesSection bodies = read_bodies(r, bodies_field);

  const BodyNames& names = bodies.names;
  std::vector<std::shared_ptr<const ForceElement>> forces;
  if (const auto forces_field = top.get("forces"))
    for (const Field& item : r.list(*forces_field, "force entries"))
      read_force(r, item, names, bodies.joints, forces);

  std::vector<Frame> frames;
  if (const auto v = top.get("frames")) frames = read_frames(r, *v, names);
  std::vector<Input> inputs;
  if (const auto v = top.get("inputs")) inputs = read_inputs(r, *v, bodies);
  std::vector<Constraint> constraints;
  std::vector<Field> constraint_items;  // where the Model's messages about them point
  if (const auto v = top.get("constraints"))
    constraints = read_constraints(r, *v, names, constraint_items);
  std::vector<int> independent_speeds;
  const auto speeds_field = top.get("independent_speeds");
  if (speeds_field)
    independent_speeds = read_independent_speeds(r, *speeds_field, bodies, !constraints.empty());

  SimulationSection simulation;
  if (const auto v = top.get("simulation")) simulation = read_simulation(r, *v);

  const int n = static_cast<int>(bodies.specs.size());
  State initial(n);
  // Per body: the joint coordinates and rates (identity for a spherical joint, else zero).
  std::vector<VectorX> q(static_cast<size_t>(n)), z(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const size_t i = static_cast<size_t>(k);
    Joint& joint = bodies.joints[i];
    q[i] = VectorX::Zero(coordinate_count(joint.type));
    z[i] = VectorX::Zero(speed_count(joint.type));
    if (relative_euler_joint(joint.type)) q[i][3] = 1.0;  // the identity's Euler parameters
    if (bodies.initial[i]) read_initial(r, *bodies.initial[i], k, initial, joint, q[i], z[i]);
  }

  try {
    Model model(std::move(bodies.specs), gravity, std::move(forces), name, std::move(bodies.joints),
                std::move(frames), std::move(inputs), std::move(constraints),
                std::move(independent_speeds));
    ModelFile file{std::move(model),
                   std::move(initial),
                   std::move(simulation),
                   source_name,
                   VectorX(),
                   VectorX(),
                   {},
                   {},
                   r.parameters()};
    const Model& m = file.model;
    file.q = VectorX::Zero(m.num_coordinates());
    file.z = VectorX::Zero(m.num_speeds());
    for (int k = 0; k < n; ++k) {
      const size_t i = static_cast<size_t>(k);
      if (m.joint(k).type == JointType::free) {
        // The notes' own coordinates and speeds: (eps_K, s'_K) and (w'_K, s'_K dot).
        q[i] << file.initial.euler_parameters(k), file.initial.translation(k);
        z[i] << file.initial.angular_velocity(k), file.initial.translation_rate(k);
      }
      file.q.segment(m.coordinate_offset(k), q[i].size()) = q[i];
      file.z.segment(m.speed_offset(k), z[i].size()) = z[i];
    }
    // The notes' state of (q, z); a free body's slices are copied, so an all-free model's is
    // its `initial:` entries as read (the same numbers).
    joint_state(m, file.q, file.z, file.initial);
    if (m.num_constraints() > 0) {
      // The initial state onto the constraints (the spec's "Constraints"), and the
      // independent speeds checked against [B] there; a failure points at its entry.
      try {
        file.projection = project_onto_constraints(m, file.q, file.z);
        ConstraintEquations equations(m);
        equations.evaluate(file.q, file.z);
        file.partition = partition_speeds(m, equations.B());
      } catch (const ConstraintError& e) {
        const std::string_view what = e.what();
        if (speeds_field && what.starts_with("independent_speeds: "))
          r.fail(*speeds_field, printable(what.substr(20), 400));
        for (size_t i = 0; i < m.constraints().size() && i < constraint_items.size(); ++i) {
          const std::string prefix = "constraint '" + m.constraints()[i].name + "': ";
          if (what.starts_with(prefix)) {
            const Field& item = constraint_items[i];
            std::string reason = "at the initial state: " + std::string(what.substr(prefix.size()));
            if (reason.find("did not converge") != std::string::npos)
              reason += "; is the initial state near an assembly of the mechanism?";
            r.fail(item.mark, item.path.str(), printable(reason, 400));
          }
        }
        r.fail(kNoPos, "", printable(what, 400));
      }
      joint_state(m, file.q, file.z, file.initial);
    }
    return file;
  } catch (const ModelError& e) {
    // Everything the Model checks was checked above with a location; this is a safety net,
    // and the Model's message names the body or force entry. One line, as every message. A
    // message about a constraint ("constraint 2 'pin': ...") or the independent speeds
    // points at that entry of the file, which the reader knows and the Model does not.
    const std::string_view what = e.what();
    if (const auto entry = detail::model_error_entry(what, "constraint");
        entry && entry->first < constraint_items.size()) {
      const Field& item = constraint_items[entry->first];
      r.fail(item.mark, item.path.str(), printable(entry->second, 400));
    }
    if (speeds_field && what.starts_with("independent_speeds: "))
      r.fail(*speeds_field, printable(what.substr(20), 400));
    r.fail(kNoPos, "", printable(what, 400));
  }
}

[[noreturn]] void out_of_memory(const std::string& source_name) {
  throw ModelFileError(source_name, 0, 0, "", "out of memory while loading the model file");
}

}  // namespace

ModelFile parse_model_file(const std::string& text, const std::string& source_name) {
  try {
    bool fast_used = false;
    try {
      return parse(text, source_name, true, fast_used);
    } catch (const ModelFileError&) {
      if (!fast_used) throw;
    }
    // Whatever refused the fast scanner's tree, libyaml's path refuses too (the trees are the
    // same); reading it again there gives the one message that path gives, syntax errors and
    // all.
    return parse(text, source_name, false, fast_used);
  } catch (const std::bad_alloc&) {
    out_of_memory(source_name);
  }
}

ModelFile load_model_file(const std::string& path) {
  std::string text;
  try {
    text = read_whole_file(open_regular_file(path), kMaxFileBytes, "a model file");
  } catch (const std::bad_alloc&) {
    out_of_memory(path);
  } catch (const std::runtime_error& e) {
    throw ModelFileError(path, 0, 0, "", e.what());
  }
  // A URDF robot reads as the model file `kanedyn import` writes for it (docs/urdf.md).
  if (path.ends_with(".urdf")) {
    // The conversion reads its text back with parse_model_file: that model is the answer.
    std::optional<ModelFile> file;
    detail::convert_urdf(text, path, {}, nullptr, &file);
    return std::move(*file);
  }
  return parse_model_file(text, path);
}

SimulationSettings simulation_settings(const SimulationSection& section) {
  SimulationSettings s;
  s.t_end = section.t_end.value_or(s.t_end);
  s.dt_out = section.dt_out.value_or(s.dt_out);
  s.rtol = section.rtol.value_or(s.rtol);
  s.atol = section.atol.value_or(s.atol);
  s.step = section.step.value_or(s.step);
  if (section.integrator) s.integrator = parse_integrator(*section.integrator);
  if (section.route) s.route = parse_route(*section.route);
  return s;
}

namespace detail {

ModelFile parse_model_file_with_libyaml(const std::string& text, const std::string& source_name) {
  try {
    bool fast_used = false;
    return parse(text, source_name, false, fast_used);
  } catch (const std::bad_alloc&) {
    out_of_memory(source_name);
  }
}

FrontEnds compare_front_ends(std::string_view text) {
  FrontEnds result;
  Tree fast;
  result.fast_accepted = build_fast_tree(text, fast);
  try {
    Reader reader("text");
    const Tree& tree = reader.tree_of(text, false);
    result.libyaml_accepted = true;
    result.nodes = tree.nodes.size();
    if (result.fast_accepted) result.difference = tree_difference(fast, tree);
  } catch (const ModelFileError& e) {
    result.libyaml_error = e.what();
    if (result.fast_accepted)
      result.difference =
          "the fast scanner read a text that libyaml refuses: " + result.libyaml_error;
  }
  return result;
}

}  // namespace detail

// ---- ModelDocument ------------------------------------------------------------------------

struct ModelDocument::Impl {
  std::string text;  // the text the tree views (never moved: Impl stays where it is made)
  std::string source_name;
  Tree tree;
  std::optional<ModelFile> base;
};

namespace {

/// The key path's first `end` characters, for messages.
std::string path_prefix(std::string_view key_path, size_t end) {
  return printable(key_path.substr(0, end), 200);
}

/// A list index: digits only, no sign.
std::optional<size_t> list_index(std::string_view s) {
  if (s.empty() || s.size() > 9 ||
      !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  size_t v = 0;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}

/// The entry of the mapping `map` under `key`, or a message naming the closest key it has.
Node mapping_entry(const Node& map, std::string_view key, std::string_view key_path, size_t at) {
  std::vector<std::string> keys;
  for (size_t i = 0; i < map.size(); ++i) {
    const Node k = map.key(i);
    if (k.IsScalar() && k.Scalar() == key) return map.value(i);
    if (k.IsScalar()) keys.emplace_back(k.Scalar());
  }
  const std::string where = at == 0 ? std::string("the model file") : path_prefix(key_path, at);
  std::string problem = where + " has no key " + quote(key);
  std::string best;
  size_t best_distance = std::numeric_limits<size_t>::max();
  for (const std::string& k : keys)
    if (const size_t d = edit_distance(key, k); d < best_distance) {
      best_distance = d;
      best = k;
    }
  if (!best.empty()) problem += " (closest: " + quote(best) + ")";
  throw std::invalid_argument(problem);
}

/// Body `ref` of the `bodies` list: a name, or K counted from 1.
Node body_entry(const Node& bodies, std::string_view ref) {
  const size_t n = bodies.size();
  if (const auto k = list_index(ref)) {
    if (*k >= 1 && *k <= n) return bodies[*k - 1];
    throw std::invalid_argument("bodies[" + std::string(ref) + "]: the file has " +
                                std::to_string(n) + " bodies, numbered 1 to " + std::to_string(n));
  }
  std::vector<std::string> names;
  for (size_t i = 0; i < n; ++i) {
    const Node body = bodies[i];
    if (!body.IsMap()) continue;
    for (size_t j = 0; j < body.size(); ++j)
      if (body.key(j).Scalar() == "name" && body.value(j).IsScalar()) {
        if (body.value(j).Scalar() == ref) return body;
        names.emplace_back(body.value(j).Scalar());
      }
  }
  std::string problem = "no body named " + quote(ref);
  std::string best;
  size_t best_distance = std::numeric_limits<size_t>::max();
  for (const std::string& name : names)
    if (const size_t d = edit_distance(ref, name); d < best_distance) {
      best_distance = d;
      best = name;
    }
  if (!best.empty()) problem += " (closest: " + quote(best) + ")";
  throw std::invalid_argument(problem);
}

/// The shortest decimal that reads back as `value`: what a changed number becomes in the tree.
std::string shortest(double value) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof buf, value);
  return std::string(buf, result.ptr);
}

}  // namespace

ModelDocument ModelDocument::load(const std::string& path, const std::string& source_name) {
  const std::string name = source_name.empty() ? path : source_name;
  std::string text;
  try {
    text = read_whole_file(open_regular_file(path), kMaxFileBytes, "a model file");
  } catch (const std::bad_alloc&) {
    out_of_memory(name);
  } catch (const std::runtime_error& e) {
    throw ModelFileError(name, 0, 0, "", e.what());
  }
  if (path.ends_with(".urdf"))
    throw ModelFileError(name, 0, 0, "",
                         "a URDF file cannot be changed number by number; convert it with "
                         "`kanedyn import` and name the model file it writes");
  return parse(std::move(text), name);
}

ModelDocument ModelDocument::parse(std::string text, const std::string& source_name) {
  auto impl = std::make_shared<Impl>();
  impl->source_name = source_name;
  try {
    Reader r(source_name);
    const Node root = r.load(text, true);
    try {
      impl->base = read_model(r, root, source_name);
    } catch (const ModelFileError&) {
      // The message of the one path every refusal takes (parse_model_file).
      impl->base = parse_model_file(text, source_name);
    }
    impl->tree = r.take_tree();
    // The tree views the text it was read from (a copy when the reader changed it): own it.
    impl->text = std::string(impl->tree.text);
    impl->tree.text = impl->text;
  } catch (const std::bad_alloc&) {
    out_of_memory(source_name);
  }
  ModelDocument doc;
  doc.impl_ = std::move(impl);
  return doc;
}

const ModelFile& ModelDocument::base() const { return *impl_->base; }
const std::string& ModelDocument::text() const { return impl_->text; }
const std::string& ModelDocument::source_name() const { return impl_->source_name; }

ModelDocument::Number ModelDocument::find_number(std::string_view key_path) const {
  const Tree& tree = impl_->tree;
  Node node(&tree, tree.root);
  size_t i = 0;
  const auto fail = [&](const std::string& problem) -> void {
    throw std::invalid_argument(problem);
  };
  if (key_path.empty()) fail("an empty key path");
  bool top_bodies = false;
  while (i < key_path.size()) {
    // A key, then any number of [index].
    const size_t key_end = std::min(key_path.find_first_of(".[", i), key_path.size());
    const std::string_view key = key_path.substr(i, key_end - i);
    if (key.empty()) fail("a key is missing at character " + std::to_string(i + 1));
    if (!node.IsMap())
      fail(path_prefix(key_path, i - 1) + " holds " + describe(node) + ", which has no keys");
    top_bodies = i == 0 && key == "bodies";
    node = mapping_entry(node, key, key_path, i == 0 ? 0 : i - 1);
    i = key_end;
    while (i < key_path.size() && key_path[i] == '[') {
      const size_t close = key_path.find(']', i);
      if (close == std::string_view::npos) fail("a '[' without its ']'");
      const std::string_view ref = key_path.substr(i + 1, close - i - 1);
      if (!node.IsSequence())
        fail(path_prefix(key_path, i) + " holds " + describe(node) + ", not a list");
      if (top_bodies) {
        node = body_entry(node, ref);
        top_bodies = false;
      } else {
        const auto k = list_index(ref);
        if (!k)
          fail(path_prefix(key_path, close + 1) +
               ": list entries are numbered from 0 (only bodies go by name)");
        if (*k >= node.size())
          fail(path_prefix(key_path, close + 1) + ": " + path_prefix(key_path, i) + " has " +
               std::to_string(node.size()) + " entries, numbered from 0");
        node = node[*k];
      }
      i = close + 1;
    }
    if (i < key_path.size()) {
      if (key_path[i] != '.') fail("expected '.' or '[' at character " + std::to_string(i + 1));
      ++i;
      if (i == key_path.size()) fail("the key path ends with '.'");
    }
  }
  const std::string whole = path_prefix(key_path, key_path.size());
  if (node.IsSequence())
    fail(whole + " holds " + describe(node) + " numbers; name one, as " + whole + "[0]");
  if (node.IsMap()) {
    std::vector<std::string> keys;
    for (size_t k = 0; k < node.size(); ++k) keys.emplace_back(node.key(k).Scalar());
    fail(whole + " holds a mapping; name one of its keys: " + join(keys));
  }
  std::optional<double> value = Reader::plain_number(node);
  if (!value) {
    // An expression (a parameter's, or `= ...` in a number's place): the value it had. A
    // change replaces it by the number given.
    const Parameters& p = base().parameters;
    for (const Parameters::Parameter& e : p.parameters)
      if (e.node == node.index()) value = e.value;
    for (const Parameters::Number& e : p.numbers)
      if (e.node == node.index() && !e.text.empty()) value = e.value;
  }
  if (!value) fail(whole + " holds " + describe(node) + ", not a number");
  const Mark m = mark_of_pos(tree.text, node.mark());
  Number n;
  n.node = node.index();
  n.value = *value;
  n.line = static_cast<int>(m.line);
  n.column = static_cast<int>(m.column);
  return n;
}

ModelFile ModelDocument::build(std::span<const std::pair<uint32_t, double>> changes) const {
  Tree tree = impl_->tree;  // a copy: its nodes are changed, its text is shared
  for (const auto& [index, value] : changes) {
    if (index >= tree.nodes.size() || tree.nodes[index].kind != static_cast<uint32_t>(Kind::scalar))
      throw std::invalid_argument("ModelDocument::build: not a number's node");
    const std::string text = shortest(value);
    TreeNode& n = tree.nodes[index];
    n.string = 0;
    n.in_text = 0;
    n.first = static_cast<uint32_t>(tree.chars.size());
    n.count = static_cast<uint32_t>(text.size());
    tree.chars += text;
  }
  try {
    Reader r(impl_->source_name);
    const Node root = r.adopt(std::move(tree));
    return read_model(r, root, impl_->source_name);
  } catch (const std::bad_alloc&) {
    out_of_memory(impl_->source_name);
  }
}

namespace detail {

std::unique_ptr<YamlText> read_yaml(std::string text, const std::string& source_name,
                                    const std::string& kind) {
  auto doc = std::make_unique<YamlText>();
  try {
    Reader r(source_name);
    r.tree_of(text, true);
    doc->tree = r.take_tree();
    // The tree's text may be the reader's own copy (JSON after leading tabs): copied out
    // while the reader lives.
    doc->text = std::string(doc->tree.text);
    doc->tree.text = doc->text;
  } catch (const ModelFileError& e) {
    // The reader speaks of model files; say which kind of file this is.
    std::string problem = e.problem();
    for (size_t at = 0; (at = problem.find("a model file", at)) != std::string::npos;)
      problem.replace(at, 12, kind), at += kind.size();
    throw ModelFileError(e.file(), e.line(), e.column(), e.key_path(), problem);
  }
  return doc;
}

std::optional<std::pair<size_t, std::string_view>> model_error_entry(std::string_view message,
                                                                     std::string_view label) {
  // "LABEL N 'NAME': PROBLEM", N counted from 1; names are [A-Za-z0-9_-]+, so the first "': "
  // ends the name.
  if (!message.starts_with(label) || message.substr(label.size(), 1) != " ") return std::nullopt;
  const std::string_view rest = message.substr(label.size() + 1);
  size_t n = 0;
  const auto [end, error] = std::from_chars(rest.data(), rest.data() + rest.size(), n);
  if (error != std::errc() || n == 0) return std::nullopt;
  const std::string_view after = rest.substr(static_cast<size_t>(end - rest.data()));
  const size_t close = after.find("': ");
  if (!after.starts_with(" '") || close == std::string_view::npos) return std::nullopt;
  return std::pair{n - 1, after.substr(close + 3)};
}

std::pair<int, int> line_column(std::string_view text, Pos pos) {
  const Mark m = mark_of_pos(text, pos);
  return {static_cast<int>(m.line), static_cast<int>(m.column)};
}

}  // namespace detail

}  // namespace kanedyn::io
