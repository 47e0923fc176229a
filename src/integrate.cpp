#include "kanedyn/integrate.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>

namespace kanedyn {

std::string to_string(Integrator integrator) {
  return integrator == Integrator::rk4 ? "rk4" : "dopri5";
}

Integrator parse_integrator(const std::string& text) {
  if (text == "dopri5") return Integrator::dopri5;
  if (text == "rk4") return Integrator::rk4;
  throw std::invalid_argument("unknown integrator '" + text + "' (expected 'dopri5' or 'rk4')");
}

// ---------------------------------------------------------------------------------------------
// RK4

Rk4::Rk4(int size, OdeFunction f)
    : f_(std::move(f)),
      k1_(VectorX::Zero(size)),
      k2_(VectorX::Zero(size)),
      k3_(VectorX::Zero(size)),
      k4_(VectorX::Zero(size)),
      tmp_(VectorX::Zero(size)) {}

void Rk4::step(double t, double h, VectorX& z) {
  f_(t, z, k1_);
  tmp_ = z + (0.5 * h) * k1_;
  f_(t + 0.5 * h, tmp_, k2_);
  tmp_ = z + (0.5 * h) * k2_;
  f_(t + 0.5 * h, tmp_, k3_);
  tmp_ = z + h * k3_;
  f_(t + h, tmp_, k4_);
  z += (h / 6.0) * (k1_ + 2.0 * k2_ + 2.0 * k3_ + k4_);
  evaluations_ += 4;
}

// ---------------------------------------------------------------------------------------------
// Dormand-Prince 5(4): the tableau of Dormand & Prince (1980), as printed in Hairer, Norsett &
// Wanner, Solving ODEs I, Table II.5.2.

namespace dp {
constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
constexpr double a21 = 1.0 / 5;
constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                 a54 = -212.0 / 729;
constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                 a65 = -5103.0 / 18656;
// Fifth-order weights b_i (= the last row a_7i: FSAL); b_2 = b_7 = 0.
constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
                 b6 = 11.0 / 84;
// e_i = b_i - bhat_i, bhat the embedded fourth-order weights
// (5179/57600, 0, 7571/16695, 393/640, -92097/339200, 187/2100, 1/40).
constexpr double e1 = 35.0 / 384 - 5179.0 / 57600, e3 = 500.0 / 1113 - 7571.0 / 16695,
                 e4 = 125.0 / 192 - 393.0 / 640, e5 = -2187.0 / 6784 + 92097.0 / 339200,
                 e6 = 11.0 / 84 - 187.0 / 2100, e7 = -1.0 / 40;

/// Weights b_i(theta) of the continuous extension, Hairer et al. Eq. (II.6.12): the step's
/// value at t + theta h is z + h sum_i b_i(theta) k_i (b_2(theta) = 0). Order 4 for every
/// theta in [0, 1]; b_i(1) = b_i.
struct DenseWeights {
  double w1, w3, w4, w5, w6, w7;
  explicit DenseWeights(double th) {
    const double cubic = th * th * (3.0 - 2.0 * th);  // weight of b_i
    const double q = th * th * (th - 1.0) * (th - 1.0);
    w1 = cubic * b1 + th * (th - 1.0) * (th - 1.0) -
         q * 5.0 * (2558722523.0 - 31403016.0 * th) / 11282082432.0;
    w3 = cubic * b3 + q * 100.0 * (882725551.0 - 15701508.0 * th) / 32700410799.0;
    w4 = cubic * b4 - q * 25.0 * (443332067.0 - 31403016.0 * th) / 1880347072.0;
    w5 = cubic * b5 + q * 32805.0 * (23143187.0 - 3489224.0 * th) / 199316789632.0;
    w6 = cubic * b6 - q * 55.0 * (29972135.0 - 7076736.0 * th) / 822651844.0;
    w7 = th * th * (th - 1.0) + q * 10.0 * (7414447.0 - 829305.0 * th) / 29380423.0;
  }
};
}  // namespace dp

// The vector arithmetic of a step: raw loops that the compiler vectorizes, once for the
// x86-64 baseline (SSE2), once for AVX2 and once for AVX-512F, the copy matching the CPU being
// chosen when the program is loaded (target_clones). No copy contracts products and sums into
// FMA (CMakeLists.txt compiles this file with -ffp-contract=off; AVX-512F brings FMA with it),
// so every operation is rounded as written and all copies give the same bits as Eigen's
// expressions did. The 13N-vectors are short and a step of the eight-body example has seven
// such passes: with twice the width they take half the instructions. ThreadSanitizer cannot
// run the resolver that picks a copy (it runs before the sanitizer's own start-up), so a TSan
// build has the baseline copy only; nor can clang 14 clone a function template, so a clang
// build (the fuzzing one) has it only too.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_THREAD__)
#define KANEDYN_VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define KANEDYN_VECTOR_CLONES
#endif

namespace {

/// out = z + h (a_0 k_0 + a_1 k_1 + ... + a_{N-1} k_{N-1}), rounded as the Eigen expression
/// z + h * (a0 * k0 + a1 * k1 + ...) is: products and sums left to right.
template <int N>
KANEDYN_VECTOR_CLONES void combine(Eigen::Index n, const double* __restrict z, double h,
                                   const double (&a)[N], const double* const (&k)[N],
                                   double* __restrict out) {
  for (Eigen::Index i = 0; i < n; ++i) {
    double sum = a[0] * k[0][i];
    for (int j = 1; j < N; ++j) sum += a[j] * k[j][i];
    out[i] = z[i] + h * sum;
  }
}

}  // namespace

Dopri5::Dopri5(int size, OdeFunction f, Dopri5Options options) : f_(std::move(f)), opt_(options) {
  if (!(opt_.rtol >= 0.0) || !(opt_.atol >= 0.0) || opt_.rtol + opt_.atol <= 0.0)
    throw std::invalid_argument("dopri5: rtol and atol must be >= 0 and not both 0");
  if (!(opt_.safety > 0.0 && opt_.safety <= 1.0) || !(opt_.min_factor > 0.0) ||
      !(opt_.min_factor < 1.0) || !(opt_.max_factor > 1.0))
    throw std::invalid_argument("dopri5: need 0 < safety <= 1, 0 < min_factor < 1 < max_factor");
  if (!(opt_.max_step > 0.0) || !(opt_.initial_step >= 0.0))
    throw std::invalid_argument("dopri5: max_step must be > 0 and initial_step >= 0");
  for (VectorX* v :
       {&z_, &z_old_, &z_new_, &tmp_, &ratio_, &k1_, &k2_, &k3_, &k4_, &k5_, &k6_, &k7_})
    v->setZero(size);
}

void Dopri5::eval(double t, const VectorX& z, VectorX& dz) {
  f_(t, z, dz);
  ++evaluations_;
}

double Dopri5::min_step() const {
  return 16.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(t_), span_);
}

