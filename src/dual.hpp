// Forward-mode dual numbers for the analytic derivatives of src/analysis.cpp: a value and its
// derivatives along N directions at once (a "chunk", as ForwardDiff's), so that the physics of
// src/equations.inc, generic over its number type, gives d(output)/d(input) exactly, to
// round-off, in one pass per N directions. Private to the library.
#pragma once

#include <array>
#include <cmath>

#include "kanedyn/types.hpp"

namespace kanedyn {

template <int N>
struct Dual {
  double v = 0.0;
  std::array<double, N> d{};

  Dual() = default;
  Dual(double value) : v(value) {}  // NOLINT: a constant is a dual with zero derivatives

  Dual& operator+=(const Dual& b) {
    v += b.v;
    for (int i = 0; i < N; ++i) d[i] += b.d[i];
    return *this;
  }
  Dual& operator-=(const Dual& b) {
    v -= b.v;
    for (int i = 0; i < N; ++i) d[i] -= b.d[i];
    return *this;
  }
  friend Dual operator+(Dual a, const Dual& b) { return a += b; }
  friend Dual operator-(Dual a, const Dual& b) { return a -= b; }
  friend Dual operator-(const Dual& a) {
    Dual r;
    r.v = -a.v;
    for (int i = 0; i < N; ++i) r.d[i] = -a.d[i];
    return r;
  }
  friend Dual operator*(const Dual& a, const Dual& b) {
    Dual r;
    r.v = a.v * b.v;
    for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
    return r;
  }
  friend Dual operator*(double a, const Dual& b) {
    Dual r;
    r.v = a * b.v;
    for (int i = 0; i < N; ++i) r.d[i] = a * b.d[i];
    return r;
  }
  friend Dual operator*(const Dual& a, double b) { return b * a; }
  friend Dual operator/(const Dual& a, const Dual& b) {
    const double inv = 1.0 / b.v;
    Dual r;
    r.v = a.v * inv;
    for (int i = 0; i < N; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
    return r;
  }
  friend Dual operator/(double a, const Dual& b) { return Dual(a) / b; }
  friend Dual operator/(const Dual& a, double b) { return (1.0 / b) * a; }
  friend Dual operator+(double a, const Dual& b) { return Dual(a) + b; }
  friend Dual operator+(const Dual& a, double b) { return a + Dual(b); }
  friend Dual operator-(double a, const Dual& b) { return Dual(a) - b; }
  friend Dual operator-(const Dual& a, double b) { return a - Dual(b); }
  // Comparisons of the values: the branches of the equations take the path of the point.
  friend bool operator<(const Dual& a, double b) { return a.v < b; }
  friend bool operator>(const Dual& a, const Dual& b) { return a.v > b.v; }
  friend bool operator<=(const Dual& a, const Dual& b) { return a.v <= b.v; }
};

template <int N>
inline Dual<N> sin(const Dual<N>& a) {
  Dual<N> r;
  r.v = std::sin(a.v);
  const double c = std::cos(a.v);
  for (int i = 0; i < N; ++i) r.d[i] = c * a.d[i];
  return r;
}
template <int N>
inline Dual<N> cos(const Dual<N>& a) {
  Dual<N> r;
  r.v = std::cos(a.v);
  const double s = -std::sin(a.v);
  for (int i = 0; i < N; ++i) r.d[i] = s * a.d[i];
  return r;
}
template <int N>
inline Dual<N> sqrt(const Dual<N>& a) {
  Dual<N> r;
  r.v = std::sqrt(a.v);
  const double h = 0.5 / r.v;
  for (int i = 0; i < N; ++i) r.d[i] = h * a.d[i];
  return r;
}

}  // namespace kanedyn
