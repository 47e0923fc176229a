#include "kanedyn/io/trajectory.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"

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

/// The longest line this model's trajectory can hold: the header, or a row of numbers in
/// their longest shortest-round-trip form (24 characters) with a comma each. A file without line
/// breaks is refused after this many bytes instead of being read whole.
size_t max_line_length(const std::vector<std::string>& columns) {
  size_t header = 0;
  for (const std::string& c : columns) header += c.size() + 1;
  return std::max(header, 32 * columns.size()) + 1024;
}

/// Opens the trajectory (a regular file only: a FIFO or a device is refused without waiting
/// on it) and checks that its header is this model's; `fail(line, problem)` builds the error.
template <typename Fail>
std::vector<std::string> open_and_check_header(const Model& model, const std::string& path,
                                               std::optional<LineReader>& in, const Fail& fail) {
  std::vector<std::string> columns = trajectory_columns(model);
  std::string line;
  bool any = false;
  try {
    in.emplace(path);
    any = in->next(line, max_line_length(columns));
  } catch (const std::runtime_error& e) {
    throw fail(0, std::string(e.what()) + " (the trajectory)");
  }
  if (!any) throw fail(0, "the trajectory is empty");
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

/// The next line of the file, or false at its end; its errors (a line too long, a read
/// error) name the line.
template <typename Fail>
bool next_line(LineReader& in, const std::vector<std::string>& columns, std::string& line,
               int line_no, const Fail& fail) {
  try {
    return in.next(line, max_line_length(columns));
  } catch (const std::runtime_error& e) {
    throw fail(line_no, std::string(e.what()) + ", longer than any row of this model's trajectory");
  }
}

/// A row is a state: every body's Euler parameters (e1..e4) and every spherical joint's q
/// (j1..j4) have norm 1 within the model file's tolerance, 1e-6 (docs/model-format.md).
template <typename Fail>
void check_row_state(const Model& model, const std::vector<std::string>& columns,
                     const std::vector<double>& row, int line_no, const Fail& fail) {
  constexpr double kTolerance = 1e-6;
  const auto check = [&](size_t first, const char* what) {
    double sum = 0.0;
    for (size_t i = 0; i < 4; ++i) sum += row[first + i] * row[first + i];
    const double norm = std::sqrt(sum);
    if (!(std::abs(norm - 1.0) <= kTolerance))
      throw fail(line_no, "columns '" + columns[first] + "' to '" + columns[first + 3] +
                              "' are not " + what + ": their norm is " + number(norm) +
                              ", not 1 within 1e-6");
  };
  size_t b = 1;
  for (int k = 0; k < model.num_bodies(); ++k) {
    check(b + 3, "Euler parameters");
    b += 16;
    const JointType type = model.joint(k).type;
    if (joint_type_info(type).coordinates == 0 || joint_type_info(type).absolute) continue;
    if (relative_euler_joint(type)) check(b, "a spherical joint's Euler parameters");
    b += static_cast<size_t>(coordinate_count(type) + speed_count(type));
  }
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
    const std::string problem = read_decimal(f[c], row[c]);
    if (!problem.empty())
      throw fail(line_no, "column '" + printable(columns[c], 60) + "': '" + printable(f[c], 40) +
                              "' " +
                              (problem.starts_with("is not") ? "is not a finite number" : problem));
  }
}

}  // namespace