StepStatus Dopri5::start(double t0, const VectorX& z0, double t_end) {
  if (z0.size() != z_.size()) throw std::invalid_argument("dopri5: state has the wrong size");
  if (!(t_end >= t0)) throw std::invalid_argument("dopri5: t_end must be >= t0");
  t_ = t_old_ = t0;
  t_end_ = t_end;
  span_ = t_end - t0;
  z_ = z0;
  z_old_ = z0;
  accepted_ = rejected_ = evaluations_ = 0;
  failed_component_ = -1;
  worst_pending_ = false;
  fsal_pending_ = false;
  h_last_ = 0.0;
  for (Eigen::Index i = 0; i < z_.size(); ++i)
    if (!std::isfinite(z_[i])) {
      failed_component_ = static_cast<int>(i);
      return StepStatus::non_finite;
    }
  eval(t_, z_, k1_);
  for (Eigen::Index i = 0; i < k1_.size(); ++i)
    if (!std::isfinite(k1_[i])) {
      failed_component_ = static_cast<int>(i);
      return StepStatus::non_finite;
    }
  h_ = opt_.initial_step > 0.0 ? opt_.initial_step : initial_step(t_end);
  // The guess can fall below the smallest step (a stiff model with a state near zero, where
  // the tolerances are atol alone): try the smallest one, and let the control grow it.
  h_ = std::min(std::max(h_, min_step()), opt_.max_step);
  return StepStatus::ok;
}

