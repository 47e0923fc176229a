// The model loader's document tree and its two front ends (private to kanedyn::io; the tests
// and the fuzz invariants include it to compare the front ends).
//
// libyaml's event parser (model_file.cpp) reads all of YAML 1.1 and JSON. The fast scanner
// (fast_tree.cpp) reads only the plain subset that model files are written in and fills the
// same tree: the same nodes in the same order, the same scalar texts and the same positions
// (libyaml's character index of each node's start). On anything outside that subset it
// declines and the loader runs libyaml from the start; and since a refused file is always
// refused again by the libyaml path, every message comes from one place.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kanedyn/io/model_file.hpp"

namespace kanedyn::io::detail {

/// A place in the text as libyaml counts it: the index of a character (a CRLF break is two);
/// kNoPos when unknown. Nodes keep only this; line and column are counted when a message
/// needs them.
using Pos = uint32_t;
constexpr Pos kNoPos = std::numeric_limits<Pos>::max();

/// Limits (docs/model-format.md, "Limits"). The format needs fewer than 10 levels of nesting;
/// a 100,000-body file is about 25 MB.
constexpr size_t kMaxFileBytes = size_t{256} << 20;
constexpr size_t kMaxDepth = 64;

enum class Kind : uint8_t { null, scalar, sequence, mapping };

/// One node of the document, 12 bytes: a scalar is `count` bytes at `first` of the text (when
/// it stands there as is) or of Tree::chars; a sequence or mapping has `count` children at
/// `first` of Tree::kids (a mapping: key, value, key, ...). Positions fit 28 bits: a file has
/// at most kMaxFileBytes = 2^28 bytes.
struct TreeNode {
  uint32_t pos : 28;
  uint32_t kind : 2;     // Kind
  uint32_t string : 1;   // quoted, a block scalar, or tagged !!str: text, never a number
  uint32_t in_text : 1;  // the scalar's bytes are in the text
  uint32_t first, count;
};
static_assert(sizeof(TreeNode) == 12);
constexpr Pos kMaxNodePos = (Pos{1} << 28) - 1;

/// The document: nodes in document order (a collection before its children), the children of
/// each collection stored together when it ends (so an inner collection's before its parent's),
/// the root at `root`.
struct Tree {
  std::string_view text;
  std::vector<TreeNode> nodes;
  std::vector<uint32_t> kids;
  std::string chars;
  uint32_t root = 0;
};

/// The YAML 1.2 core schema's null: an empty plain scalar, `~`, `null`, `Null`, `NULL`.
inline bool is_null_word(std::string_view s) {
  return s.empty() || s == "~" || s == "null" || s == "Null" || s == "NULL";
}

/// The fast front end: fills `tree` from `text` (which must outlive it) and returns true, or
/// returns false, leaving `tree` empty, when the text is outside the subset it reads
/// (fast_tree.cpp lists it). It never throws but std::bad_alloc.
bool build_fast_tree(std::string_view text, Tree& tree);

/// "" when the trees are the same node by node (positions, kinds, flags, texts, children),
/// else the first difference.
std::string tree_difference(const Tree& a, const Tree& b);

/// io::parse_model_file with libyaml only, the fast scanner left out: for the tests, whose
/// loads and messages must be the same either way.
ModelFile parse_model_file_with_libyaml(const std::string& text, const std::string& source_name);

/// Both front ends on one text.
struct FrontEnds {
  bool fast_accepted = false;     ///< the fast scanner read the text
  bool libyaml_accepted = false;  ///< libyaml built a tree (the checks are not run)
  std::string libyaml_error;      ///< its message otherwise
  size_t nodes = 0;               ///< in the libyaml tree
  std::string difference;         ///< "" when they agree, or the fast scanner declined
};
FrontEnds compare_front_ends(std::string_view text);

/// A YAML document other than a model file (a study file): its text and the tree viewing it.
struct YamlText {
  std::string text;
  Tree tree;
};
/// Parses `text` by the model files' rules of YAML (one document, no tags, the size limit);
/// throws ModelFileError naming source_name, whose problem calls the file `kind` ("a study
/// file").
std::unique_ptr<YamlText> read_yaml(std::string text, const std::string& source_name,
                                    const std::string& kind);
/// The 1-based line and column of position `pos` of `text` (0, 0 for kNoPos).
std::pair<int, int> line_column(std::string_view text, Pos pos);

/// The entry a Model's message is about, when it begins as the Model's messages about list
/// entries do ("constraint 2 'pin': length must be > 0" for `label` "constraint"): the entry's
/// 0-based index and the problem after the name; nothing for any other message.
std::optional<std::pair<size_t, std::string_view>> model_error_entry(std::string_view message,
                                                                     std::string_view label);

}  // namespace kanedyn::io::detail