TrajectoryRow read_trajectory_row(const Model& model, const std::string& path, double t) {
  const auto fail = [&](int line, const std::string& problem) -> std::runtime_error {
    return std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
  };
  std::optional<LineReader> in;
  const std::vector<std::string> columns = open_and_check_header(model, path, in, fail);
  std::string line;
  // One pass: keep the row nearest to t and the times of its neighbours.
  const size_t width = columns.size();
  std::vector<double> best(width), row(width), prev(width);
  int best_line = 0, line_no = 1;
  double t_first = 0.0, t_last = 0.0, before_best = NAN, after_best = NAN, prev_t = NAN;
  bool any = false, take_next = false;
  while (next_line(*in, columns, line, line_no + 1, fail)) {
    ++line_no;
    if (line.empty()) continue;
    parse_row(line, line_no, columns, row, fail);
    check_row_state(model, columns, row, line_no, fail);
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
  out.q = VectorX::Zero(model.num_coordinates());
  out.z = VectorX::Zero(model.num_speeds());
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
    {
      const JointType type = model.joint(k).type;
      const int o = model.coordinate_offset(k), p = model.speed_offset(k);
      if (type == JointType::free) {  // the notes' own: (eps, s'), (w', s' dot)
        for (int i = 0; i < 7; ++i) out.q[o + i] = best[b + 3 + static_cast<size_t>(i)];
        for (int i = 0; i < 6; ++i) out.z[p + i] = best[b + 10 + static_cast<size_t>(i)];
      } else if (coordinate_count(type) > 0) {
        const int nq = coordinate_count(type), nz = speed_count(type);
        for (int i = 0; i < nq; ++i) out.q[o + i] = best[b + 16 + static_cast<size_t>(i)];
        for (int i = 0; i < nz; ++i) out.z[p + i] = best[b + 16 + static_cast<size_t>(nq + i)];
        b += static_cast<size_t>(nq + nz);
      }
    }
    b += 16;
  }
  // energy, then the inputs.
  out.inputs = VectorX::Zero(model.num_inputs());
  for (int i = 0; i < model.num_inputs(); ++i) out.inputs[i] = best[b + 1 + static_cast<size_t>(i)];
  return out;
}

Trajectory read_trajectory(const Model& model, const std::string& path) {
  const auto fail = [&](int line, const std::string& problem) -> std::runtime_error {
    return std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
  };
  std::optional<LineReader> in;
  Trajectory out;
  out.columns = open_and_check_header(model, path, in, fail);
  std::vector<double> row(out.columns.size());
  std::string line;
  int line_no = 1;
  while (next_line(*in, out.columns, line, line_no + 1, fail)) {
    ++line_no;
    if (line.empty()) continue;
    parse_row(line, line_no, out.columns, row, fail);
    check_row_state(model, out.columns, row, line_no, fail);
    // Interpolating between rows needs times in order.
    if (!out.values.empty() && row[0] < out.values[out.values.size() - out.columns.size()])
      throw fail(line_no, "t = " + number(row[0]) + " is before the previous row's t = " +
                              number(out.values[out.values.size() - out.columns.size()]));
    out.values.insert(out.values.end(), row.begin(), row.end());
  }
  if (out.values.empty()) throw fail(0, "the trajectory has no rows");
  return out;
}

namespace {

// The slope at t[at] of the polynomial through the points first..first+count-1 (Lagrange).
double polynomial_slope(const std::vector<double>& t, const VectorX& y, size_t first, size_t count,
                        size_t at) {
  double slope = 0.0;
  for (size_t i = first; i < first + count; ++i) {
    // d/dt of l_i at t[at]: l_i(t) = prod_{j != i} (t - t_j) / (t_i - t_j).
    double d = 0.0;
    for (size_t m = first; m < first + count; ++m) {
      if (m == i) continue;
      double term = 1.0 / (t[i] - t[m]);
      for (size_t j = first; j < first + count; ++j)
        if (j != i && j != m) term *= (t[at] - t[j]) / (t[i] - t[j]);
      d += term;
    }
    slope += y[static_cast<Eigen::Index>(i)] * d;
  }
  return slope;
}

}  // namespace