// Hairer et al., Sec. II.4 "Automatic Step Size Control", starting step size: a guess from
// |z|/|f|, refined by an explicit Euler step's estimate of the second derivative.
double Dopri5::initial_step(double t_end) {
  if (span_ <= 0.0) return 0.0;
  auto norm = [this](const VectorX& v) {
    double sum = 0.0;
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      const double sc = opt_.atol + opt_.rtol * std::abs(z_[i]);
      sum += (v[i] / sc) * (v[i] / sc);
    }
    return std::sqrt(sum / static_cast<double>(std::max<Eigen::Index>(v.size(), 1)));
  };
  // The norms may overflow for tiny tolerances; the guess then falls back to 1e-6.
  const double d0 = norm(z_), d1 = norm(k1_);
  const bool usable = d0 >= 1e-5 && d1 >= 1e-5 && std::isfinite(d0) && std::isfinite(d1);
  double h0 = usable ? 0.01 * d0 / d1 : 1e-6;
  h0 = std::min({h0, opt_.max_step, t_end - t_});
  tmp_ = z_ + h0 * k1_;
  eval(t_ + h0, tmp_, k2_);
  k2_ -= k1_;
  const double d2 = norm(k2_) / h0;
  const double dmax = std::max(d1, d2);
  const double h1 = dmax <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dmax, 1.0 / 5.0);
  const double h = std::min(100.0 * h0, h1);
  return std::isfinite(h) && h > 0.0 ? std::min(h, t_end - t_) : h0;
}

double Dopri5::attempt(double h) {
  using namespace dp;
  const double t = t_;
  const Eigen::Index n = z_.size();
  const double* const z = z_.data();
  const double *const k1 = k1_.data(), *const k2 = k2_.data(), *const k3 = k3_.data(),
                      *const k4 = k4_.data(), *const k5 = k5_.data(), *const k6 = k6_.data();
  combine<1>(n, z, h, {a21}, {k1}, tmp_.data());
  eval(t + c2 * h, tmp_, k2_);
  combine<2>(n, z, h, {a31, a32}, {k1, k2}, tmp_.data());
  eval(t + c3 * h, tmp_, k3_);
  combine<3>(n, z, h, {a41, a42, a43}, {k1, k2, k3}, tmp_.data());
  eval(t + c4 * h, tmp_, k4_);
  combine<4>(n, z, h, {a51, a52, a53, a54}, {k1, k2, k3, k4}, tmp_.data());
  eval(t + c5 * h, tmp_, k5_);
  combine<5>(n, z, h, {a61, a62, a63, a64, a65}, {k1, k2, k3, k4, k5}, tmp_.data());
  eval(t + h, tmp_, k6_);
  combine<5>(n, z, h, {b1, b3, b4, b5, b6}, {k1, k3, k4, k5, k6}, z_new_.data());
  eval(t + h, z_new_, k7_);
  err_ = error_norm(h);
  return err_;
}

namespace {
/// 2^63 when x is not finite (its exponent bits are all ones and the 1 added carries out of
/// them), else 0: an integer test that vectorizes, unlike std::isfinite.
inline std::uint64_t non_finite_bit(double x) {
  constexpr std::uint64_t kExponent = 0x7FF0000000000000, kExponentOne = 0x0010000000000000;
  return ((std::bit_cast<std::uint64_t>(x) & kExponent) + kExponentOne) & 0x8000000000000000;
}

/// e = h sum (b_i - bhat_i) k_i and r_i = (e_i / sc_i)^2, sc_i = atol + rtol max(|z_i|,
/// |z_new_i|); returns nonzero when some z_new_i, k7_i or e_i is not finite. A function of
/// its own so that __restrict tells the vectorizer the vectors are distinct.
KANEDYN_VECTOR_CLONES std::uint64_t scaled_errors(
    Eigen::Index n, double h, double atol, double rtol, const double* __restrict z,
    const double* __restrict z_new, const double* __restrict k1, const double* __restrict k3,
    const double* __restrict k4, const double* __restrict k5, const double* __restrict k6,
    const double* __restrict k7, double* __restrict e, double* __restrict r) {
  using namespace dp;
  std::uint64_t non_finite = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double ei =
        h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i]);
    const double sc = atol + rtol * std::max(std::abs(z[i]), std::abs(z_new[i]));
    const double q = ei / sc;
    e[i] = ei;
    r[i] = q * q;
    non_finite |= non_finite_bit(z_new[i]) | non_finite_bit(k7[i]) | non_finite_bit(ei);
  }
  return non_finite;
}
}  // namespace

