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
#include <filesystem>
#include <limits>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <thread>

#include "kanedyn/constraints.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/text.hpp"
#include "model_tree.hpp"

namespace kanedyn::io {

namespace {

using detail::Kind;
using detail::Pos;
using detail::Tree;

constexpr const char* kStudyFormat = "kanedyn-study/1";
constexpr const char* kManifestLine = "# kanedyn-study manifest 1, fingerprint ";
/// More runs than a study could do; it bounds the products of grids against overflow.
constexpr long kMaxRuns = 1'000'000'000'000L;

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
      const std::string at = path.empty() ? key : path + "." + key;
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
        if (study.grid_points > kMaxRuns / static_cast<long>(v.values.size()))
          r.fail(value, at, "the grids make more than 10^12 runs");
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

void read_outputs(const StudyReader& r, const YNode& list, Study& study) {
  if (!list.is(Kind::sequence)) r.fail(list, "outputs", "expected a list, got " + describe(list));
  const std::vector<std::string> columns = trajectory_columns(study.model.base().model);
  const std::vector<std::string> statistics{"final", "max", "min", "mean", "rms"};
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = "outputs[" + std::to_string(i) + "]";
    const auto m = r.mapping(list[i], path, statistics);
    if (m.size() != 1)
      r.fail(list[i], path, "expected one of final, max, min, mean, rms with a column name");
    const auto& [kind, value] = *m.begin();
    StudyOutput o;
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
    r.fail(root, "", "a study file must be a mapping (key: value lines), got " + describe(root));
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
    // read and refused says where, in its own message.
    if (e.line() > 0 || !e.key_path().empty()) throw;
    r.fail(model_it->second, "model",
           "the model file " + quote(study.model_path) + ": " + e.problem());
  }

  if (const auto it = top.find("runs"); it != top.end())
    study.runs_per_point = static_cast<long>(r.integer(it->second, "runs", 1, kMaxRuns));
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
  if (study.grid_points > kMaxRuns / study.runs_per_point)
    r.fail(root, "runs", "the grids times `runs` make more than 10^12 runs");
  study.runs = study.grid_points * study.runs_per_point;
  if (const auto it = top.find("simulate"); it != top.end())
    read_simulate(r, it->second, study.simulate);
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
  c.emplace_back("status");
  c.emplace_back("wall_s");
  return c;
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
        p[j] = v.a + (v.b - v.a) * u(j, 0);
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
    if (jointed && type != JointType::free && type != JointType::weld) {
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

StudyRun run_study_run(const Study& study, long run, const std::function<bool()>& stop) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<double> p = study.parameters(run);
  StudyRun result;
  result.run = run;
  std::vector<double> outputs;
  try {
    auto [file, settings] = run_model(study, p);
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
    result.status = stats.ok()
                        ? "ok"
                        : one_line(to_string(stats.status),
                                   stats.message.empty() ? to_string(stats.status) : stats.message);
    if (stats.ok())
      for (size_t i = 0; i < study.outputs.size(); ++i) outputs.push_back(reducer.output(i));
  } catch (const RunFailure& e) {
    result.status = e.what();
  } catch (const std::exception& e) {
    result.status = one_line("error", e.what());
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
  for (size_t i = 0; i < study.outputs.size(); ++i) {
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
  if (::lstat(copy.c_str(), &st) == 0) {
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
    write_file_atomically(copy, study.text);
  }
  make_directory(dir_ + "/manifest");
  if (study.keep_every > 0) make_directory(dir_ + "/runs");
  read_manifest();
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
        if (rows_.emplace(run, lines[i]).second && status != "ok")
          kinds_[run] = status_kind(status);
      }
    }
  }
}

std::vector<long> StudyFolder::missing() const {
  std::vector<long> m;
  for (long i = 0; i < study_->runs; ++i)
    if (!rows_.count(i)) m.push_back(i);
  return m;
}

std::string StudyFolder::trajectory_path(long run) const {
  std::string digits = std::to_string(run);
  const size_t width = std::max<size_t>(6, std::to_string(study_->runs - 1).size());
  if (digits.size() < width) digits.insert(0, width - digits.size(), '0');
  return dir_ + "/runs/run_" + digits + ".csv";
}

void StudyFolder::record(const std::vector<StudyRun>& runs) {
  std::string part =
      kManifestLine + hex(study_->fingerprint) + "\n" + join_columns(study_->columns()) + "\n";
  std::vector<const StudyRun*> fresh;
  for (const StudyRun& r : runs) {
    if (r.interrupted || rows_.count(r.run) ||
        std::any_of(fresh.begin(), fresh.end(), [&](const StudyRun* f) { return f->run == r.run; }))
      continue;
    if (r.run < 0 || r.run >= study_->runs) throw std::out_of_range("run " + std::to_string(r.run));
    fresh.push_back(&r);
  }
  if (fresh.empty()) return;
  // The trajectories first: a row in the manifest says its trajectory is whole. When one
  // cannot be written (a full disk), the runs before it are still recorded.
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
    for (size_t i = 0; i < written; ++i) {
      rows_.emplace(fresh[i]->run, fresh[i]->row);
      if (fresh[i]->status != "ok") kinds_[fresh[i]->run] = status_kind(fresh[i]->status);
    }
  }
  if (error) std::rethrow_exception(error);
}

