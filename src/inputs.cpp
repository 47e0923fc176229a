#include "kanedyn/inputs.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace kanedyn {

std::string to_string(InputHold hold) {
  return hold == InputHold::linear ? "linear" : "zero-order";
}

InputHold parse_input_hold(const std::string& text) {
  if (text == "zero-order" || text == "zoh") return InputHold::zero_order;
  if (text == "linear") return InputHold::linear;
  throw std::invalid_argument("unknown input hold '" + text +
                              "' (expected 'zero-order' or 'linear')");
}

InputTable::InputTable(std::vector<double> times, MatrixX values, InputHold hold)
    : times_(std::move(times)), values_(std::move(values)), hold_(hold) {
  if (times_.empty()) throw std::invalid_argument("input table: no rows");
  if (static_cast<Eigen::Index>(times_.size()) != values_.rows())
    throw std::invalid_argument("input table: " + std::to_string(times_.size()) + " times for " +
                                std::to_string(values_.rows()) + " rows of values");
  if (!values_.allFinite()) throw std::invalid_argument("input table: a value is not finite");
  for (size_t i = 0; i < times_.size(); ++i) {
    if (!std::isfinite(times_[i])) throw std::invalid_argument("input table: a time is not finite");
    if (i > 0 && !(times_[i] > times_[i - 1]))
      throw std::invalid_argument("input table: the times must increase strictly");
  }
}

int InputTable::segment(double t) const {
  // The first time > t, minus one.
  return static_cast<int>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin()) - 1;
}

void InputTable::value(double t, int s, Eigen::Ref<VectorX> u) const {
  const int last = rows() - 1;
  if (s < 0) {
    u = values_.row(0).transpose();
    return;
  }
  if (hold_ == InputHold::zero_order || s >= last) {
    u = values_.row(std::min(s, last)).transpose();
    return;
  }
  const auto i = static_cast<size_t>(s);
  const double a = (t - times_[i]) / (times_[i + 1] - times_[i]);
  u = (1.0 - a) * values_.row(s).transpose() + a * values_.row(s + 1).transpose();
}

}  // namespace kanedyn
