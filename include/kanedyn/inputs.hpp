// Inputs over time (docs/model-format.md, "Inputs"): a table of rows (t_i, u_i) held between
// rows (zero-order hold) or interpolated (linear), as `simulate --inputs FILE.csv` reads it.
#pragma once

#include <string>
#include <vector>

#include "kanedyn/types.hpp"

namespace kanedyn {

enum class InputHold {
  zero_order,  ///< u_i from t_i until the next row's time
  linear,      ///< straight between rows
};

/// "zero-order" / "linear"; parse_input_hold throws std::invalid_argument for anything else.
std::string to_string(InputHold hold);
InputHold parse_input_hold(const std::string& text);

/// Rows (t_i, u_i), t strictly increasing, each u_i with one value per input of the model.
/// Before the first row the first row's values hold, after the last the last's. The value
/// jumps (zero-order) or its slope does (linear) at every row's time: an integrator restarts
/// there (simulate() never steps across one).
class InputTable {
 public:
  /// values: one row per time, one column per input. Throws std::invalid_argument when the
  /// sizes disagree, a number is not finite, or the times do not increase strictly.
  InputTable(std::vector<double> times, MatrixX values, InputHold hold = InputHold::zero_order);

  int rows() const { return static_cast<int>(times_.size()); }
  int num_inputs() const { return static_cast<int>(values_.cols()); }
  InputHold hold() const { return hold_; }
  const std::vector<double>& times() const { return times_; }
  const MatrixX& values() const { return values_; }

  /// The segment of t: the last row i with t_i <= t, or -1 before the first row.
  int segment(double t) const;
  /// The value at t computed as on segment s (s = segment(t) for the value in force at t; an
  /// integrator inside segment s keeps s up to its end, where the next segment's value may
  /// differ). u must have num_inputs() entries. No allocation.
  void value(double t, int s, Eigen::Ref<VectorX> u) const;
  /// The value in force at t: value(t, segment(t), u).
  void value(double t, Eigen::Ref<VectorX> u) const { value(t, segment(t), u); }

 private:
  std::vector<double> times_;
  MatrixX values_;
  InputHold hold_;
};

}  // namespace kanedyn
