// The expressions of a model file's numbers (docs/model-format.md, "Parameters"): numbers,
// parameter names, + - * /, ^ (power, right-associative), unary minus, parentheses, pi and the
// functions sqrt sin cos tan asin acos atan atan2 exp log abs min max. A small recursive-descent
// evaluator, private to kanedyn::io: the model loader calls it where a number is read.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>

namespace kanedyn::io::detail {

/// A refused expression: the problem, and the byte offset in the expression's text it is
/// about (the start of the offending token).
struct ExpressionError {
  size_t at = 0;
  std::string problem;
};

/// The value of a name: called for each parameter name as the evaluator meets it, with the
/// name's byte offset in the text; it throws ExpressionError (an unknown name, a cycle) or
/// whatever the caller's own errors are.
using NameLookup = std::function<double(std::string_view name, size_t at)>;

/// The value of the expression text[start..] (after its leading '='), evaluated in double
/// precision left to right as written. Throws ExpressionError, its offset and the characters
/// its message names counted in `text` (from 0; "character N" from 1): bad syntax, an unknown
/// function or a wrong number of its arguments, a result that is not finite (at the operation
/// that made it).
double evaluate_expression(std::string_view text, const NameLookup& lookup, size_t start = 0);

/// True for the words an expression reserves (pi and the functions): no parameter is named so.
bool is_reserved_name(std::string_view name);

/// True for a parameter name: a letter or '_', then letters, digits and '_'.
bool is_parameter_name(std::string_view name);

}  // namespace kanedyn::io::detail