VectorX spline_slopes(const std::vector<double>& t, const VectorX& y) {
  const size_t n = t.size();
  VectorX m = VectorX::Zero(static_cast<Eigen::Index>(n));
  if (n < 4) {  // the polynomial through every point
    for (size_t i = 0; i < n; ++i)
      m[static_cast<Eigen::Index>(i)] = polynomial_slope(t, y, 0, n, i);
    return m;
  }
  // Clamped: the end slopes from the cubics through the end rows, then the interior slopes of
  // the C2 spline, h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1} = 3 (h_i d_{i-1} +
  // h_{i-1} d_i), d_i = (y_{i+1} - y_i) / h_i: a diagonally dominant tridiagonal system (Thomas).
  m[0] = polynomial_slope(t, y, 0, 4, 0);
  m[static_cast<Eigen::Index>(n - 1)] = polynomial_slope(t, y, n - 4, 4, n - 1);
  const auto h = [&](size_t i) { return t[i + 1] - t[i]; };
  const auto d = [&](size_t i) {
    return (y[static_cast<Eigen::Index>(i + 1)] - y[static_cast<Eigen::Index>(i)]) / h(i);
  };
  const size_t k = n - 2;  // unknowns m_1 .. m_{n-2}
  std::vector<double> diag(k), upper(k), rhs(k);
  for (size_t r = 0; r < k; ++r) {
    const size_t i = r + 1;
    diag[r] = 2.0 * (h(i - 1) + h(i));
    upper[r] = h(i - 1);
    rhs[r] = 3.0 * (h(i) * d(i - 1) + h(i - 1) * d(i));
  }
  rhs[0] -= h(1) * m[0];
  rhs[k - 1] -= h(n - 3) * m[static_cast<Eigen::Index>(n - 1)];
  for (size_t r = 1; r < k; ++r) {  // eliminate the lower band: row r's lower entry is h(r + 1)
    const double f = h(r + 1) / diag[r - 1];
    diag[r] -= f * upper[r - 1];
    rhs[r] -= f * rhs[r - 1];
  }
  for (size_t r = k; r-- > 0;) {
    const double next = r + 1 < k ? m[static_cast<Eigen::Index>(r + 2)] : 0.0;
    m[static_cast<Eigen::Index>(r + 1)] = (rhs[r] - (r + 1 < k ? upper[r] * next : 0.0)) / diag[r];
  }
  return m;
}

TrajectoryMotion trajectory_motion(const Model& model, const Trajectory& trajectory,
                                   const std::string& path) {
  const size_t rows = trajectory.rows();
  if (rows < 2)
    throw std::runtime_error(path +
                             ": the accelerations need at least 2 rows; the trajectory has " +
                             std::to_string(rows));
  TrajectoryMotion out;
  const auto nq = model.num_coordinates(), nz = model.num_speeds(), nu = model.num_inputs();
  const auto cols = static_cast<Eigen::Index>(rows);
  out.q = MatrixX::Zero(nq, cols);
  out.z = MatrixX::Zero(nz, cols);
  out.zdot = MatrixX::Zero(nz, cols);
  out.u = MatrixX::Zero(nu, cols);
  for (size_t r = 0; r < rows; ++r) {
    out.t.push_back(trajectory.at(r, 0));
    if (r > 0 && !(out.t[r] > out.t[r - 1]))
      throw std::runtime_error(path + ":" + std::to_string(r + 2) + ": t = " + number(out.t[r]) +
                               " repeats the previous row's; the accelerations need increasing "
                               "times");
    size_t b = 1;  // t, then 16 columns per body, each followed by its joint columns
    const auto c = static_cast<Eigen::Index>(r);
    for (int k = 0; k < model.num_bodies(); ++k) {
      const JointType type = model.joint(k).type;
      const int o = model.coordinate_offset(k), p = model.speed_offset(k);
      if (type == JointType::free) {  // the notes' own: (eps, s'), (w', s' dot)
        for (int i = 0; i < 7; ++i)
          out.q(o + i, c) = trajectory.at(r, b + 3 + static_cast<size_t>(i));
        for (int i = 0; i < 6; ++i)
          out.z(p + i, c) = trajectory.at(r, b + 10 + static_cast<size_t>(i));
      } else if (coordinate_count(type) > 0) {
        const int jq = coordinate_count(type), jz = speed_count(type);
        for (int i = 0; i < jq; ++i)
          out.q(o + i, c) = trajectory.at(r, b + 16 + static_cast<size_t>(i));
        for (int i = 0; i < jz; ++i)
          out.z(p + i, c) = trajectory.at(r, b + 16 + static_cast<size_t>(jq + i));
        b += static_cast<size_t>(jq + jz);
      }
      b += 16;
    }
    for (int i = 0; i < nu; ++i) out.u(i, c) = trajectory.at(r, b + 1 + static_cast<size_t>(i));
    out.lines.push_back(static_cast<int>(r) + 2);
  }
  for (int i = 0; i < nz; ++i)
    out.zdot.row(i) = spline_slopes(out.t, out.z.row(i).transpose()).transpose();
  return out;
}

