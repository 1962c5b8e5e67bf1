// Forward-mode dual numbers: a value and its derivatives with respect to N
// parameters. Principled v2 (principled_v2.h) evaluates one templated formula
// with T = float (rendering) and T = Dual<5> (the material adjoints: base colour
// R, G, B, roughness, metallic), so the gradient is that of the very function the
// renderer evaluates -- table interpolation, clamps and all.
//
// Branches (clamps, min/max) follow the value: a clamped quantity is a constant
// (zero derivative), as for the analytic derivatives of the other models.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace ptir {

template <int N>
struct Dual {
  float v = 0.0f;
  std::array<float, N> d{};

  Dual() = default;
  Dual(float value) : v(value) {}  // a constant (implicit: mixes with float)
  static Dual variable(float value, int i) {
    Dual x(value);
    x.d[size_t(i)] = 1.0f;
    return x;
  }
};

// Value of a scalar (float or Dual).
inline float value_of(float x) { return x; }
template <int N>
float value_of(const Dual<N>& x) {
  return x.v;
}

template <int N>
Dual<N> operator+(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r(a.v + b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] + b.d[i];
  return r;
}
template <int N>
Dual<N> operator-(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r(a.v - b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] - b.d[i];
  return r;
}
template <int N>
Dual<N> operator-(const Dual<N>& a) {
  Dual<N> r(-a.v);
  for (int i = 0; i < N; ++i) r.d[i] = -a.d[i];
  return r;
}
template <int N>
Dual<N> operator*(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r(a.v * b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return r;
}
template <int N>
Dual<N> operator/(const Dual<N>& a, const Dual<N>& b) {
  const float inv = 1.0f / b.v;
  Dual<N> r(a.v * inv);
  for (int i = 0; i < N; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
  return r;
}
template <int N>
Dual<N> operator+(const Dual<N>& a, float b) {
  Dual<N> r = a;
  r.v += b;
  return r;
}
template <int N>
Dual<N> operator+(float a, const Dual<N>& b) {
  return b + a;
}
template <int N>
Dual<N> operator-(const Dual<N>& a, float b) {
  Dual<N> r = a;
  r.v -= b;
  return r;
}
template <int N>
Dual<N> operator-(float a, const Dual<N>& b) {
  return Dual<N>(a) - b;
}
template <int N>
Dual<N> operator*(const Dual<N>& a, float b) {
  Dual<N> r(a.v * b);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b;
  return r;
}
template <int N>
Dual<N> operator*(float a, const Dual<N>& b) {
  return b * a;
}
template <int N>
Dual<N> operator/(const Dual<N>& a, float b) {
  return a * (1.0f / b);
}
template <int N>
Dual<N> operator/(float a, const Dual<N>& b) {
  return Dual<N>(a) / b;
}
template <int N>
Dual<N>& operator+=(Dual<N>& a, const Dual<N>& b) {
  return a = a + b;
}
template <int N>
Dual<N>& operator*=(Dual<N>& a, const Dual<N>& b) {
  return a = a * b;
}

// sqrt: the derivative at 0 is taken as 0 (only reached by clamped inputs).
inline float dual_sqrt(float x) { return std::sqrt(x); }
template <int N>
Dual<N> dual_sqrt(const Dual<N>& x) {
  Dual<N> r(std::sqrt(x.v));
  const float k = r.v > 0.0f ? 0.5f / r.v : 0.0f;
  for (int i = 0; i < N; ++i) r.d[i] = x.d[i] * k;
  return r;
}

// Clamps and extrema by value.
template <class T>
T clamp_by_value(const T& x, float lo, float hi) {
  const float v = value_of(x);
  if (v < lo) return T(lo);
  if (v > hi) return T(hi);
  return x;
}
template <class T>
T saturate_t(const T& x) {
  return clamp_by_value(x, 0.0f, 1.0f);
}
template <class T>
T max_by_value(const T& a, const T& b) {
  return value_of(a) >= value_of(b) ? a : b;
}
template <class T>
T min_by_value(const T& a, const T& b) {
  return value_of(a) <= value_of(b) ? a : b;
}

}  // namespace ptir
