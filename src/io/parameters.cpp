// The expressions of model files (parameters.hpp): a recursive-descent parser that evaluates
// as it reads, one function per level of the grammar
//
//   sum     := product (('+' | '-') product)*
//   product := unary (('*' | '/') unary)*
//   unary   := '-' unary | power
//   power   := primary ('^' unary)?          (right-associative: 2^3^2 = 2^9; -2^2 = -4)
//   primary := number | pi | name | function '(' sum (',' sum)* ')' | '(' sum ')'
//
// so that each operation is done in double precision in the order the text gives it.
#include "parameters.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

namespace kanedyn::io::detail {

namespace {

struct Function {
  std::string_view name;
  size_t min_args, max_args;  // max_args 0: any number from min_args on
  double (*apply)(const std::vector<double>&);
};

// min and max take two or more arguments; the others exactly their mathematical count.
constexpr Function kFunctions[] = {
    {"sqrt", 1, 1, [](const std::vector<double>& a) { return std::sqrt(a[0]); }},
    {"sin", 1, 1, [](const std::vector<double>& a) { return std::sin(a[0]); }},
    {"cos", 1, 1, [](const std::vector<double>& a) { return std::cos(a[0]); }},
    {"tan", 1, 1, [](const std::vector<double>& a) { return std::tan(a[0]); }},
    {"asin", 1, 1, [](const std::vector<double>& a) { return std::asin(a[0]); }},
    {"acos", 1, 1, [](const std::vector<double>& a) { return std::acos(a[0]); }},
    {"atan", 1, 1, [](const std::vector<double>& a) { return std::atan(a[0]); }},
    {"atan2", 2, 2, [](const std::vector<double>& a) { return std::atan2(a[0], a[1]); }},
    {"exp", 1, 1, [](const std::vector<double>& a) { return std::exp(a[0]); }},
    {"log", 1, 1, [](const std::vector<double>& a) { return std::log(a[0]); }},
    {"abs", 1, 1, [](const std::vector<double>& a) { return std::abs(a[0]); }},
    {"min", 2, 0,
     [](const std::vector<double>& a) {
       double v = a[0];
       for (const double x : a) v = x < v ? x : v;  // left to right, the first of equals
       return v;
     }},
    {"max", 2, 0,
     [](const std::vector<double>& a) {
       double v = a[0];
       for (const double x : a) v = x > v ? x : v;
       return v;
     }},
};

const Function* find_function(std::string_view name) {
  for (const Function& f : kFunctions)
    if (f.name == name) return &f;
  return nullptr;
}

bool is_letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// A character of the text for a message: quoted, or its byte in hex when it is no printable
/// ASCII.
std::string shown(char c) {
  if (c >= 0x20 && c < 0x7f) return std::string("'") + c + "'";
  char buf[16];
  std::snprintf(buf, sizeof buf, "the byte \\x%02x",
                static_cast<unsigned>(static_cast<unsigned char>(c)));
  return buf;
}

std::string character(size_t at) { return "character " + std::to_string(at + 1); }

class Parser {
 public:
  Parser(std::string_view text, const NameLookup& lookup, size_t start)
      : s_(text), lookup_(lookup), i_(std::min(start, text.size())) {}

  double parse() {
    skip();
    if (i_ == s_.size()) fail(i_, "an empty expression; give a number, a parameter or a formula");
    const double v = sum();
    if (i_ < s_.size()) {
      if (s_[i_] == ')') fail(i_, "')' without its '('");
      fail(i_,
           "unexpected " + shown(s_[i_]) + " after a complete expression (an operator missing?)");
    }
    return v;
  }

 private:
  [[noreturn]] void fail(size_t at, const std::string& problem) const {
    throw ExpressionError{at, problem};
  }

  void skip() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t')) ++i_;
  }

  bool take(char c) {
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      skip();
      return true;
    }
    return false;
  }

  /// `v` if finite, else the failure of the operation at `at`.
  double finite(double v, size_t at, const std::string& what) const {
    if (!std::isfinite(v))
      fail(at, "the result of " + what + " is not finite (" + (std::isnan(v) ? "nan" : "inf") +
                   "); numbers must be finite");
    return v;
  }

  double sum() {
    double v = product();
    for (;;) {
      const size_t at = i_;
      if (take('+')) {
        v = finite(v + product(), at, "'+' at " + character(at));
      } else if (take('-')) {
        v = finite(v - product(), at, "'-' at " + character(at));
      } else {
        return v;
      }
    }
  }

  double product() {
    double v = unary();
    for (;;) {
      const size_t at = i_;
      if (take('*')) {
        v = finite(v * unary(), at, "'*' at " + character(at));
      } else if (take('/')) {
        const double d = unary();
        if (d == 0.0) fail(at, "division by zero ('/' at " + character(at) + ")");
        v = finite(v / d, at, "'/' at " + character(at));
      } else {
        return v;
      }
    }
  }