namespace {

/// Where a column of a plain table of joint coordinates goes.
struct TableColumn {
  enum Kind { time, coordinate, rate, input } kind = time;
  int body = -1;  ///< coordinate, rate: the body's index
  int index = 0;  ///< coordinate, rate: 0-based within the body's q or z; input: the input's
};

/// The columns a plain table of this model may have: t, every jointed body's j and jd columns,
/// its inputs'.
std::vector<std::pair<std::string, TableColumn>> joint_table_columns(const Model& model) {
  std::vector<std::pair<std::string, TableColumn>> out{{"t", {}}};
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    if (joint_type_info(type).coordinates == 0 || joint_type_info(type).absolute) continue;
    const std::string& name = model.body(k).name;
    for (int i = 0; i < coordinate_count(type); ++i)
      out.push_back({name + ".j" + std::to_string(i + 1), {TableColumn::coordinate, k, i}});
    for (int i = 0; i < speed_count(type); ++i)
      out.push_back({name + ".jd" + std::to_string(i + 1), {TableColumn::rate, k, i}});
  }
  for (int i = 0; i < model.num_inputs(); ++i)
    out.push_back(
        {"input." + model.inputs()[static_cast<size_t>(i)].name, {TableColumn::input, -1, i}});
  return out;
}

/// The 4 x 3 map from a spherical joint's w_rel (body-K components) to the rates of its Euler
/// parameters at q, read off the kinematic equation joint_coordinate_rates (the form of Eq. 39),
/// one speed at a time: it is linear in z.
Eigen::Matrix<double, 4, 3> spherical_rate_map(const Model& model, int k, const VectorX& q,
                                               VectorX& z, VectorX& qdot) {
  Eigen::Matrix<double, 4, 3> B;
  z.setZero();
  for (int i = 0; i < 3; ++i) {
    z[model.speed_offset(k) + i] = 1.0;
    joint_coordinate_rates(model, q, z, qdot);
    B.col(i) = qdot.segment<4>(model.coordinate_offset(k));
    z[model.speed_offset(k) + i] = 0.0;
  }
  return B;
}

}  // namespace

