// Forward-mode automatic differentiation: the one dual-number type of quadid.
//
// Dual<N, S> holds a value and its derivatives with respect to N seeded
// inputs, propagated exactly by the chain rule. S is double or itself a Dual,
// so derivatives nest:
//   - Dual<N> gives a gradient (the design module's d Phi / d coefficients);
//   - TimeJet1<S> = Dual<1, S> is a value with its time derivative;
//   - TimeJet2<S> = Dual<1, Dual<1, S>> is a value with its first and second
//     time derivatives (both nesting levels seeded with the same direction):
//     v.v = f, v.d[0] = d.v = df/dt, d.d[0] = d2f/dt2.
// The reference map of eqs. (26)-(27) uses TimeJet2 for the angles (their
// rates need the jerk and their accelerations the snap of the position,
// docs/method.md, "Corrections to the printed paper") and TimeJet1 for the
// body velocity and rates, with S = double or S = Dual<15> for the gradient.
//
// Eigen's AutoDiffScalar was considered: it has no atan (eqs. 26-27 need it)
// and its expression templates are slower than these fixed arrays.
#pragma once

#include <array>
#include <cmath>
#include <utility>

namespace quadid {

template <int N, class S = double>
struct Dual {
  S v{};
  std::array<S, N> d{};

  Dual() = default;
  Dual(double x) : v(x) {}  // NOLINT: constants mix freely with duals
  Dual(const S& x, const std::array<S, N>& dx) : v(x), d(dx) {}
  /// Input i of N: value x, derivative 1 with respect to itself.
  static Dual seed(const S& x, int i) {
    Dual r;
    r.v = x;
    r.d[static_cast<size_t>(i)] = S(1.0);
    return r;
  }
  /// f(a) for a scalar function f with f(a.v) = f and f'(a.v) = fp.
  static Dual chain(const Dual& a, const S& f, const S& fp) {
    Dual r;
    r.v = f;
    for (int i = 0; i < N; ++i) r.d[static_cast<size_t>(i)] = fp * a.d[static_cast<size_t>(i)];
    return r;
  }
};

/// A value with its time derivative; and with its first and second time derivatives.
template <class S = double> using TimeJet1 = Dual<1, S>;
template <class S = double> using TimeJet2 = Dual<1, Dual<1, S>>;

/// The jet of (f, df/dt, d2f/dt2).
template <class S>
TimeJet2<S> time_jet(const S& f, const S& f1, const S& f2) {
  return TimeJet2<S>(TimeJet1<S>(f, {f1}), {TimeJet1<S>(f1, {f2})});
}
/// The jet of (f, df/dt).
template <class S>
TimeJet1<S> time_jet(const S& f, const S& f1) {
  return TimeJet1<S>(f, {f1});
}

template <int N, class S> Dual<N, S> operator+(const Dual<N, S>& a, const Dual<N, S>& b) {
  Dual<N, S> r;
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.d[static_cast<size_t>(i)] = a.d[static_cast<size_t>(i)] + b.d[static_cast<size_t>(i)];
  return r;
}
template <int N, class S> Dual<N, S> operator-(const Dual<N, S>& a, const Dual<N, S>& b) {
  Dual<N, S> r;
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.d[static_cast<size_t>(i)] = a.d[static_cast<size_t>(i)] - b.d[static_cast<size_t>(i)];
  return r;
}
template <int N, class S> Dual<N, S> operator-(const Dual<N, S>& a) {
  Dual<N, S> r;
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.d[static_cast<size_t>(i)] = -a.d[static_cast<size_t>(i)];
  return r;
}
template <int N, class S> Dual<N, S> operator*(const Dual<N, S>& a, const Dual<N, S>& b) {
  Dual<N, S> r;
  r.v = a.v * b.v;
  for (int i = 0; i < N; ++i)
    r.d[static_cast<size_t>(i)] = a.d[static_cast<size_t>(i)] * b.v + a.v * b.d[static_cast<size_t>(i)];
  return r;
}
template <int N, class S> Dual<N, S> operator/(const Dual<N, S>& a, const Dual<N, S>& b) {
  const S ib = S(1.0) / b.v, q = a.v * ib;
  Dual<N, S> r;
  r.v = q;
  for (int i = 0; i < N; ++i)
    r.d[static_cast<size_t>(i)] = (a.d[static_cast<size_t>(i)] - q * b.d[static_cast<size_t>(i)]) * ib;
  return r;
}
// Mixed with a plain double (any nesting depth).
template <int N, class S> Dual<N, S> operator+(const Dual<N, S>& a, double c) {
  Dual<N, S> r = a;
  r.v = a.v + c;
  return r;
}
template <int N, class S> Dual<N, S> operator+(double c, const Dual<N, S>& a) { return a + c; }
template <int N, class S> Dual<N, S> operator-(const Dual<N, S>& a, double c) { return a + (-c); }
template <int N, class S> Dual<N, S> operator-(double c, const Dual<N, S>& a) { return (-a) + c; }
template <int N, class S> Dual<N, S> operator*(const Dual<N, S>& a, double c) {
  Dual<N, S> r;
  r.v = a.v * c;
  for (int i = 0; i < N; ++i) r.d[static_cast<size_t>(i)] = a.d[static_cast<size_t>(i)] * c;
  return r;
}
template <int N, class S> Dual<N, S> operator*(double c, const Dual<N, S>& a) { return a * c; }
template <int N, class S> Dual<N, S> operator/(const Dual<N, S>& a, double c) { return a * (1.0 / c); }
template <int N, class S> Dual<N, S>& operator+=(Dual<N, S>& a, const Dual<N, S>& b) { return a = a + b; }
template <int N, class S> Dual<N, S>& operator-=(Dual<N, S>& a, const Dual<N, S>& b) { return a = a - b; }
template <int N, class S> Dual<N, S>& operator*=(Dual<N, S>& a, const Dual<N, S>& b) { return a = a * b; }

/// {sin a, cos a} together (one sin and one cos of the innermost value at every
/// depth); the innermost scalar is double or any type with std-style sin and cos.
template <class T> std::pair<T, T> sin_cos(const T& x) {
  using std::cos;
  using std::sin;
  return {sin(x), cos(x)};
}
template <int N, class S> std::pair<Dual<N, S>, Dual<N, S>> sin_cos(const Dual<N, S>& a) {
  const auto [s, c] = sin_cos(a.v);
  return {Dual<N, S>::chain(a, s, c), Dual<N, S>::chain(a, c, -s)};
}
template <int N, class S> Dual<N, S> sin(const Dual<N, S>& a) { return sin_cos(a).first; }
template <int N, class S> Dual<N, S> cos(const Dual<N, S>& a) { return sin_cos(a).second; }
template <int N, class S> Dual<N, S> atan(const Dual<N, S>& a) {
  using std::atan;
  return Dual<N, S>::chain(a, atan(a.v), S(1.0) / (S(1.0) + a.v * a.v));
}

}  // namespace quadid
