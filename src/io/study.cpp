#include "kanedyn/io/study.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <limits>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <thread>
#include <unordered_set>
#include <variant>

#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/threads.hpp"
#include "model_tree.hpp"

namespace kanedyn::io {

namespace {

using detail::Kind;
using detail::Pos;
using detail::Tree;

constexpr const char* kStudyFormat = "kanedyn-study/1";
constexpr const char* kManifestLine = "# kanedyn-study manifest 1, fingerprint ";
/// The refusal of a study of more than kMaxStudyRuns runs: "`what` more than 10^7 runs...".
std::string too_many_runs(const std::string& what) {
  return what + " more than 10^7 runs, the most a study may have (its folder holds every run's " +
         "row in memory; docs/studies.md, \"Limits\")";
}

// ---- The study file's tree ------------------------------------------------------------------

/// A node of the study file's tree.
class YNode {
 public:
  YNode(const Tree* tree, uint32_t index) : tree_(tree), index_(index) {}
  Kind kind() const { return static_cast<Kind>(node().kind); }
  bool is(Kind k) const { return kind() == k; }
  size_t size() const {
    const auto& n = node();
    return kind() == Kind::mapping ? n.count / 2 : kind() == Kind::sequence ? n.count : 0;
  }
  YNode operator[](size_t i) const { return kid(i); }
  YNode key(size_t i) const { return kid(2 * i); }
  YNode value(size_t i) const { return kid(2 * i + 1); }
  bool quoted() const { return node().string; }
  std::string_view scalar() const {
    const auto& n = node();
    if (kind() != Kind::scalar) return {};
    return (n.in_text ? tree_->text : std::string_view(tree_->chars)).substr(n.first, n.count);
  }
  Pos pos() const { return node().pos; }

 private:
  const detail::TreeNode& node() const { return tree_->nodes[index_]; }
  YNode kid(size_t i) const { return {tree_, tree_->kids[node().first + i]}; }
  const Tree* tree_;
  uint32_t index_;
};

std::string quote(std::string_view s) { return "'" + printable(s, 80) + "'"; }

std::string describe(const YNode& n) {
  if (n.is(Kind::null)) return "nothing (null)";
  if (n.is(Kind::sequence)) return "a list of " + std::to_string(n.size());
  if (n.is(Kind::mapping)) return "a mapping";
  return quote(n.scalar());
}

/// Reads the study file's values, each refusal located.
class StudyReader {
 public:
  StudyReader(const std::string& file, const Tree& tree) : file_(file), tree_(tree) {}

  [[noreturn]] void fail(Pos pos, const std::string& path, const std::string& problem) const {
    const auto [line, column] = detail::line_column(tree_.text, pos);
    throw StudyFileError(file_, line, column, path, problem);
  }
  [[noreturn]] void fail(const YNode& n, const std::string& path,
                         const std::string& problem) const {
    fail(n.pos(), path, problem);
  }

  /// The entries of a mapping, refusing duplicate keys and keys not in `allowed`.
  std::map<std::string, YNode> mapping(const YNode& n, const std::string& path,
                                       const std::vector<std::string>& allowed) const {
    if (!n.is(Kind::mapping)) fail(n, path, "expected a mapping, got " + describe(n));
    std::map<std::string, YNode> entries;
    for (size_t i = 0; i < n.size(); ++i) {
      const YNode k = n.key(i);
      const std::string key(k.scalar());
      // The key as messages show it: a key the YAML reader lets through may hold a tab.
      const std::string shown = printable(key, 60);
      const std::string at = path.empty() ? shown : path + "." + shown;
      if (!k.is(Kind::scalar)) fail(k, path, "keys must be plain words, got " + describe(k));
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        std::string problem = "unknown key " + quote(key);
        if (const std::string c = closest_word(key, allowed); !c.empty())
          problem += " (did you mean " + quote(c) + "?)";
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(k, at, problem + "; allowed keys: " + list);
      }
      if (entries.count(key)) fail(k, at, "duplicate key " + quote(key));
      entries.emplace(key, n.value(i));
    }
    return entries;
  }

  double number(const YNode& n, const std::string& path) const {
    if (!n.is(Kind::scalar) || n.quoted()) fail(n, path, "expected a number, got " + describe(n));
    const std::string_view s = n.scalar();
    const char* first = s.data() + (!s.empty() && s[0] == '+' ? 1 : 0);
    double value = 0.0;
    const auto [end, error] = std::from_chars(first, s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size() || s.empty())
      fail(n, path, "expected a number, got " + quote(s));
    if (!std::isfinite(value)) fail(n, path, "numbers must be finite, got " + quote(s));
    return value;
  }

  /// A whole number in [low, high].
  long long integer(const YNode& n, const std::string& path, long long low, long long high) const {
    if (!n.is(Kind::scalar) || n.quoted())
      fail(n, path, "expected a whole number, got " + describe(n));
    const std::string_view s = n.scalar();
    long long value = 0;
    const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size() || s.empty())
      fail(n, path, "expected a whole number, got " + quote(s));
    if (value < low || value > high)
      fail(n, path,
           "must be from " + std::to_string(low) + " to " + std::to_string(high) + ", got " +
               quote(s));
    return value;
  }

  std::string text(const YNode& n, const std::string& path) const {
    if (!n.is(Kind::scalar)) fail(n, path, "expected a text value, got " + describe(n));
    return std::string(n.scalar());
  }

  std::vector<double> numbers(const YNode& n, const std::string& path) const {
    if (!n.is(Kind::sequence) || n.size() == 0)
      fail(n, path, "expected a non-empty list of numbers, got " + describe(n));
    std::vector<double> v;
    for (size_t i = 0; i < n.size(); ++i)
      v.push_back(number(n[i], path + "[" + std::to_string(i) + "]"));
    return v;
  }

 private:
  const std::string& file_;
  const Tree& tree_;
};

std::uint64_t fnv1a(std::string_view text, std::uint64_t h = 14695981039346656037ULL) {
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ULL;
  }
  return h;
}

/// SplitMix64's finalizer: a bijection of 64-bit words whose every output bit depends on every
/// input bit.
std::uint64_t mix(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// The shortest decimal that reads back as the same double.
void put_number(std::string& out, double value) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof buf, value);
  out.append(buf, result.ptr);
}

/// A CSV field: quoted (RFC 4180) when it holds a comma, a quote or a line break.
void put_field(std::string& out, std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) {
    out += text;
    return;
  }
  out += '"';
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
}

/// The fields of one CSV line (RFC 4180 quoting); nothing if the quotes do not close.
std::optional<std::vector<std::string>> split_csv(std::string_view line) {
  std::vector<std::string> fields(1);
  bool in_quotes = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (in_quotes) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        in_quotes = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      in_quotes = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  if (in_quotes) return std::nullopt;
  return fields;
}

std::string join_columns(const std::vector<std::string>& columns) {
  std::string s;
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) s += ',';
    put_field(s, columns[i]);
  }
  return s;
}

// ---- Reading a study -------------------------------------------------------------------------