TrajectoryMotion read_joint_table_motion(const Model& model, const std::string& path) {
  const auto fail = [&](int line, const std::string& problem) -> std::runtime_error {
    return std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
  };
  for (int k = 0; k < model.num_bodies(); ++k)
    if (model.joint(k).type == JointType::free)
      throw fail(0, "body '" + model.body(k).name +
                        "' has a free joint: a table of joint coordinates does not give its "
                        "motion; give simulate's trajectory CSV (every column) instead");
  const std::vector<std::pair<std::string, TableColumn>> known = joint_table_columns(model);
  std::vector<std::string> names;
  size_t longest = 0;
  for (const auto& [name, where] : known) {
    names.push_back(name);
    longest += name.size() + 1;
  }
  std::optional<LineReader> in;
  std::string line;
  bool any = false;
  try {
    in.emplace(path);
    any = in->next(line, longest + 1024);
  } catch (const std::runtime_error& e) {
    throw fail(0, std::string(e.what()) + " (the trajectory)");
  }
  if (!any) throw fail(0, "the trajectory is empty");
  // The header: each column once, t and every jointed body's q required.
  std::vector<std::string> header;
  for (const std::string_view f : fields(line)) header.emplace_back(f);
  std::vector<TableColumn> column;
  std::vector<int> seen(known.size(), 0);  // 1-based column of each known name, 0: absent
  for (size_t c = 0; c < header.size(); ++c) {
    size_t at = 0;
    while (at < known.size() && known[at].first != header[c]) ++at;
    if (at == known.size()) {
      const std::string near = closest_word(header[c], names);
      throw fail(1,
                 "column " + std::to_string(c + 1) + " '" + printable(header[c], 60) +
                     "' is not a column of a table of " +
                     (model.name().empty() ? std::string("this model") : "'" + model.name() + "'") +
                     (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                     "; a table of joint coordinates has t, NAME.j1.. and optionally "
                     "NAME.jd1.. of each jointed body, and input.NAME");
    }
    if (seen[at] != 0)
      throw fail(1, "column " + std::to_string(c + 1) + " '" + printable(header[c], 60) +
                        "' repeats column " + std::to_string(seen[at]));
    seen[at] = static_cast<int>(c + 1);
    column.push_back(known[at].second);
  }
  if (seen[0] == 0) throw fail(1, "the header has no 't' column (the time of each row)");
  // Per body: its q is required; its rates are all there (given) or none (differentiated).
  std::vector<char> rates_given(static_cast<size_t>(model.num_bodies()), 0);
  bool differentiated = false;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    if (coordinate_count(type) == 0) continue;
    size_t first_rate = 0, rates = 0, missing_rate = 0;
    for (size_t a = 0; a < known.size(); ++a) {
      const TableColumn& w = known[a].second;
      if (w.body != k) continue;
      if (w.kind == TableColumn::coordinate && seen[a] == 0)
        throw fail(1, "the header has no column '" + known[a].first + "' (body '" +
                          model.body(k).name + "': a table needs all its joint coordinates " +
                          "j1..j" + std::to_string(coordinate_count(type)) + ")");
      if (w.kind != TableColumn::rate) continue;
      if (seen[a] != 0) {
        if (rates++ == 0) first_rate = a;
      } else if (missing_rate == 0) {
        missing_rate = a;
      }
    }
    if (rates > 0 && missing_rate != 0)
      throw fail(1, "the header has '" + known[first_rate].first + "' but no column '" +
                        known[missing_rate].first + "': give all of body '" + model.body(k).name +
                        "''s rates jd1..jd" + std::to_string(speed_count(type)) +
                        " or none (then they are differentiated from its coordinates)");
    rates_given[static_cast<size_t>(k)] = rates > 0;
    differentiated = differentiated || rates == 0;
  }
  // The rows.
  TrajectoryMotion out;
  const int nq = model.num_coordinates(), nz = model.num_speeds(), nu = model.num_inputs();
  std::vector<double> q_rows, z_rows, u_rows;  // row-major
  std::vector<double> row(header.size());
  int line_no = 1;
  while (true) {
    try {
      if (!in->next(line, 32 * header.size() + 1024)) break;
    } catch (const std::runtime_error& e) {
      throw fail(line_no + 1, std::string(e.what()) + ", longer than any row of this table");
    }
    ++line_no;
    if (line.empty()) continue;
    parse_row(line, line_no, header, row, fail);
    const size_t r = out.t.size();
    q_rows.resize((r + 1) * static_cast<size_t>(nq), 0.0);
    z_rows.resize((r + 1) * static_cast<size_t>(nz), 0.0);
    u_rows.resize((r + 1) * static_cast<size_t>(nu), 0.0);
    double t = 0.0;
    for (size_t c = 0; c < column.size(); ++c) {
      const TableColumn& w = column[c];
      switch (w.kind) {
        case TableColumn::time:
          t = row[c];
          break;
        case TableColumn::coordinate:
          q_rows[r * static_cast<size_t>(nq) +
                 static_cast<size_t>(model.coordinate_offset(w.body) + w.index)] = row[c];
          break;
        case TableColumn::rate:
          z_rows[r * static_cast<size_t>(nz) +
                 static_cast<size_t>(model.speed_offset(w.body) + w.index)] = row[c];
          break;
        case TableColumn::input:
          u_rows[r * static_cast<size_t>(nu) + static_cast<size_t>(w.index)] = row[c];
          break;
      }
    }
    if (!out.t.empty() && !(t > out.t.back()))
      throw fail(line_no, "t = " + number(t) + " does not come after the previous row's t = " +
                              number(out.t.back()) + " (line " + std::to_string(out.lines.back()) +
                              "); the times must increase");
    // A spherical joint's q are Euler parameters: unit, and continuous from row to row (e and
    // -e are the same rotation, but differentiating across the jump is not).
    for (int k = 0; k < model.num_bodies(); ++k) {
      if (!relative_euler_joint(model.joint(k).type)) continue;
      const size_t o =
          r * static_cast<size_t>(nq) + static_cast<size_t>(model.coordinate_offset(k));
      const std::string cols =
          "columns '" + model.body(k).name + ".j1' to '" + model.body(k).name + ".j4'";
      double norm = 0.0, dot = 0.0;
      for (size_t i = 0; i < 4; ++i) {
        norm += q_rows[o + i] * q_rows[o + i];
        if (r > 0) dot += q_rows[o + i] * q_rows[o + i - static_cast<size_t>(nq)];
      }
      norm = std::sqrt(norm);
      if (!(std::abs(norm - 1.0) <= 1e-6))
        throw fail(line_no, cols + " are not a spherical joint's Euler parameters: their norm is " +
                                number(norm) + ", not 1 within 1e-6");
      if (dot < 0.0)
        throw fail(line_no, cols + " change sign from the previous row's (line " +
                                std::to_string(out.lines.back()) +
                                "): the Euler parameters must keep a continuous sign, as "
                                "simulate writes them");
    }
    out.t.push_back(t);
    out.lines.push_back(line_no);
  }
  const size_t rows = out.t.size();
  if (rows == 0) throw fail(0, "the table has a header but no rows");
  if (rows < (differentiated ? 3u : 2u))
    throw fail(
        0, std::string(differentiated ? "the accelerations of coordinates without rates need at "
                                        "least 3 rows (the parabola through them)"
                                      : "the accelerations need at least 2 rows") +
               "; the table has " + std::to_string(rows));
  const auto cols = static_cast<Eigen::Index>(rows);
  out.q = Eigen::Map<const MatrixX>(q_rows.data(), nq, cols);
  out.z = Eigen::Map<const MatrixX>(z_rows.data(), nz, cols);
  out.u = Eigen::Map<const MatrixX>(u_rows.data(), nu, cols);
  // The rates that are not given: the spline's slopes of q (z = dq/dt), or for a spherical
  // joint w_rel from the slopes e dot of its Euler parameters, by least squares on
  // e dot = [B(e)] w_rel (exact where e dot is tangent to the unit sphere).
  VectorX q(nq), z(nz), qdot(nq);
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    if (coordinate_count(type) == 0 || rates_given[static_cast<size_t>(k)]) continue;
    const int o = model.coordinate_offset(k), p = model.speed_offset(k);
    if (!relative_euler_joint(type)) {
      for (int i = 0; i < coordinate_count(type); ++i)
        out.z.row(p + i) = spline_slopes(out.t, out.q.row(o + i).transpose()).transpose();
      continue;
    }
    MatrixX edot(4, cols);
    for (int i = 0; i < 4; ++i)
      edot.row(i) = spline_slopes(out.t, out.q.row(o + i).transpose()).transpose();
    for (Eigen::Index c = 0; c < cols; ++c) {
      q = out.q.col(c);
      const Eigen::Matrix<double, 4, 3> B = spherical_rate_map(model, k, q, z, qdot);
      out.z.block<3, 1>(p, c) = (B.transpose() * B).inverse() * (B.transpose() * edot.col(c));
    }
  }
  out.zdot = MatrixX::Zero(nz, cols);
  for (int i = 0; i < nz; ++i)
    out.zdot.row(i) = spline_slopes(out.t, out.z.row(i).transpose()).transpose();
  return out;
}