double Dopri5::error_norm(double h) {
  // The scaled errors r_i into ratio_ (e into tmp_) and the finiteness test in a loop the
  // compiler vectorizes; then their sum in index order (the same rounding as one loop). The
  // component of the largest r_i is found only when asked for (failed_component()).
  const Eigen::Index n = tmp_.size();
  const bool finite = scaled_errors(n, h, opt_.atol, opt_.rtol, z_.data(), z_new_.data(),
                                    k1_.data(), k3_.data(), k4_.data(), k5_.data(), k6_.data(),
                                    k7_.data(), tmp_.data(), ratio_.data()) == 0;
  failed_component_ = -1;
  trial_non_finite_ = !finite;
  worst_pending_ = finite;
  if (!finite) {  // the first component at fault
    for (Eigen::Index i = 0; i < n; ++i)
      if (!std::isfinite(z_new_[i]) || !std::isfinite(k7_[i]) || !std::isfinite(tmp_[i])) {
        failed_component_ = static_cast<int>(i);
        break;
      }
    return std::numeric_limits<double>::quiet_NaN();
  }
  double sum = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) sum += ratio_[i];
  // +inf when a ratio overflows (tolerances far below the error): a plain rejection.
  return std::sqrt(sum / static_cast<double>(std::max<Eigen::Index>(n, 1)));
}

int Dopri5::failed_component() const {
  if (worst_pending_) {  // the first largest r_i of the last attempted step
    double worst = -1.0;
    for (Eigen::Index i = 0; i < ratio_.size(); ++i)
      if (ratio_[i] > worst) {
        worst = ratio_[i];
        failed_component_ = static_cast<int>(i);
      }
    worst_pending_ = false;
  }
  return failed_component_;
}

void Dopri5::accept(double h, double t_new) {
  // The step's start value and stages stay for dense output until the next step; k7 = f at
  // the new state becomes k1 of the next step (FSAL) when that begins.
  z_old_.swap(z_);
  z_.swap(z_new_);
  t_old_ = t_;
  t_ = t_new;
  h_last_ = h;
  fsal_pending_ = true;
  ++accepted_;
}

StepStatus Dopri5::step() {
  if (t_ >= t_end_) return StepStatus::ok;
  if (fsal_pending_) {
    k1_.swap(k7_);
    fsal_pending_ = false;
  }
  bool rejected_before = false;
  for (;;) {
    double h = std::min(h_, opt_.max_step);
    // Land on t_end exactly; stretch a little rather than leave a sliver of a step.
    const double remaining = t_end_ - t_;
    const bool last = h >= remaining || remaining - h < 1e-3 * h;
    if (last) h = remaining;
    if (!(h >= min_step()) && h < remaining) {
      // failed_component_ still names the culprit of the last attempt.
      return StepStatus::step_underflow;
    }
    const double err = attempt(h);
    if (trial_non_finite_) {
      ++rejected_;
      rejected_before = true;
      const int culprit = failed_component_;  // set by error_norm: the first non-finite one
      h_ = h * opt_.min_factor;
      if (h_ < min_step()) {
        failed_component_ = culprit;
        return StepStatus::non_finite;
      }
      continue;
    }
    if (err <= 1.0) {
      double factor = err == 0.0 ? opt_.max_factor : opt_.safety * std::pow(err, -1.0 / 5.0);
      factor = std::clamp(factor, opt_.min_factor, opt_.max_factor);
      if (rejected_before) factor = std::min(factor, 1.0);
      accept(h, last ? t_end_ : t_ + h);
      h_ = std::min(h * factor, opt_.max_step);
      return StepStatus::ok;
    }
    ++rejected_;
    rejected_before = true;
    const double factor = std::clamp(opt_.safety * std::pow(err, -1.0 / 5.0), opt_.min_factor, 1.0);
    h_ = h * factor;
    if (!(h_ >= min_step()) && h_ < remaining) return StepStatus::step_underflow;
  }
}

StepStatus Dopri5::fixed_step(double h) {
  if (fsal_pending_) {
    k1_.swap(k7_);
    fsal_pending_ = false;
  }
  attempt(h);
  if (trial_non_finite_) return StepStatus::non_finite;
  accept(h, t_ + h);
  return StepStatus::ok;
}

void Dopri5::dense_output(double t, VectorX& out) const {
  const double h = h_last_;
  if (h == 0.0) {
    out = z_;
    return;
  }
  const double th = std::clamp((t - t_old_) / h, 0.0, 1.0);
  const dp::DenseWeights w(th);
  out.resize(z_.size());
  combine<6>(z_.size(), z_old_.data(), h, {w.w1, w.w3, w.w4, w.w5, w.w6, w.w7},
             {k1_.data(), k3_.data(), k4_.data(), k5_.data(), k6_.data(), k7_.data()}, out.data());
}

}  // namespace kanedyn