void read_vary(const StudyReader& r, const YNode& list, Study& study) {
  if (!list.is(Kind::sequence)) r.fail(list, "vary", "expected a list, got " + describe(list));
  const ModelFile& base = study.model.base();
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = "vary[" + std::to_string(i) + "]";
    const auto m = r.mapping(list[i], path,
                             {"key", "normal", "uniform", "lognormal", "choice", "grid", "values"});
    const auto key_it = m.find("key");
    if (key_it == m.end()) r.fail(list[i], path, "missing required key 'key'");
    StudyVary v;
    v.key = r.text(key_it->second, path + ".key");
    const YNode& key_node = key_it->second;
    if (m.size() != 2)
      r.fail(list[i], path,
             "give exactly one of normal, uniform, lognormal, choice, grid, values beside 'key'");
    for (const StudyVary& earlier : study.vary)
      if (earlier.key == v.key) r.fail(key_node, path + ".key", quote(v.key) + " is varied twice");
    // The key: an input's constant value, or a number of the model file.
    if (v.key.starts_with("inputs[")) {
      const size_t close = v.key.find(']');
      if (close == std::string::npos || close + 1 != v.key.size())
        r.fail(key_node, path + ".key",
               quote(v.key) + ": an input's value is named inputs[INDEX] or inputs[NAME]");
      const std::string ref = v.key.substr(7, close - 7);
      const auto& inputs = base.model.inputs();
      std::vector<std::string> names;
      for (size_t k = 0; k < inputs.size(); ++k) {
        names.push_back(inputs[k].name);
        if (inputs[k].name == ref || ref == std::to_string(k)) v.input = static_cast<int>(k);
      }
      if (v.input < 0) {
        std::string problem = quote(v.key) + " names nothing: ";
        if (inputs.empty()) {
          problem += "the model has no inputs";
        } else {
          problem += "the model's inputs are numbered 0 to " + std::to_string(inputs.size() - 1);
          const std::string c = closest_word(ref, names, 1000);
          if (!c.empty()) problem += " (closest name: " + quote(c) + ")";
        }
        r.fail(key_node, path + ".key", problem);
      }
    } else {
      try {
        v.node = study.model.find_number(v.key).node;
      } catch (const std::invalid_argument& e) {
        r.fail(key_node, path + ".key", quote(v.key) + " names nothing: " + e.what());
      }
      // A setting of the model's `simulation:` section that the study's `simulate:` sets
      // too: the run takes simulate's, and the table would show values never used.
      const std::pair<const char*, bool> settings[] = {
          {"t_end", study.simulate.t_end.has_value()},
          {"dt_out", study.simulate.dt_out.has_value()},
          {"rtol", study.simulate.rtol.has_value()},
          {"atol", study.simulate.atol.has_value()},
          {"step", study.simulate.step.has_value()}};
      for (const auto& [name, overridden] : settings) {
        if (!overridden) continue;
        std::optional<uint32_t> node;
        try {
          node = study.model.find_number(std::string("simulation.") + name).node;
        } catch (const std::invalid_argument&) {  // not in the model file: nothing to clash
        }
        if (node == v.node)
          r.fail(key_node, path + ".key",
                 quote(v.key) + " is the model's simulation." + name +
                     ", which the study's simulate." + name +
                     " overrides in every run: vary it without simulate." + name);
      }
    }
    // One number under two spellings (bodies[racket] and bodies[1], inputs[0] and
    // inputs[push]): each run would take the later entry's value, and the table would show the
    // earlier one's.
    for (size_t e = 0; e < study.vary.size(); ++e) {
      const StudyVary& earlier = study.vary[e];
      if (v.input >= 0 ? earlier.input == v.input : earlier.input < 0 && earlier.node == v.node)
        r.fail(key_node, path + ".key",
               quote(v.key) + " is the number that vary[" + std::to_string(e) + "].key " +
                   quote(earlier.key) + " varies already; vary it once");
    }
    const auto& [kind, value] =
        *std::find_if(m.begin(), m.end(), [](const auto& e) { return e.first != "key"; });
    const std::string at = path + "." + kind;
    if (kind == "normal" || kind == "lognormal") {
      const bool normal = kind == "normal";
      const std::string first = normal ? "mean" : "mu", second = normal ? "std" : "sigma";
      const auto p = r.mapping(value, at, {first, second});
      if (!p.count(first) || !p.count(second))
        r.fail(value, at, "needs both " + first + " and " + second);
      v.draw = normal ? Draw::normal : Draw::lognormal;
      v.a = r.number(p.at(first), at + "." + first);
      v.b = r.number(p.at(second), at + "." + second);
      if (v.b < 0.0) r.fail(p.at(second), at + "." + second, "must be >= 0");
    } else if (kind == "uniform") {
      const std::vector<double> range = r.numbers(value, at);
      if (range.size() != 2) r.fail(value, at, "expected [low, high], got " + describe(value));
      if (range[0] > range[1]) r.fail(value, at, "low must not exceed high");
      v.draw = Draw::uniform;
      v.a = range[0];
      v.b = range[1];
    } else {
      v.draw = kind == "choice" ? Draw::choice : Draw::grid;
      v.values = r.numbers(value, at);
      if (v.draw == Draw::grid) {
        if (study.grid_points > kMaxStudyRuns / static_cast<long>(v.values.size()))
          r.fail(value, at, too_many_runs("the grids make"));
        study.grid_points *= static_cast<long>(v.values.size());
      }
    }
    study.vary.push_back(std::move(v));
  }
}

void read_simulate(const StudyReader& r, const YNode& n, SimulationSection& s) {
  const auto m =
      r.mapping(n, "simulate", {"t_end", "dt_out", "integrator", "rtol", "atol", "step", "route"});
  const auto positive = [&](const char* key) -> std::optional<double> {
    const auto it = m.find(key);
    if (it == m.end()) return std::nullopt;
    const double v = r.number(it->second, std::string("simulate.") + key);
    if (!(v > 0.0)) r.fail(it->second, std::string("simulate.") + key, "must be > 0");
    return v;
  };
  const auto choice = [&](const char* key,
                          const std::vector<std::string>& allowed) -> std::optional<std::string> {
    const auto it = m.find(key);
    if (it == m.end()) return std::nullopt;
    const std::string v = r.text(it->second, std::string("simulate.") + key);
    if (std::find(allowed.begin(), allowed.end(), v) == allowed.end())
      r.fail(it->second, std::string("simulate.") + key,
             "unknown " + std::string(key) + " " + quote(v) + "; allowed: " + allowed[0] + ", " +
                 allowed[1]);
    return v;
  };
  s.t_end = positive("t_end");
  s.dt_out = positive("dt_out");
  s.rtol = positive("rtol");
  s.atol = positive("atol");
  s.step = positive("step");
  s.integrator = choice("integrator", {"dopri5", "rk4"});
  s.route = choice("route", {"recursive", "assembled"});
}

/// Whether `text` is a model file, however it is refused: a mapping whose `format` is
/// kanedyn-model/N; when it is not YAML at all, whether it names that format anywhere.
bool is_model_file(const std::string& text) {
  try {
    const auto doc = detail::read_yaml(text, "", "a model file");
    const Tree& tree = doc->tree;
    if (tree.nodes.empty()) return false;
    const YNode root(&tree, tree.root);
    if (!root.is(Kind::mapping)) return false;
    for (size_t i = 0; i < root.size(); ++i)
      if (root.key(i).scalar() == "format")
        return root.value(i).scalar().starts_with("kanedyn-model/");
    return false;
  } catch (const ModelFileError&) {
    return text.find("kanedyn-model/") != std::string::npos;
  }
}

/// The text of the model file that `refusal` was about, read again; rethrows `refusal` when it
/// cannot be (it then changed under us, and its own message is the truer one).
std::string reread(const std::string& path, const ModelFileError& refusal) {
  try {
    return read_whole_file(open_regular_file(path), std::size_t{256} << 20, "a model file");
  } catch (const std::exception&) {
    throw refusal;
  }
}

/// The index of the state entry `name` of the linearization, or why there is none.
std::variant<Eigen::Index, std::string> state_entry(const Linearization& lin,
                                                    const std::string& name) {
  const auto it = std::find(lin.state.begin(), lin.state.end(), name);
  if (it != lin.state.end()) return static_cast<Eigen::Index>(it - lin.state.begin());
  std::string problem = "no entry " + quote(name) + " in the linearization's state";
  if (const std::string c = closest_word(name, lin.state, 1000); !c.empty())
    problem += " (closest: " + quote(c) + ")";
  return problem;
}