TrajectoryMotion read_trajectory_motion(const Model& model, const std::string& path) {
  // The header decides: simulate's body columns or its energy column mean simulate's CSV, whose
  // reader names the first column that differs from this model's.
  std::vector<std::string> header;
  try {
    LineReader in(path);
    std::string line;
    if (in.next(line, max_line_length(trajectory_columns(model))))
      for (const std::string_view f : fields(line)) header.emplace_back(f);
  } catch (const std::runtime_error&) {
    // Read again below, by the reader that reports it.
  }
  // t, then 16 columns per body (then energy, the inputs' and the constraints' columns).
  const std::vector<std::string> columns = trajectory_body_columns(model);
  const auto bodies_begin = columns.begin() + 1,
             bodies_end = bodies_begin + 16 * model.num_bodies();
  bool full = header.empty();
  for (const std::string& h : header)
    full = full || h == "energy" || std::find(bodies_begin, bodies_end, h) != bodies_end;
  if (!full) return read_joint_table_motion(model, path);
  return trajectory_motion(model, read_trajectory(model, path), path);
}

InputTable read_input_table(const Model& model, const std::string& path, InputHold hold) {
  const auto fail = [&](int line, const std::string& problem) -> std::runtime_error {
    return std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
  };
  const int m = model.num_inputs();
  if (m == 0)
    throw fail(0, "the model " +
                      (model.name().empty() ? std::string() : "'" + model.name() + "' ") +
                      "has no inputs to drive (a model file's `inputs:` section declares them)");
  std::vector<std::string> names;
  for (const Input& in : model.inputs()) names.push_back(in.name);
  std::optional<LineReader> in;
  std::string line;
  // A header of t and every input, each name at most 256 bytes: longer lines are refused.
  const size_t max_line = 32 * static_cast<size_t>(m + 1) + 256 * static_cast<size_t>(m + 1);
  bool any = false;
  try {
    in.emplace(path);
    any = in->next(line, max_line);
  } catch (const std::runtime_error& e) {
    throw fail(0, std::string(e.what()) + " (the inputs)");
  }
  if (!any) throw fail(0, "the file is empty; its first line is the header");
  // Column c of the file: -1 for t, else the input's index.
  std::vector<int> column;
  std::vector<std::string> header;
  for (const std::string_view f : fields(line)) header.emplace_back(f);
  bool has_t = false;
  std::vector<bool> named(static_cast<size_t>(m), false);
  for (size_t c = 0; c < header.size(); ++c) {
    const std::string& h = header[c];
    if (h == "t") {
      if (has_t) throw fail(1, "column " + std::to_string(c + 1) + ": a second 't' column");
      has_t = true;
      column.push_back(-1);
      continue;
    }
    const int i = model.input_index(h);
    if (i < 0) {
      const std::string near = closest_word(h, names);
      throw fail(
          1, "column " + std::to_string(c + 1) + ": unknown input '" + printable(h, 60) + "'" +
                 (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                 "; the model's inputs are " + [&] {
                   std::string all;
                   for (size_t k = 0; k < names.size(); ++k) all += (k ? ", " : "") + names[k];
                   return all;
                 }());
    }
    if (named[static_cast<size_t>(i)])
      throw fail(1, "column " + std::to_string(c + 1) + ": input '" + printable(h, 60) +
                        "' is named twice");
    named[static_cast<size_t>(i)] = true;
    column.push_back(i);
  }
  if (!has_t) throw fail(1, "the header has no 't' column (the time of each row)");
  std::vector<double> times;
  std::vector<double> values;  // row-major, m per row
  std::vector<double> row(column.size());
  int line_no = 1;
  while (true) {
    try {
      if (!in->next(line, 32 * column.size() + 1024)) break;
    } catch (const std::runtime_error& e) {
      throw fail(line_no + 1, std::string(e.what()) + ", longer than any row of these inputs");
    }
    ++line_no;
    if (line.empty()) continue;
    parse_row(line, line_no, header, row, fail);
    double t = 0.0;
    const size_t first = values.size();
    values.resize(first + static_cast<size_t>(m), 0.0);
    for (size_t c = 0; c < column.size(); ++c) {
      if (column[c] < 0)
        t = row[c];
      else
        values[first + static_cast<size_t>(column[c])] = row[c];
    }
    if (!times.empty() && !(t > times.back()))
      throw fail(line_no, "t = " + number(t) + " does not come after the previous row's t = " +
                              number(times.back()) + "; the times must increase");
    times.push_back(t);
  }
  if (times.empty()) throw fail(0, "the inputs have a header but no rows");
  MatrixX table(static_cast<Eigen::Index>(times.size()), m);
  for (size_t r = 0; r < times.size(); ++r)
    for (int i = 0; i < m; ++i)
      table(static_cast<Eigen::Index>(r), i) =
          values[r * static_cast<size_t>(m) + static_cast<size_t>(i)];
  return InputTable(std::move(times), std::move(table), hold);
}

}  // namespace kanedyn::io