  // Every nesting (parentheses, arguments, signs, powers) passes here: its depth is bounded,
  // so that no text runs the parser's stack out.
  double unary() {
    if (++depth_ > kMaxDepth)
      fail(i_, "nested deeper than " + std::to_string(kMaxDepth) + " levels");
    const double v = take('-') ? -unary() : power();
    --depth_;
    return v;
  }

  double power() {
    const double base = primary();
    const size_t at = i_;
    if (!take('^')) return base;
    const double exponent = unary();
    return finite(std::pow(base, exponent), at, "'^' at " + character(at));
  }

  double primary() {
    if (i_ == s_.size()) fail(i_, "the expression ends where a number, a name or '(' was expected");
    const char c = s_[i_];
    const size_t at = i_;
    if (take('(')) {
      const double v = sum();
      if (!take(')'))
        fail(i_, i_ == s_.size() ? "the '(' at " + character(at) + " is not closed"
                                 : "expected ')' to close the '(' at " + character(at) + ", got " +
                                       shown(s_[i_]));
      return v;
    }
    if (is_digit(c) || c == '.') return number();
    if (is_letter(c)) return name();
    fail(at, "unexpected " + shown(c) + " where a number, a name or '(' was expected");
  }

  double number() {
    const size_t at = i_;
    while (i_ < s_.size() && (is_digit(s_[i_]) || s_[i_] == '.')) ++i_;
    if (i_ < s_.size() && (s_[i_] == 'e' || s_[i_] == 'E')) {
      size_t j = i_ + 1;
      if (j < s_.size() && (s_[j] == '+' || s_[j] == '-')) ++j;
      if (j < s_.size() && is_digit(s_[j])) {
        i_ = j;
        while (i_ < s_.size() && is_digit(s_[i_])) ++i_;
      }
    }
    const std::string_view word = s_.substr(at, i_ - at);
    double v = 0.0;
    const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), v);
    if (error == std::errc::result_out_of_range)
      fail(at, "'" + std::string(word) + "' is out of the range of a double");
    if (error != std::errc() || end != word.data() + word.size())
      fail(at, "'" + std::string(word) + "' is not a number");
    if (i_ < s_.size() && is_letter(s_[i_]))
      fail(i_, "unexpected " + shown(s_[i_]) + " after the number '" + std::string(word) +
                   "' (a '*' missing?)");
    skip();
    return v;
  }

  double name() {
    const size_t at = i_;
    while (i_ < s_.size() && (is_letter(s_[i_]) || is_digit(s_[i_]))) ++i_;
    const std::string_view word = s_.substr(at, i_ - at);
    skip();
    const bool call = i_ < s_.size() && s_[i_] == '(';
    if (const Function* f = find_function(word)) {
      if (!call)
        fail(at, "'" + std::string(word) + "' is a function: write " + std::string(word) + "(...)");
      return apply(*f, at);
    }
    if (word == "pi") {
      if (call) fail(i_, "'pi' is a number, not a function");
      return std::numbers::pi;
    }
    if (call)
      fail(at, "unknown function '" + std::string(word) +
                   "'; functions: sqrt sin cos tan asin acos atan atan2 exp log abs min max");
    return lookup_(word, at);
  }

  double apply(const Function& f, size_t at) {
    take('(');
    std::vector<double> args;
    if (i_ < s_.size() && s_[i_] != ')') {
      args.push_back(sum());
      while (take(',')) args.push_back(sum());
    }
    if (!take(')'))
      fail(i_, i_ == s_.size() ? "the '(' of " + std::string(f.name) + " is not closed"
                               : "expected ',' or ')' in the arguments of " + std::string(f.name) +
                                     ", got " + shown(s_[i_]));
    const std::string name(f.name);
    if (args.size() < f.min_args || (f.max_args > 0 && args.size() > f.max_args)) {
      const std::string wanted = f.max_args == 0
                                     ? "at least " + std::to_string(f.min_args) + " arguments"
                                 : f.min_args == 1 ? std::string("1 argument")
                                                   : std::to_string(f.min_args) + " arguments";
      fail(at, name + " takes " + wanted + ", got " + std::to_string(args.size()));
    }
    return finite(f.apply(args), at, name + "(...) at " + character(at));
  }

  std::string_view s_;
  const NameLookup& lookup_;
  size_t i_;
  static constexpr int kMaxDepth = 200;
  int depth_ = 0;
};

}  // namespace

double evaluate_expression(std::string_view text, const NameLookup& lookup, size_t start) {
  return Parser(text, lookup, start).parse();
}

bool is_reserved_name(std::string_view name) {
  return name == "pi" || find_function(name) != nullptr;
}

bool is_parameter_name(std::string_view name) {
  return !name.empty() && is_letter(name[0]) &&
         std::all_of(name.begin(), name.end(), [](char c) { return is_letter(c) || is_digit(c); });
}

}  // namespace kanedyn::io::detail