/// The indices of the block `of` of the linearization's state in `block`; or why it is not a
/// block whose eigenvalues are A's.
std::optional<std::string> linearize_block(const Linearization& lin,
                                           const std::vector<std::string>& of,
                                           std::vector<Eigen::Index>& block) {
  const auto size = static_cast<Eigen::Index>(lin.state.size());
  std::vector<bool> in(static_cast<size_t>(size), false);
  block.clear();
  for (const std::string& name : of) {
    const auto entry = state_entry(lin, name);
    if (const auto* problem = std::get_if<std::string>(&entry)) return *problem;
    const Eigen::Index k = std::get<Eigen::Index>(entry);
    in[static_cast<size_t>(k)] = true;
    block.push_back(k);
  }
  // The block's eigenvalues are eigenvalues of A when A is block-triangular: the block's rows
  // do not depend on the other entries, or the other rows do not depend on the block. Zero is
  // judged against A's largest entry: 1e-9 of it is far above the round-off of a derivative
  // that vanishes (1e-17 where the bicycle's forward speed meets its lean) and far below a
  // coupling that matters.
  const double zero = 1e-9 * (size > 0 ? lin.A.cwiseAbs().maxCoeff() : 0.0);
  double rows_out = 0.0, cols_in = 0.0;
  Eigen::Index worst_row = 0, worst_col = 0;
  for (Eigen::Index i = 0; i < size; ++i)
    for (Eigen::Index j = 0; j < size; ++j) {
      if (in[static_cast<size_t>(i)] == in[static_cast<size_t>(j)]) continue;
      const double a = std::abs(lin.A(i, j));
      if (in[static_cast<size_t>(i)] && a > rows_out) {
        rows_out = a;
        worst_row = i;
        worst_col = j;
      }
      if (!in[static_cast<size_t>(i)]) cols_in = std::max(cols_in, a);
    }
  if (rows_out > zero && cols_in > zero) {
    char value[32];
    std::snprintf(value, sizeof value, "%.3g", lin.A(worst_row, worst_col));
    return "the block is coupled to the rest of A both ways (the rate of " +
           quote(lin.state[static_cast<size_t>(worst_row)]) + " depends on " +
           quote(lin.state[static_cast<size_t>(worst_col)]) + ", A = " + value +
           "), so its eigenvalues are not A's: add the entries it depends on";
  }
  return std::nullopt;
}

/// The operating point of a run's `linearize` outputs: its initial state, the inputs at the
/// run's constant values (zero for those not varied).
VectorX linearize_inputs(const Model& model, const SimulationSettings& settings) {
  VectorX u = VectorX::Zero(model.num_inputs());
  if (settings.inputs && settings.inputs->num_inputs() == model.num_inputs())
    settings.inputs->value(settings.t_start, u);
  return u;
}

/// Reads one `linearize` output (`at` is its key path) into `o`; `lin` is the study's model
/// linearized about its initial state, whose state names `of` is checked against.
void read_linearize(const StudyReader& r, const YNode& value, const std::string& at,
                    const Linearization& lin, StudyOutput& o) {
  StudyLinearize l;
  if (value.is(Kind::scalar)) {
    if (value.scalar() != "max_real")
      r.fail(value, at,
             "expected max_real or a mapping {mode: NAME, rank: K, of: [STATE, ...], value: "
             "real|imag|frequency|damping}, got " +
                 describe(value));
    o.name = "linearize:max_real";
    o.linearize = std::move(l);
    return;
  }
  const auto m = r.mapping(value, at, {"mode", "rank", "of", "value"});
  if (!m.count("mode")) r.fail(value, at, "missing required key 'mode' (the mode's name)");
  l.mode = r.text(m.at("mode"), at + ".mode");
  if (l.mode.empty() || l.mode.size() > 64 ||
      l.mode.find_first_not_of(
          "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-") != std::string::npos)
    r.fail(m.at("mode"), at + ".mode",
           "a mode's name is 1 to 64 letters, digits, '_' or '-', got " + quote(l.mode));
  if (const auto it = m.find("of"); it != m.end()) {
    const YNode& list = it->second;
    if (!list.is(Kind::sequence) || list.size() == 0)
      r.fail(list, at + ".of",
             "expected a non-empty list of the linearization's state names, got " + describe(list));
    for (size_t k = 0; k < list.size(); ++k) {
      const std::string name = r.text(list[k], at + ".of[" + std::to_string(k) + "]");
      if (std::find(l.of.begin(), l.of.end(), name) != l.of.end())
        r.fail(list[k], at + ".of[" + std::to_string(k) + "]", quote(name) + " is named twice");
      l.of.push_back(name);
      const auto entry = state_entry(lin, name);
      if (const auto* problem = std::get_if<std::string>(&entry))
        r.fail(list[k], at + ".of[" + std::to_string(k) + "]", *problem);
    }
    // Whether the block is one whose eigenvalues are A's depends on the run's values: each
    // run checks it (a failure of the run when it is not).
  }
  const long long entries =
      l.of.empty() ? static_cast<long long>(lin.state.size()) : static_cast<long long>(l.of.size());
  if (entries == 0) r.fail(value, at, "the model's linearization has no state: no modes");
  if (const auto it = m.find("rank"); it != m.end())
    l.rank = static_cast<int>(r.integer(it->second, at + ".rank", 1, entries));
  const std::vector<std::string> values{"real", "imag", "frequency", "damping"};
  std::string v = "real";
  if (const auto it = m.find("value"); it != m.end()) {
    v = r.text(it->second, at + ".value");
    const auto k = std::find(values.begin(), values.end(), v);
    if (k == values.end()) {
      std::string problem =
          "unknown value " + quote(v) + "; allowed: real, imag, frequency, damping";
      if (const std::string c = closest_word(v, values); !c.empty())
        problem += " (did you mean " + quote(c) + "?)";
      r.fail(it->second, at + ".value", problem);
    }
    l.value = static_cast<ModeValue>(k - values.begin());
  }
  o.name = "linearize:" + l.mode + "." + v;
  o.linearize = std::move(l);
}

void read_outputs(const StudyReader& r, const YNode& list, Study& study) {
  if (!list.is(Kind::sequence)) r.fail(list, "outputs", "expected a list, got " + describe(list));
  const ModelFile& base = study.model.base();
  const std::vector<std::string> columns = trajectory_columns(base.model);
  const std::vector<std::string> statistics{"final", "max", "min", "mean", "rms", "linearize"};
  std::optional<Linearization> lin;  // the model's, made for the first `linearize` output
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = "outputs[" + std::to_string(i) + "]";
    const auto m = r.mapping(list[i], path, statistics);
    if (m.size() != 1)
      r.fail(list[i], path,
             "expected one of final, max, min, mean, rms with a column name, or linearize");
    const auto& [kind, value] = *m.begin();
    StudyOutput o;
    if (kind == "linearize") {
      if (!lin) {
        try {
          lin = linearize(base.model, base.q, base.z, VectorX::Zero(base.model.num_inputs()));
        } catch (const std::exception& e) {
          r.fail(value, path + ".linearize",
                 "the model cannot be linearized about its initial state: " +
                     printable(e.what(), 400));
        }
      }
      read_linearize(r, value, path + ".linearize", *lin, o);
      for (const StudyOutput& earlier : study.outputs)
        if (earlier.name == o.name) r.fail(value, path, quote(o.name) + " is asked for twice");
      study.outputs.push_back(std::move(o));
      continue;
    }
    o.statistic = static_cast<Statistic>(std::find(statistics.begin(), statistics.end(), kind) -
                                         statistics.begin());
    o.column = r.text(value, path + "." + kind);
    const auto it = std::find(columns.begin(), columns.end(), o.column);
    if (it == columns.end()) {
      std::string problem = "no trajectory column " + quote(o.column);
      const std::string c = closest_word(o.column, columns, 1000);
      if (!c.empty()) problem += " (closest: " + quote(c) + ")";
      r.fail(value, path + "." + kind, problem);
    }
    o.column_index = static_cast<int>(it - columns.begin());
    o.name = kind + ":" + o.column;
    for (const StudyOutput& earlier : study.outputs)
      if (earlier.name == o.name) r.fail(value, path, quote(o.name) + " is asked for twice");
    study.outputs.push_back(std::move(o));
  }
}

long read_trajectories(const StudyReader& r, const YNode& n) {
  const std::string s = r.text(n, "trajectories");
  if (s == "none") return 0;
  if (s == "all") return 1;
  if (s.starts_with("every ")) {
    const std::string_view count = std::string_view(s).substr(6);
    long v = 0;
    const auto [end, error] = std::from_chars(count.data(), count.data() + count.size(), v);
    if (error == std::errc() && end == count.data() + count.size() && v >= 1) return v;
  }
  r.fail(n, "trajectories",
         "expected none, all or 'every N' (N a whole number >= 1), got " + quote(s));
}

}  // namespace

