#include "kanedyn/io/trajectory.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/text.hpp"

namespace kanedyn::io {

namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::vector<std::string_view> fields(std::string_view line) {
  std::vector<std::string_view> out;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    out.push_back(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

/// Opens the trajectory and checks that its header is this model's; `fail(line, problem)`
/// builds the error.
template <typename Fail>
std::vector<std::string> open_and_check_header(const Model& model, const JointTree* joints,
                                               const std::string& path, std::ifstream& in,
                                               const Fail& fail) {
  in.open(path, std::ios::binary);
  if (!in) throw fail(0, "cannot open the trajectory");
  std::vector<std::string> columns = trajectory_columns(model, joints);
  std::string line;
  if (!std::getline(in, line)) throw fail(0, "the trajectory is empty");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::vector<std::string_view> header = fields(line);
  for (size_t c = 0; c < std::max(header.size(), columns.size()); ++c) {
    if (c < header.size() && c < columns.size() && header[c] == columns[c]) continue;
    const std::string got = c < header.size() ? "'" + printable(header[c], 60) + "'" : "nothing";
    const std::string want = c < columns.size() ? "'" + columns[c] + "'" : "the end of the line";
    throw fail(1,
               "column " + std::to_string(c + 1) + " is " + got + " where this model's " +
                   "trajectory has " + want + ": the trajectory is not of " +
                   (model.name().empty() ? std::string("this model") : "'" + model.name() + "'"));
  }
  return columns;
}

/// Parses one data row into `row` (its size is the number of columns).
template <typename Fail>
void parse_row(std::string_view line, int line_no, const std::vector<std::string>& columns,
               std::vector<double>& row, const Fail& fail) {
  const std::vector<std::string_view> f = fields(line);
  const size_t width = columns.size();
  if (f.size() != width)
    throw fail(line_no, "the row has " + std::to_string(f.size()) + " fields, the header " +
                            std::to_string(width));
  for (size_t c = 0; c < width; ++c) {
    const char* end = f[c].data() + f[c].size();
    const auto [ptr, ec] = std::from_chars(f[c].data(), end, row[c]);
    if (ec != std::errc() || ptr != end || !std::isfinite(row[c]))
      throw fail(line_no, "column '" + columns[c] + "': '" + printable(f[c], 40) +
                              "' is not a finite number");
  }
}

}  // namespace

TrajectoryRow read_trajectory_row(const Model& model, const std::string& path, double t,
                                  const JointTree* joints) {
  const auto fail = [&](int line, const std::string& problem) -> std::runtime_error {
    return std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
  };
  std::ifstream in;
  const std::vector<std::string> columns = open_and_check_header(model, joints, path, in, fail);
  std::string line;
  // One pass: keep the row nearest to t and the times of its neighbours.
  const size_t width = columns.size();
  std::vector<double> best(width), row(width), prev(width);
  int best_line = 0, line_no = 1;
  double t_first = 0.0, t_last = 0.0, before_best = NAN, after_best = NAN, prev_t = NAN;
  bool any = false, take_next = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    parse_row(line, line_no, columns, row, fail);
    const double tr = row[0];
    if (take_next) {
      after_best = tr;
      take_next = false;
    }
    if (!any) t_first = tr;
    if (!any || std::abs(tr - t) < std::abs(best[0] - t)) {
      best = row;
      best_line = line_no;
      before_best = prev_t;
      after_best = NAN;
      take_next = true;
    }
    any = true;
    t_last = tr;
    prev_t = tr;
  }
  if (!any) throw fail(0, "the trajectory has no rows");
  // Half the spacing to the neighbouring rows (one side at the ends; a lone row: exactly).
  const double gap_before = std::isnan(before_best) ? INFINITY : best[0] - before_best;
  const double gap_after = std::isnan(after_best) ? INFINITY : after_best - best[0];
  double half = 0.5 * std::min(gap_before, gap_after);
  if (!std::isfinite(half)) half = 0.0;
  if (!(std::abs(best[0] - t) <= half))
    throw fail(0, "no row at t = " + number(t) + ": the rows run from t = " + number(t_first) +
                      " to " + number(t_last) + " (the nearest is t = " + number(best[0]) +
                      ", line " + std::to_string(best_line) + ")");
  TrajectoryRow out;
  out.t = best[0];
  out.line = best_line;
  out.state = State(model);
  const int n = model.num_bodies();
  if (joints) {
    out.q = VectorX::Zero(joints->num_coordinates());
    out.z = VectorX::Zero(joints->num_speeds());
  }
  size_t b = 1;  // t, then 16 columns per body, each followed by its joint columns
  for (int k = 0; k < n; ++k) {
    for (int i = 0; i < 4; ++i)
      out.state.euler_parameters(k)[i] = best[b + 3 + static_cast<size_t>(i)];
    for (int i = 0; i < 3; ++i) {
      const size_t ii = static_cast<size_t>(i);
      out.state.translation(k)[i] = best[b + 7 + ii];
      out.state.angular_velocity(k)[i] = best[b + 10 + ii];
      out.state.translation_rate(k)[i] = best[b + 13 + ii];
    }
    if (joints) {
      const JointType type = joints->joint(k).type;
      const int o = joints->coordinate_offset(k), p = joints->speed_offset(k);
      if (type == JointType::free) {  // the notes' own: (eps, s'), (w', s' dot)
        for (int i = 0; i < 7; ++i) out.q[o + i] = best[b + 3 + static_cast<size_t>(i)];
        for (int i = 0; i < 6; ++i) out.z[p + i] = best[b + 10 + static_cast<size_t>(i)];
      } else if (type != JointType::weld) {
        const int nq = coordinate_count(type), nz = speed_count(type);
        for (int i = 0; i < nq; ++i) out.q[o + i] = best[b + 16 + static_cast<size_t>(i)];
        for (int i = 0; i < nz; ++i) out.z[p + i] = best[b + 16 + static_cast<size_t>(nq + i)];
        b += static_cast<size_t>(nq + nz);
      }
    }
    b += 16;
  }
  return out;
}

Trajectory read_trajectory(const Model& model, const std::string& path, const JointTree* joints) {
  const auto fail = [&](int line, const std::string& problem) -> std::runtime_error {
    return std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
  };
  std::ifstream in;
  Trajectory out;
  out.columns = open_and_check_header(model, joints, path, in, fail);
  std::vector<double> row(out.columns.size());
  std::string line;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    parse_row(line, line_no, out.columns, row, fail);
    // Interpolating between rows needs times in order.
    if (!out.values.empty() && row[0] < out.values[out.values.size() - out.columns.size()])
      throw fail(line_no, "t = " + number(row[0]) + " is before the previous row's t = " +
                              number(out.values[out.values.size() - out.columns.size()]));
    out.values.insert(out.values.end(), row.begin(), row.end());
  }
  if (out.values.empty()) throw fail(0, "the trajectory has no rows");
  return out;
}

}  // namespace kanedyn::io
