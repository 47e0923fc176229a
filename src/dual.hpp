// Forward-mode dual numbers for the analytic derivatives of src/analysis.cpp: a value and its
// derivatives along N directions at once (a "chunk", as ForwardDiff's), so that the physics of
// src/equations.inc, generic over its number type, gives d(output)/d(input) exactly, to
// round-off, in one pass per N directions. Private to the library.
#pragma once

#include <array>
#include <cmath>

#include "kanedyn/types.hpp"

// The attributes of code over the dual numbers (the derivatives' passes, src/analysis.cpp, and
// the force elements' laws for them, src/forces.cpp): compiled for AVX2 and for the baseline
// and chosen when the program is loaded (a pack of four directions is one AVX register), and
// flattened: every small vector operation inlined, which the compiler would leave as calls for
// the wide numbers and which then dominate.
// clang refuses flatten beside target_clones: it gets the clones alone. ThreadSanitizer cannot
// run the resolver that picks a clone (it runs before the sanitizer's own start-up), so a TSan
// build, like any other target, has the baseline function only (src/integrate.cpp likewise).
#if !defined(__x86_64__) || defined(__SANITIZE_THREAD__)
#define KANEDYN_DUAL_ATTRIBUTES __attribute__((flatten))
#elif defined(__clang__)
#define KANEDYN_DUAL_ATTRIBUTES __attribute__((target_clones("avx2", "default")))
#else
#define KANEDYN_DUAL_ATTRIBUTES __attribute__((flatten, target_clones("avx2", "default")))
#endif

namespace kanedyn {

// Aligned explicitly: without AVX the compiler aligns a 32-byte vector to 16 bytes only, and the
// AVX2 clones of src/analysis.cpp and the baseline code must agree on the layout.
template <int N>
struct alignas(32) Dual {
  static_assert(N % 4 == 0, "a dual number carries whole packs of four directions");
  // Four directions a pack, one AVX register: the compiler keeps small std::arrays in 128-bit
  // halves and copies them through memory, where packs stay in registers.
  using Pack = double __attribute__((vector_size(32)));
  static constexpr int kPacks = N / 4;

  double v;
  alignas(32) Pack d[kPacks];

  // Value-initialized (S{}) it is zero; default-initialized its parts are set by the caller.
  Dual() = default;
  static_assert(sizeof(Pack) == 32);
  Dual(double value) : v(value) {  // NOLINT: a constant is a dual with zero derivatives
    for (int i = 0; i < kPacks; ++i) d[i] = Pack{};
  }
  double derivative(int i) const { return d[i / 4][i % 4]; }
  void set_derivative(int i, double value) { d[i / 4][i % 4] = value; }

  Dual& operator+=(double b) {
    v += b;
    return *this;
  }
  Dual& operator+=(const Dual& b) {
    v += b.v;
    for (int i = 0; i < kPacks; ++i) d[i] += b.d[i];
    return *this;
  }
  Dual& operator-=(const Dual& b) {
    v -= b.v;
    for (int i = 0; i < kPacks; ++i) d[i] -= b.d[i];
    return *this;
  }
  // Each result built in place: a copy of an operand (136 bytes and more) costs more than the
  // arithmetic.
  friend Dual operator+(const Dual& a, const Dual& b) {
    Dual r;
    r.v = a.v + b.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = a.d[i] + b.d[i];
    return r;
  }
  friend Dual operator-(const Dual& a, const Dual& b) {
    Dual r;
    r.v = a.v - b.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = a.d[i] - b.d[i];
    return r;
  }
  friend Dual operator-(const Dual& a) {
    Dual r;
    r.v = -a.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = -a.d[i];
    return r;
  }
  friend Dual operator*(const Dual& a, const Dual& b) {
    Dual r;
    r.v = a.v * b.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
    return r;
  }
  friend Dual operator*(double a, const Dual& b) {
    Dual r;
    r.v = a * b.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = a * b.d[i];
    return r;
  }
  friend Dual operator*(const Dual& a, double b) { return b * a; }
  friend Dual operator/(const Dual& a, const Dual& b) {
    const double inv = 1.0 / b.v;
    Dual r;
    r.v = a.v * inv;
    for (int i = 0; i < kPacks; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
    return r;
  }
  friend Dual operator/(double a, const Dual& b) { return Dual(a) / b; }
  friend Dual operator/(const Dual& a, double b) { return (1.0 / b) * a; }
  friend Dual operator+(double a, const Dual& b) {
    Dual r;
    r.v = a + b.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = b.d[i];
    return r;
  }
  friend Dual operator+(const Dual& a, double b) { return b + a; }
  friend Dual operator-(double a, const Dual& b) {
    Dual r;
    r.v = a - b.v;
    for (int i = 0; i < kPacks; ++i) r.d[i] = -b.d[i];
    return r;
  }
  friend Dual operator-(const Dual& a, double b) { return (-b) + a; }
  // Comparisons of the values: the branches of the equations take the path of the point.
  friend bool operator<(const Dual& a, double b) { return a.v < b; }
  friend bool operator>(const Dual& a, double b) { return a.v > b; }
  friend bool operator>(const Dual& a, const Dual& b) { return a.v > b.v; }
  friend bool operator<=(const Dual& a, const Dual& b) { return a.v <= b.v; }
};

template <int N>
inline Dual<N> sin(const Dual<N>& a) {
  Dual<N> r;
  r.v = std::sin(a.v);
  const double c = std::cos(a.v);
  for (int i = 0; i < Dual<N>::kPacks; ++i) r.d[i] = c * a.d[i];
  return r;
}
template <int N>
inline Dual<N> cos(const Dual<N>& a) {
  Dual<N> r;
  r.v = std::cos(a.v);
  const double s = -std::sin(a.v);
  for (int i = 0; i < Dual<N>::kPacks; ++i) r.d[i] = s * a.d[i];
  return r;
}
template <int N>
inline Dual<N> sqrt(const Dual<N>& a) {
  Dual<N> r;
  r.v = std::sqrt(a.v);
  const double h = 0.5 / r.v;
  for (int i = 0; i < Dual<N>::kPacks; ++i) r.d[i] = h * a.d[i];
  return r;
}

}  // namespace kanedyn