Study parse_study(std::string text, const std::string& source_name, const std::string& base_dir,
                  const std::string* model_text) {
  const auto doc = detail::read_yaml(std::move(text), source_name, "a study file");
  const Tree& tree = doc->tree;
  const StudyReader r(source_name, tree);
  if (tree.nodes.empty() || YNode(&tree, tree.root).is(Kind::null))
    r.fail(detail::kNoPos, "",
           "the file is empty; a study file is a mapping starting with 'format: " +
               std::string(kStudyFormat) + "'");
  const YNode root(&tree, tree.root);
  if (!root.is(Kind::mapping))
    r.fail(root, "",
           "a study file must be a mapping (key: value lines), got " +
               (root.is(Kind::sequence) ? describe(root)
                                        : std::string("plain text (not shown: this is no study "
                                                      "file)")));
  // The format first: a file of another kind is told so, not about its keys.
  std::optional<YNode> format;
  for (size_t i = 0; i < root.size(); ++i)
    if (root.key(i).scalar() == "format") format = root.value(i);
  if (!format)
    r.fail(root, "format",
           "missing required key 'format'; a study file starts with 'format: " +
               std::string(kStudyFormat) + "'");
  if (const std::string f = r.text(*format, "format"); f != kStudyFormat)
    r.fail(
        *format, "format",
        "unsupported format " + quote(f) + "; this version reads 'format: " + kStudyFormat + "'");
  const auto top = r.mapping(
      root, "", {"format", "model", "seed", "runs", "vary", "simulate", "outputs", "trajectories"});

  Study study;
  study.path = source_name;
  study.text = doc->text;
  const auto model_it = top.find("model");
  if (model_it == top.end()) r.fail(root, "model", "missing required key 'model'");
  const std::string model_name = r.text(model_it->second, "model");
  if (model_name.empty()) r.fail(model_it->second, "model", "the model file's name is empty");
  // An escape ("\0", "\u0000") can put a NUL byte in the name: the C library would end the
  // name there and read another file.
  if (model_name.find('\0') != std::string::npos)
    r.fail(model_it->second, "model", "the model file's name holds a NUL byte");
  const std::filesystem::path model_path(model_name);
  study.model_path = model_path.is_absolute() || base_dir.empty()
                         ? model_name
                         : (std::filesystem::path(base_dir) / model_path).string();
  // The model's messages name it as the study does, whatever the current folder: the table of
  // one study is the same file wherever it runs.
  try {
    study.model = model_text ? ModelDocument::parse(*model_text, model_name)
                             : ModelDocument::load(study.model_path, model_name);
  } catch (const ModelFileError& e) {
    // A file that cannot be read is the study's `model:` key at fault; a model file that is
    // read and refused says where, in its own message. `model:` may name any file, though, and
    // a refusal of its contents quotes them: a file that is not a model file is told so alone.
    if (e.line() > 0 || !e.key_path().empty()) {
      if (!is_model_file(model_text ? *model_text : reread(study.model_path, e)))
        r.fail(model_it->second, "model",
               quote(study.model_path) +
                   " is not a model file (a model file is a mapping starting with 'format: "
                   "kanedyn-model/1', docs/model-format.md)");
      throw;
    }
    r.fail(model_it->second, "model",
           "the model file " + quote(study.model_path) + ": " + e.problem());
  }

  if (const auto it = top.find("runs"); it != top.end()) {
    // Read as any whole number first, so that a count too large is told the limit's reason.
    const long long runs = r.integer(it->second, "runs", 1, std::numeric_limits<long long>::max());
    if (runs > kMaxStudyRuns)
      r.fail(it->second, "runs", too_many_runs(quote(it->second.scalar()) + " is"));
    study.runs_per_point = static_cast<long>(runs);
  }
  // `simulate` before `vary`: a varied setting that `simulate` overrides is refused there.
  if (const auto it = top.find("simulate"); it != top.end())
    read_simulate(r, it->second, study.simulate);
  if (const auto it = top.find("vary"); it != top.end()) read_vary(r, it->second, study);
  const bool draws = std::any_of(study.vary.begin(), study.vary.end(),
                                 [](const StudyVary& v) { return v.draw != Draw::grid; });
  if (const auto it = top.find("seed"); it != top.end()) {
    const YNode& n = it->second;
    const std::string_view s = n.scalar();
    std::uint64_t seed = 0;
    const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), seed);
    if (!n.is(Kind::scalar) || n.quoted() || s.empty() || error != std::errc() ||
        end != s.data() + s.size())
      r.fail(n, "seed", "expected a whole number from 0 to 2^64 - 1, got " + describe(n));
    study.seed = seed;
  } else if (draws) {
    r.fail(root, "seed",
           "missing key 'seed': a study that draws random numbers needs one, so that its "
           "results can be made again");
  }
  if (study.grid_points > kMaxStudyRuns / study.runs_per_point)
    r.fail(top.count("runs") ? top.at("runs") : root, "runs",
           too_many_runs("the grids times `runs` make"));
  study.runs = study.grid_points * study.runs_per_point;
  if (const auto it = top.find("outputs"); it != top.end()) read_outputs(r, it->second, study);
  if (const auto it = top.find("trajectories"); it != top.end())
    study.keep_every = read_trajectories(r, it->second);
  // Settings refused for the model as the file gives it are the study's error, not each run's.
  try {
    validate_settings(study.model.base().model, study.settings(study.model.base()));
  } catch (const std::invalid_argument& e) {
    const auto it = top.find("simulate");
    r.fail(it != top.end() ? it->second : root, "simulate", e.what());
  }
  study.fingerprint = fnv1a(study.model.text(), fnv1a(study.text));
  return study;
}

Study load_study(const std::string& path) {
  std::string text;
  try {
    text = read_whole_file(open_regular_file(path), std::size_t{16} << 20, "a study file");
  } catch (const std::runtime_error& e) {
    throw StudyFileError(path, 0, 0, "", e.what());
  }
  return parse_study(std::move(text), path, std::filesystem::path(path).parent_path().string());
}

std::vector<std::string> Study::columns() const {
  std::vector<std::string> c{"run"};
  for (const StudyVary& v : vary) c.push_back(v.key);
  for (const StudyOutput& o : outputs) c.push_back(o.name);
  for (const std::string& name : function_outputs) c.push_back(name);
  c.emplace_back("status");
  c.emplace_back("wall_s");
  return c;
}

void Study::set_function_outputs(std::vector<std::string> names) {
  function_outputs.clear();
  const std::vector<std::string> taken = columns();
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    const std::string at = "function output " + std::to_string(i) + " ";
    if (name.empty()) throw std::invalid_argument(at + "has an empty name");
    if (std::any_of(name.begin(), name.end(),
                    [](char ch) { return static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f; }))
      throw std::invalid_argument(at + quote(name) + " holds a control character");
    if (std::find(taken.begin(), taken.end(), name) != taken.end())
      throw std::invalid_argument(at + quote(name) + " is already a column of the study's table");
    if (std::find(names.begin(), names.begin() + static_cast<long>(i), name) !=
        names.begin() + static_cast<long>(i))
      throw std::invalid_argument(at + quote(name) + " is named twice");
  }
  // The names are part of the folder's identity: the rows of a study without them (or with
  // others) are another table's.
  std::string joined = "function outputs";
  for (const std::string& name : names) joined += "\n" + name;
  fingerprint = fnv1a(model.text(), fnv1a(text));
  if (!names.empty()) fingerprint = fnv1a(joined, fingerprint);
  function_outputs = std::move(names);
}

bool Study::simulates() const {
  // A study of trajectory outputs, or of none (its runs' statuses are its results), simulates;
  // one whose every output is a linearization's or a function's needs no trajectory.
  const bool reads_trajectory = std::any_of(outputs.begin(), outputs.end(),
                                            [](const StudyOutput& o) { return !o.linearize; });
  return keep_every > 0 || reads_trajectory || (outputs.empty() && function_outputs.empty());
}

double study_uniform(std::uint64_t seed, std::uint64_t run, std::uint64_t entry, std::uint64_t k) {
  const std::uint64_t bits = mix(mix(mix(seed) ^ run) ^ (entry << 8 | (k & 0xff)));
  return static_cast<double>(bits >> 11) * 0x1p-53;
}