void StudyFolder::write_results() const {
  if (done() != total()) throw std::logic_error("write_results: runs are missing");
  std::string text = join_columns(study_->columns()) + "\n";
  for (const auto& [run, row] : rows_) {
    text += row;
    text += '\n';
  }
  write_file_atomically(results_path(), text);
}

std::map<std::string, long> StudyFolder::failures() const {
  std::map<std::string, long> by_kind;
  for (const auto& [run, kind] : kinds_) ++by_kind[kind];
  return by_kind;
}

// ---- Running on threads ----------------------------------------------------------------------

namespace {

/// Threads that run a list of runs, each taking the next one, and hand the results to the
/// thread that made the pool (collect()). stop() ends the runs in flight within a step.
class RunPool {
 public:
  RunPool(const Study& study, std::vector<long> todo, int threads)
      : study_(study), todo_(std::move(todo)) {
    const int n = std::max(1, std::min<int>(threads, static_cast<int>(todo_.size())));
    for (int i = 0; i < n && !todo_.empty(); ++i) pool_.emplace_back([this] { work(); });
  }
  ~RunPool() { stop(); }
  RunPool(const RunPool&) = delete;
  RunPool& operator=(const RunPool&) = delete;

  /// Waits up to `wait` for results and moves those finished into `out`; true once every run
  /// has come back (or the pool has stopped). Rethrows a worker's exception.
  bool collect(std::chrono::milliseconds wait, std::vector<StudyRun>& out) {
    std::unique_lock lock(mutex_);
    finished_.wait_for(lock, wait);
    if (error_) std::rethrow_exception(error_);
    received_ += ready_.size();
    for (StudyRun& r : ready_) out.push_back(std::move(r));
    ready_.clear();
    return received_ == todo_.size();
  }
  /// Stops the runs, waits for the threads, and moves what they finished into `out`.
  void stop(std::vector<StudyRun>* out = nullptr) {
    stopping_ = true;
    for (std::thread& t : pool_) t.join();
    pool_.clear();
    if (out)
      for (StudyRun& r : ready_) out->push_back(std::move(r));
    ready_.clear();
  }

 private:
  void work() {
    const std::function<bool()> stop = [this] { return stopping_.load(std::memory_order_relaxed); };
    try {
      while (!stopping_) {
        const size_t i = next_.fetch_add(1);
        if (i >= todo_.size()) return;
        StudyRun r = run_study_run(study_, todo_[i], stop);
        const std::lock_guard lock(mutex_);
        ready_.push_back(std::move(r));
        finished_.notify_one();
      }
    } catch (...) {
      const std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
      stopping_ = true;
      finished_.notify_one();
    }
  }

  const Study& study_;
  const std::vector<long> todo_;
  std::atomic<size_t> next_{0};
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;
  std::condition_variable finished_;
  std::vector<StudyRun> ready_;  // guarded by mutex_
  size_t received_ = 0;
  std::exception_ptr error_;  // guarded by mutex_
  std::vector<std::thread> pool_;
};

}  // namespace

SweepResult sweep(const Study& study, StudyFolder& folder, const SweepOptions& options) {
  using Clock = std::chrono::steady_clock;
  const int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  SweepResult result;
  std::vector<StudyRun> pending;
  auto last_flush = Clock::now();
  const auto flush = [&] {
    std::vector<StudyRun> batch;
    batch.swap(pending);
    folder.record(batch);
    for (const StudyRun& r : batch) result.ran += r.interrupted ? 0 : 1;
    last_flush = Clock::now();
  };
  RunPool pool(study, folder.missing(), threads);
  try {
    bool all_back = folder.done() == folder.total();
    while (!all_back) {
      all_back = pool.collect(std::chrono::milliseconds(100), pending);
      if (options.stop && options.stop()) {
        pool.stop(&pending);  // the runs in flight end within a step, interrupted
        break;
      }
      if (std::chrono::duration<double>(Clock::now() - last_flush).count() >= options.flush_seconds)
        flush();
      if (options.progress)
        options.progress(folder.done() + static_cast<long>(pending.size()),
                         result.ran + static_cast<long>(pending.size()));
    }
  } catch (...) {
    // A worker's error, a write error, or the caller's callbacks: keep what finished if the
    // disk lets us, and report the error.
    pool.stop(&pending);
    try {
      flush();
    } catch (...) {
    }
    throw;
  }
  flush();
  if (options.progress) options.progress(folder.done(), result.ran);
  result.stopped = folder.done() < folder.total();
  if (!result.stopped) folder.write_results();
  return result;
}

}  // namespace kanedyn::io