std::vector<double> Study::parameters(long run) const {
  if (run < 0 || run >= runs) throw std::out_of_range("run " + std::to_string(run));
  std::vector<double> p(vary.size());
  long point = run / runs_per_point;
  for (size_t j = vary.size(); j-- > 0;) {
    const StudyVary& v = vary[j];
    if (v.draw != Draw::grid) continue;
    const long n = static_cast<long>(v.values.size());
    p[j] = v.values[static_cast<size_t>(point % n)];
    point /= n;
  }
  const auto u = [&](size_t j, std::uint64_t k) {
    return study_uniform(seed, static_cast<std::uint64_t>(run), j, k);
  };
  for (size_t j = 0; j < vary.size(); ++j) {
    const StudyVary& v = vary[j];
    switch (v.draw) {
      case Draw::grid:
        break;
      case Draw::uniform:
        // low + (high - low) u, the formula of docs/studies.md; a range wider than the largest
        // double (high - low overflows) is drawn as the same point written without the width.
        p[j] = std::isfinite(v.b - v.a) ? v.a + (v.b - v.a) * u(j, 0)
                                        : v.a * (1.0 - u(j, 0)) + v.b * u(j, 0);
        break;
      case Draw::choice: {
        const auto n = v.values.size();
        p[j] = v.values[std::min(n - 1, static_cast<size_t>(u(j, 0) * static_cast<double>(n)))];
        break;
      }
      case Draw::normal:
      case Draw::lognormal: {
        // Box-Muller: 1 - u is in (0, 1], so the log is finite.
        const double z =
            std::sqrt(-2.0 * std::log(1.0 - u(j, 0))) * std::cos(2.0 * std::numbers::pi * u(j, 1));
        p[j] = v.draw == Draw::normal ? v.a + v.b * z : std::exp(v.a + v.b * z);
        break;
      }
    }
  }
  return p;
}

SimulationSettings Study::settings(const ModelFile& file) const {
  SimulationSection s = file.simulation;
  if (simulate.t_end) s.t_end = simulate.t_end;
  if (simulate.dt_out) s.dt_out = simulate.dt_out;
  if (simulate.integrator) s.integrator = simulate.integrator;
  if (simulate.rtol) s.rtol = simulate.rtol;
  if (simulate.atol) s.atol = simulate.atol;
  if (simulate.step) s.step = simulate.step;
  if (simulate.route) s.route = simulate.route;
  return simulation_settings(s);
}

std::string status_kind(const std::string& status) {
  const size_t colon = status.find(": ");
  return colon == std::string::npos ? status : status.substr(0, colon);
}

// ---- One run ---------------------------------------------------------------------------------

namespace {

/// The numbers of one trajectory row, in the order of trajectory_columns() (the writer's,
/// csv.cpp): t, per body G_K, eps, s', w', s' dot and the joint columns, energy, inputs, the
/// constraints' reactions.
/// Without `kinematics` (data's not computed for this state) G_K is left 0.
void row_values(const Model& model, double t, const State& state, const VectorX& q,
                const VectorX& z, const Data& data, bool kinematics, double energy,
                std::vector<double>& row) {
  row.clear();
  row.push_back(t);
  const auto put = [&row](const auto& v) {
    for (Eigen::Index i = 0; i < v.size(); ++i) row.push_back(v[i]);
  };
  const bool jointed = !model.all_free();
  for (int k = 0; k < model.num_bodies(); ++k) {
    put(kinematics ? data.kinematics.p_G[static_cast<size_t>(k)] : Vector3::Zero().eval());
    put(state.euler_parameters(k));
    put(state.translation(k));
    put(state.angular_velocity(k));
    put(state.translation_rate(k));
    const JointType type = model.joint(k).type;
    if (jointed && joint_type_info(type).coordinates > 0 && !joint_type_info(type).absolute) {
      put(q.segment(model.coordinate_offset(k), coordinate_count(type)));
      put(z.segment(model.speed_offset(k), speed_count(type)));
    }
  }
  row.push_back(energy);
  if (model.num_inputs() > 0) put(data.inputs);
  put(data.reactions);
}

/// A running statistic of one column.
struct Accumulator {
  double final = 0.0, max = -std::numeric_limits<double>::infinity(),
         min = std::numeric_limits<double>::infinity(), sum = 0.0, sum_squares = 0.0;
  long rows = 0;
  void add(double v) {
    final = v;
    max = std::max(max, v);
    min = std::min(min, v);
    sum += v;
    sum_squares += v * v;
    ++rows;
  }
  double value(Statistic s) const {
    switch (s) {
      case Statistic::final:
        return final;
      case Statistic::max:
        return max;
      case Statistic::min:
        return min;
      case Statistic::mean:
        return sum / static_cast<double>(rows);
      case Statistic::rms:
        return std::sqrt(sum_squares / static_cast<double>(rows));
    }
    return 0.0;
  }
};

std::string one_line(const std::string& kind, const std::string& message) {
  return kind + ": " + printable(message, 2000);
}

/// A failure of one run, its status already "KIND: message".
struct RunFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace

namespace {

/// Run `run`'s model, built with its values p, and its settings (inputs held at their values);
/// throws RunFailure when the values make either invalid.
std::pair<ModelFile, SimulationSettings> run_model(const Study& study,
                                                   const std::vector<double>& p) {
  std::vector<std::pair<uint32_t, double>> changes;
  for (size_t j = 0; j < p.size(); ++j)
    if (study.vary[j].input < 0) changes.emplace_back(study.vary[j].node, p[j]);
  std::optional<ModelFile> file;
  try {
    file = study.model.build(changes);
  } catch (const ModelFileError& e) {
    throw RunFailure(one_line("invalid model", e.what()));
  }
  const Model& model = file->model;
  SimulationSettings settings = study.settings(*file);
  if (std::any_of(study.vary.begin(), study.vary.end(),
                  [](const auto& v) { return v.input >= 0; })) {
    // One row of the inputs table holds from t_start on.
    MatrixX u = MatrixX::Zero(1, model.num_inputs());
    for (size_t j = 0; j < p.size(); ++j)
      if (study.vary[j].input >= 0) u(0, study.vary[j].input) = p[j];
    settings.inputs = std::make_shared<const InputTable>(std::vector<double>{settings.t_start}, u);
  }
  try {
    validate_settings(model, settings);
  } catch (const std::invalid_argument& e) {
    throw RunFailure(one_line("invalid settings", e.what()));
  }
  return {std::move(*file), std::move(settings)};
}

/// Reduces a run's output rows to the study's outputs, and writes them as a trajectory CSV
/// when kept. The kinematics and the energy of a row are computed only when read.
class RowReducer {
 public:
  RowReducer(const Study& study, const Model& model, bool keep, std::string& trajectory)
      : study_(study),
        model_(model),
        keep_(keep),
        trajectory_(trajectory),
        outputs_(study.outputs.size()) {
    const int energy_column = static_cast<int>(trajectory_columns(model).size()) - 1 -
                              model.num_inputs() - reaction_count(model);
    needs_energy_ = needs_kinematics_ = keep;
    for (const StudyOutput& o : study.outputs) {
      if (o.linearize) continue;
      needs_energy_ = needs_energy_ || o.column_index == energy_column;
      needs_kinematics_ =
          needs_kinematics_ || (o.column_index > 0 && o.column_index <= energy_column);
    }
    if (keep) trajectory_ = join_columns(trajectory_columns(model)) + "\n";
  }
  bool needs_kinematics() const { return needs_kinematics_; }

  void add(double t, const State& state, const VectorX& q, const VectorX& z, const Data& data) {
    double energy = 0.0;
    if (needs_energy_)
      energy = model_.all_free() ? total_energy_of_kinematics(model_, state, data)
                                 : total_energy_of_kinematics(model_, state, q, data);
    row_values(model_, t, state, q, z, data, needs_kinematics_, energy, row_);
    for (size_t i = 0; i < outputs_.size(); ++i)
      if (!study_.outputs[i].linearize)
        outputs_[i].add(row_[static_cast<size_t>(study_.outputs[i].column_index)]);
    if (!keep_) return;
    for (size_t i = 0; i < row_.size(); ++i) {
      if (i) trajectory_ += ',';
      put_number(trajectory_, row_[i]);
    }
    trajectory_ += '\n';
  }
  double output(size_t i) const { return outputs_[i].value(study_.outputs[i].statistic); }

 private:
  const Study& study_;
  const Model& model_;
  bool keep_;
  std::string& trajectory_;
  std::vector<Accumulator> outputs_;
  std::vector<double> row_;
  bool needs_energy_ = false, needs_kinematics_ = false;
};

}  // namespace

namespace {

/// A run's `linearize` output from its linearization: throws RunFailure when the block or
/// the mode it names is not there.
double linearize_output(const Linearization& lin, const StudyOutput& o) {
  const StudyLinearize& l = *o.linearize;
  Eigen::VectorXcd eigenvalues = lin.eigenvalues;
  if (!l.of.empty()) {
    std::vector<Eigen::Index> block;
    if (const auto problem = linearize_block(lin, l.of, block))
      throw RunFailure(one_line("linearize", o.name + ": " + *problem));
    eigenvalues = sorted_eigenvalues(lin.A(block, block));
  }
  if (eigenvalues.size() == 0)
    throw RunFailure(one_line("linearize", o.name + ": the linearization has no state"));
  if (l.mode.empty()) return eigenvalues.real().maxCoeff();
  // The modes: a complex pair (its member of positive imaginary part; Eigen's solver for a
  // real matrix gives the two exactly conjugate) or a real eigenvalue each, ranked by
  // decreasing |Im|, then by decreasing Re (a stable sort of the sorted eigenvalues).
  std::vector<std::complex<double>> modes;
  for (Eigen::Index k = 0; k < eigenvalues.size(); ++k)
    if (eigenvalues[k].imag() >= 0.0) modes.push_back(eigenvalues[k]);
  std::stable_sort(modes.begin(), modes.end(), [](const auto& a, const auto& b) {
    return std::abs(a.imag()) > std::abs(b.imag());
  });
  if (static_cast<size_t>(l.rank) > modes.size())
    throw RunFailure(one_line(
        "linearize", o.name + ": rank " + std::to_string(l.rank) + ", but " +
                         (l.of.empty() ? std::string("A") : std::string("the block")) + " has " +
                         std::to_string(modes.size()) + (modes.size() == 1 ? " mode" : " modes")));
  const std::complex<double> lambda = modes[static_cast<size_t>(l.rank - 1)];
  switch (l.value) {
    case ModeValue::real:
      return lambda.real();
    case ModeValue::imag:
      return std::abs(lambda.imag());
    case ModeValue::frequency:
      return std::abs(lambda.imag()) / (2.0 * std::numbers::pi);
    case ModeValue::damping:
      return std::abs(lambda) == 0.0 ? 0.0 : -lambda.real() / std::abs(lambda);
  }
  return 0.0;
}

}  // namespace

StudyRun run_study_run(const Study& study, long run, const std::function<bool()>& stop,
                       const StudyFunction& function) {
  if (!study.function_outputs.empty() && !function)
    throw std::logic_error("run_study_run: the study has function outputs and no function");
  const auto start = std::chrono::steady_clock::now();
  const std::vector<double> p = study.parameters(run);
  StudyRun result;
  result.run = run;
  std::vector<double> outputs;
  try {
    auto [file, settings] = run_model(study, p);
    outputs.resize(study.outputs.size());
    if (study.simulates()) {
      RowReducer reducer(study, file.model, study.keeps_trajectory(run), result.trajectory);
      settings.observer_kinematics = reducer.needs_kinematics();
      if (stop) settings.on_step = [&stop](double) { return !stop(); };
      const SimulationStats stats =
          simulate(file.model, file.q, file.z, settings,
                   [&reducer](double t, const State& state, const VectorX& q, const VectorX& z,
                              Data& data) { reducer.add(t, state, q, z, data); });
      if (stats.status == SimulationStatus::interrupted) {
        result.interrupted = true;
        return result;
      }
      if (!stats.ok())
        throw RunFailure(one_line(to_string(stats.status),
                                  stats.message.empty() ? to_string(stats.status) : stats.message));
      for (size_t i = 0; i < study.outputs.size(); ++i)
        if (!study.outputs[i].linearize) outputs[i] = reducer.output(i);
    }
    if (std::any_of(study.outputs.begin(), study.outputs.end(),
                    [](const StudyOutput& o) { return o.linearize.has_value(); })) {
      std::optional<Linearization> lin;
      try {
        lin = linearize(file.model, file.q, file.z, linearize_inputs(file.model, settings));
      } catch (const std::exception& e) {
        throw RunFailure(one_line("linearize", e.what()));
      }
      for (size_t i = 0; i < study.outputs.size(); ++i)
        if (study.outputs[i].linearize) outputs[i] = linearize_output(*lin, study.outputs[i]);
    }
    if (!study.function_outputs.empty()) {
      std::vector<double> values;
      try {
        values = function(std::move(file), run);
      } catch (const std::exception& e) {
        throw RunFailure(one_line("function", e.what()));
      }
      if (values.size() != study.function_outputs.size())
        throw RunFailure(
            one_line("function", "gave " + std::to_string(values.size()) +
                                     (values.size() == 1 ? " value" : " values") + " for " +
                                     std::to_string(study.function_outputs.size()) + " outputs"));
      outputs.insert(outputs.end(), values.begin(), values.end());
    }
    result.status = "ok";
  } catch (const RunFailure& e) {
    result.status = e.what();
    outputs.clear();
  } catch (const std::exception& e) {
    result.status = one_line("error", e.what());
    outputs.clear();
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // The row: run, values, outputs (empty for a failed run), status, wall_s.
  std::string& line = result.row;
  line = std::to_string(run);
  for (const double v : p) {
    line += ',';
    put_number(line, v);
  }
  for (size_t i = 0; i < study.outputs.size() + study.function_outputs.size(); ++i) {
    line += ',';
    if (i < outputs.size()) put_number(line, outputs[i]);
  }
  line += ',';
  put_field(line, result.status);
  char wall_text[32];
  std::snprintf(wall_text, sizeof wall_text, ",%.6g", wall);
  line += wall_text;
  return result;
}

// ---- The output folder -----------------------------------------------------------------------

namespace {

bool is_directory(const std::string& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

void make_directory(const std::string& path) {
  if (is_directory(path)) return;
  if (::mkdir(path.c_str(), 0777) != 0)
    throw std::runtime_error("cannot create the folder '" + printable(path) +
                             "': " + std::strerror(errno));
}

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

/// Every line of a file (the file is ours: a manifest part or a copy of a study).
/// The lines of a file (ours: a manifest part), without their breaks; `whole` tells whether
/// the last one ended with a break.
std::vector<std::string> read_lines(const std::string& path, bool& whole) {
  const std::string text =
      read_whole_file(open_regular_file(path), std::size_t{1} << 30, "a manifest part");
  whole = text.empty() || text.back() == '\n';
  std::vector<std::string> lines;
  for (size_t start = 0; start < text.size();) {
    const size_t end = std::min(text.find('\n', start), text.size());
    lines.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

/// The first entry of the folder `dir` (by name) other than `ignored`; "" when there is none.
std::string first_entry(const std::string& dir, const std::string& ignored) {
  std::string first;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name != ignored && (first.empty() || name < first)) first = name;
  }
  return first;
}

/// Whether two paths name the same file (by device and inode).
bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {
  }, sb{};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev &&
         sa.st_ino == sb.st_ino;
}

}  // namespace

StudyFolder::StudyFolder(const Study& study, std::string dir)
    : study_(&study), dir_(std::move(dir)) {
  while (dir_.size() > 1 && dir_.back() == '/') dir_.pop_back();
  if (dir_.empty()) throw std::runtime_error("the output folder's name is empty");
  struct stat st {};
  if (::lstat(dir_.c_str(), &st) == 0 && !S_ISDIR(st.st_mode))
    throw std::runtime_error(
        "'" + printable(dir_) +
        "' exists and is not a folder; a study writes into a folder of its own");
  make_directory(dir_);
  const std::string copy = dir_ + "/study.yaml";
  // A folder is this study's when its study.yaml is a copy of the study: the study file
  // itself there (`-o .` beside it) makes it the study's source folder, not its output's.
  if (::lstat(copy.c_str(), &st) == 0 && !same_file(copy, study.path)) {
    std::string text;
    try {
      text = read_whole_file(open_regular_file(copy), std::size_t{16} << 20, "a study file");
    } catch (const std::runtime_error& e) {
      throw std::runtime_error("'" + printable(copy) + "': " + e.what());
    }
    if (text != study.text)
      throw std::runtime_error("'" + printable(dir_) +
                               "' holds the runs of another study (its study.yaml differs from " +
                               printable(study.path) +
                               "); give a new folder, or remove this one to start again");
  } else {
    // Any other folder must be empty: its results.csv and runs/ would be overwritten. (A
    // study.yaml.partial is what a stop while the copy was written leaves.)
    if (const std::string first = first_entry(dir_, "study.yaml.partial"); !first.empty())
      throw std::runtime_error("'" + printable(dir_) + "' is not empty and holds no run of " +
                               printable(study.path) + " ('" + printable(dir_ + "/" + first) +
                               "' is in the way); give a new or empty folder, or the folder of "
                               "an earlier start of this study to resume it");
    write_file_atomically(copy, study.text);
  }
  make_directory(dir_ + "/manifest");
  if (study.keep_every > 0) make_directory(dir_ + "/runs");
  read_manifest();
}

void StudyFolder::add_row(long run, std::string_view row, std::string_view status) {
  const auto r = static_cast<size_t>(run);
  // Grown to the highest run done (runs are done about in order), not to the study's count.
  if (done_.size() <= r) done_.resize(r + 1);
  done_[r] = true;
  index_.emplace_back(run, rows_.size());
  rows_.append(row);
  rows_ += '\n';
  if (status != "ok") ++failures_[status_kind(std::string(status))];
}

void StudyFolder::read_manifest() {
  namespace fs = std::filesystem;
  const std::string header = join_columns(study_->columns());
  const std::string first = kManifestLine + hex(study_->fingerprint);
  const size_t fields = study_->columns().size();
  for (const std::string sub : {"/manifest", "/runs"}) {
    if (!is_directory(dir_ + sub)) continue;
    for (const auto& entry : fs::directory_iterator(dir_ + sub)) {
      const std::string name = entry.path().filename().string();
      // A temporary file of a stopped run: never renamed, so never counted.
      if (name.ends_with(".partial")) {
        fs::remove(entry.path());
        continue;
      }
      if (sub != "/manifest" || !name.starts_with("part_") || !name.ends_with(".csv")) continue;
      const long part = std::atol(name.substr(5).c_str());
      next_part_ = std::max(next_part_, part + 1);
      const std::string path = entry.path().string();
      bool whole = true;
      const std::vector<std::string> lines = read_lines(path, whole);
      const auto bad = [&](size_t line, const std::string& problem) {
        throw std::runtime_error("'" + printable(path) + "' line " + std::to_string(line) + ": " +
                                 problem + "; remove the file to run its runs again");
      };
      if (lines.size() < 2 || lines[0].substr(0, std::strlen(kManifestLine)) != kManifestLine)
        bad(1, "not a manifest part of kanedyn-study/1");
      if (lines[0] != first)
        throw std::runtime_error(
            "'" + printable(dir_) +
            "' holds the runs of another study or model file (the model file changed since "
            "they ran); give a new folder, or remove this one to start again");
      if (lines[1] != header) bad(2, "its header is not this study's");
      for (size_t i = 2; i < lines.size(); ++i) {
        const auto f = split_csv(lines[i]);
        if (!f || f->size() != fields || (i + 1 == lines.size() && !whole))
          bad(i + 1, "not a whole row of " + std::to_string(fields) + " fields");
        long run = -1;
        const std::string& r = f->front();
        const auto [end, error] = std::from_chars(r.data(), r.data() + r.size(), run);
        if (error != std::errc() || end != r.data() + r.size() || run < 0 || run >= study_->runs)
          bad(i + 1, "the run number " + quote(r) + " is not one of this study's");
        // A kept trajectory that has gone makes its run missing again (a run refused before
        // it began has none).
        const std::string& status = (*f)[fields - 2];
        if (status == "ok" && study_->keeps_trajectory(run) && !fs::exists(trajectory_path(run)))
          continue;
        if (!is_done(run)) add_row(run, lines[i], status);
      }
    }
  }
}

long StudyFolder::next_missing(long from) const {
  from = std::max(from, 0L);
  const auto known = static_cast<long>(done_.size());
  while (from < known && done_[static_cast<size_t>(from)]) ++from;
  return std::min(from, total());
}

std::vector<long> StudyFolder::missing() const {
  std::vector<long> m;
  for (long i = next_missing(0); i < total(); i = next_missing(i + 1)) m.push_back(i);
  return m;
}

std::string StudyFolder::trajectory_path(long run) const {
  std::string digits = std::to_string(run);
  const size_t width = std::max<size_t>(6, std::to_string(study_->runs - 1).size());
  if (digits.size() < width) digits.insert(0, width - digits.size(), '0');
  return dir_ + "/runs/run_" + digits + ".csv";
}

void StudyFolder::write_trajectory(StudyRun& run) const {
  if (run.interrupted || run.trajectory.empty() || is_done(run.run)) return;
  if (run.run < 0 || run.run >= study_->runs)
    throw std::out_of_range("run " + std::to_string(run.run));
  if (study_->keeps_trajectory(run.run))
    write_file_atomically(trajectory_path(run.run), run.trajectory);
  std::string().swap(run.trajectory);
}

void StudyFolder::record(const std::vector<StudyRun>& runs) {
  std::string part =
      kManifestLine + hex(study_->fingerprint) + "\n" + join_columns(study_->columns()) + "\n";
  std::vector<const StudyRun*> fresh;
  std::unordered_set<long> taken;
  for (const StudyRun& r : runs) {
    if (r.interrupted || is_done(r.run) || taken.count(r.run)) continue;
    if (r.run < 0 || r.run >= study_->runs) throw std::out_of_range("run " + std::to_string(r.run));
    taken.insert(r.run);
    fresh.push_back(&r);
  }
  if (fresh.empty()) return;
  // The trajectories first: a row in the manifest says its trajectory is whole. When one
  // cannot be written (a full disk), the runs before it are still recorded. (A trajectory
  // written by write_trajectory() is no longer in its run.)
  size_t written = 0;
  std::exception_ptr error;
  for (; written < fresh.size(); ++written) {
    const StudyRun& r = *fresh[written];
    try {
      if (study_->keeps_trajectory(r.run) && !r.trajectory.empty())
        write_file_atomically(trajectory_path(r.run), r.trajectory);
    } catch (...) {
      error = std::current_exception();
      break;
    }
  }
  if (written > 0) {
    for (size_t i = 0; i < written; ++i) {
      part += fresh[i]->row;
      part += '\n';
    }
    char name[32];
    std::snprintf(name, sizeof name, "/part_%06ld.csv", next_part_);
    write_file_atomically(dir_ + "/manifest" + name, part);
    ++next_part_;
    for (size_t i = 0; i < written; ++i) add_row(fresh[i]->run, fresh[i]->row, fresh[i]->status);
  }
  if (error) std::rethrow_exception(error);
}

void StudyFolder::write_results() {
  if (done() != total()) throw std::logic_error("write_results: runs are missing");
  // Written a piece at a time from the rows kept, not from a copy of them all.
  std::sort(index_.begin(), index_.end());
  write_file_atomically(results_path(), [&](const PieceWriter& write) {
    std::string piece = join_columns(study_->columns()) + "\n";
    for (const auto& [run, at] : index_) {
      piece.append(rows_, at, rows_.find('\n', at) + 1 - at);
      if (piece.size() >= (std::size_t{1} << 20)) {
        write(piece);
        piece.clear();
      }
    }
    write(piece);
  });
}

std::map<std::string, long> StudyFolder::failures() const { return failures_; }

// ---- Running on threads ----------------------------------------------------------------------

namespace {

/// Threads that run the runs handed to them (feed()), each taking the next one, and hand the
/// finished runs to the thread that made the pool (collect()) through a queue of bounded size:
/// a thread with a finished run waits while the queue is full, so a writer slower than the runs
/// slows them instead of filling the memory. stop() ends the runs in flight within a step.
class RunPool {
 public:
  /// The queue holds at most `queue_runs` runs, `queue_trajectories` of them with a
  /// trajectory, and `queue_bytes` bytes of rows and trajectories (but always one run).
  struct Limits {
    size_t queue_runs, queue_trajectories, queue_bytes;
  };

  RunPool(const Study& study, const StudyFunction& function, int threads, Limits limits)
      : study_(study), function_(function), limits_(limits) {
    // A thread that cannot start: those started end at once (stopping_), are joined, and the
    // error goes to the caller.
    threads_ = start_threads(
        threads, [this](int) { work(); }, [this] { halt(); });
  }
  ~RunPool() { stop(); }
  RunPool(const RunPool&) = delete;
  RunPool& operator=(const RunPool&) = delete;

  int threads() const { return threads_.size(); }

  /// Adds runs to do; `last`: no more will come (the threads end when these are done).
  void feed(const std::vector<long>& runs, bool last) {
    {
      const std::lock_guard lock(mutex_);
      todo_.insert(todo_.end(), runs.begin(), runs.end());
      fed_all_ = last;
    }
    has_work_.notify_all();
  }
  /// The runs fed and not yet taken by a thread.
  size_t waiting() {
    const std::lock_guard lock(mutex_);
    return todo_.size();
  }

  /// Waits up to `wait` for a finished run, and moves those finished into `out`. Rethrows a
  /// thread's exception.
  void collect(std::chrono::milliseconds wait, std::vector<StudyRun>& out) {
    {
      std::unique_lock lock(mutex_);
      finished_.wait_for(lock, wait, [this] { return !ready_.empty() || error_; });
      if (error_) std::rethrow_exception(error_);
      for (StudyRun& r : ready_) out.push_back(std::move(r));
      ready_.clear();
      ready_bytes_ = ready_trajectories_ = 0;
    }
    has_room_.notify_all();
  }
  /// Tells the threads to stop, without waiting: the runs in flight end within a step,
  /// interrupted, and no other begins.
  void halt() {
    {
      const std::lock_guard lock(mutex_);
      stopping_ = true;
      stop_runs_.store(true, std::memory_order_relaxed);
    }
    has_work_.notify_all();
    has_room_.notify_all();
  }
  /// halt(), then waits for the threads, and moves what they finished into `out`.
  void stop(std::vector<StudyRun>* out = nullptr) {
    halt();
    threads_.join();
    if (out)
      for (StudyRun& r : ready_) out->push_back(std::move(r));
    ready_.clear();
  }

 private:
  /// Whether the queue takes `r` now (under mutex_).
  bool room_for(const StudyRun& r) const {
    if (ready_.empty()) return true;
    return ready_.size() < limits_.queue_runs &&
           ready_bytes_ + r.row.size() + r.trajectory.size() <= limits_.queue_bytes &&
           (r.trajectory.empty() || ready_trajectories_ < limits_.queue_trajectories);
  }

  void work() {
    const std::function<bool()> stop = [this] {
      return stop_runs_.load(std::memory_order_relaxed);
    };
    try {
      for (;;) {
        long run = 0;
        {
          std::unique_lock lock(mutex_);
          has_work_.wait(lock, [this] { return stopping_ || !todo_.empty() || fed_all_; });
          if (stopping_ || todo_.empty()) return;
          run = todo_.front();
          todo_.pop_front();
        }
        StudyRun r = run_study_run(study_, run, stop, function_);
        std::unique_lock lock(mutex_);
        // A stop lets a finished run in whatever the queue holds: it is recorded, and there
        // are at most as many as threads.
        has_room_.wait(lock, [&] { return stopping_ || room_for(r); });
        ready_bytes_ += r.row.size() + r.trajectory.size();
        ready_trajectories_ += r.trajectory.empty() ? 0 : 1;
        ready_.push_back(std::move(r));
        finished_.notify_one();
      }
    } catch (...) {
      const std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
      stopping_ = true;
      stop_runs_.store(true, std::memory_order_relaxed);
      finished_.notify_one();
    }
  }

  const Study& study_;
  const StudyFunction& function_;
  const Limits limits_;
  std::mutex mutex_;
  std::condition_variable has_work_, has_room_, finished_;
  // Guarded by mutex_.
  std::deque<long> todo_;
  bool fed_all_ = false;
  bool stopping_ = false;
  std::vector<StudyRun> ready_;
  size_t ready_bytes_ = 0, ready_trajectories_ = 0;
  std::exception_ptr error_;
  std::atomic<bool> stop_runs_{false};  // stopping_, polled at every step of a run
  ThreadGroup threads_;
};

}  // namespace

SweepResult sweep(const Study& study, StudyFolder& folder, const SweepOptions& options) {
  using Clock = std::chrono::steady_clock;
  const long to_run = folder.total() - folder.done();
  const int threads = static_cast<int>(std::min<long>(
      options.threads > 0 ? options.threads : hardware_threads(), std::max(1L, to_run)));
  SweepResult result;
  std::vector<StudyRun> pending;  // finished runs, their trajectories written: rows to record
  auto last_flush = Clock::now();
  const auto flush = [&] {
    std::vector<StudyRun> batch;
    batch.swap(pending);
    folder.record(batch);
    for (const StudyRun& r : batch) result.ran += r.interrupted ? 0 : 1;
    last_flush = Clock::now();
  };
  auto last_poll = Clock::now();
  // Progress and the stop, about ten times a second; true: stop.
  const auto poll = [&] {
    if (Clock::now() - last_poll < std::chrono::milliseconds(100)) return false;
    last_poll = Clock::now();
    if (options.progress)
      options.progress(folder.done() + static_cast<long>(pending.size()),
                       result.ran + static_cast<long>(pending.size()));
    return options.stop && options.stop();
  };
  if (to_run > 0) {
    // Finished runs wait in the queue, their trajectories with them: a few per thread (the
    // writer takes a few ms for each), and no more than 64 MiB. Rows alone are small: a
    // second's worth of the quickest runs.
    const RunPool::Limits limits{16384, 4 * static_cast<size_t>(threads) + 4, size_t{64} << 20};
    RunPool pool(study, options.function, threads, limits);
    result.threads = pool.threads();
    // The missing runs are handed over a few thousand at a time: nothing is held per run of
    // the study. Runs handed over are past `cursor`, so none is handed twice.
    long cursor = folder.next_missing(0);
    const auto feed = [&] {
      std::vector<long> runs;
      for (; cursor < folder.total() && runs.size() < 4096;
           cursor = folder.next_missing(cursor + 1))
        runs.push_back(cursor);
      pool.feed(runs, cursor >= folder.total());
    };
    feed();
    // A finished run: its trajectory written now, its row kept for the next manifest part.
    const auto take = [&](StudyRun& r) {
      if (r.interrupted) return;
      folder.write_trajectory(r);
      pending.push_back(std::move(r));
    };
    const auto flush_due = [&] {
      return !pending.empty() && std::chrono::duration<double>(Clock::now() - last_flush).count() >=
                                     options.flush_seconds;
    };
    std::vector<StudyRun> got;
    long received = 0;
    bool stopping = false;
    try {
      while (received < to_run && !stopping) {
        if (cursor < folder.total() && pool.waiting() < 1024) feed();
        pool.collect(std::chrono::milliseconds(100), got);
        received += static_cast<long>(got.size());
        for (StudyRun& r : got) {
          take(r);
          if (flush_due()) flush();
          // A stop asked while trajectories are written is seen between two of them; the
          // few finished runs still in hand are written all the same.
          if (!stopping && poll()) {
            stopping = true;
            pool.halt();
          }
        }
        got.clear();
        if (flush_due()) flush();
        if (!stopping && poll()) stopping = true;
      }
      if (stopping) {
        pool.stop(&got);  // the runs in flight end within a step, interrupted
        for (StudyRun& r : got) take(r);
      }
    } catch (...) {
      // A thread's error, a write error, or the caller's callbacks: keep what finished if the
      // disk lets us, and report the error.
      pool.stop();
      try {
        flush();
      } catch (...) {
      }
      throw;
    }
  }
  flush();
  if (options.progress) options.progress(folder.done(), result.ran);
  result.stopped = folder.done() < folder.total();
  if (!result.stopped) folder.write_results();
  return result;
}

}  // namespace kanedyn::io
