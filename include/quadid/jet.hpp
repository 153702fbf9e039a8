// Second-order jets: a value with its first and second time derivatives,
// propagated exactly by the chain rule. Used for the reference map of
// eqs. (26)-(27), whose angular rates need the jerk and angular accelerations
// the snap of the position trajectory (docs/method.md, "Corrections to the printed paper").
#pragma once

#include <cmath>

namespace quadid {

template <class S>
struct Jet2 {
  S v{}, d1{}, d2{};  // value, d/dt, d2/dt2

  Jet2() = default;
  Jet2(S v_, S d1_, S d2_) : v(v_), d1(d1_), d2(d2_) {}
  static Jet2 constant(S c) { return Jet2(c, S(0), S(0)); }

  // f(a) for scalar f with f' and f'' known at a.v (Faa di Bruno, order 2).
  static Jet2 apply(const Jet2& a, S f, S fp, S fpp) {
    return Jet2(f, fp * a.d1, fpp * a.d1 * a.d1 + fp * a.d2);
  }
  /// The jet of d/dt: shifts derivatives down; the new second derivative is
  /// unknown and set to zero (callers only use its value and first derivative).
  Jet2 derivative() const { return Jet2(d1, d2, S(0)); }
};

template <class S> Jet2<S> operator+(const Jet2<S>& a, const Jet2<S>& b) { return {a.v + b.v, a.d1 + b.d1, a.d2 + b.d2}; }
template <class S> Jet2<S> operator-(const Jet2<S>& a, const Jet2<S>& b) { return {a.v - b.v, a.d1 - b.d1, a.d2 - b.d2}; }
template <class S> Jet2<S> operator-(const Jet2<S>& a) { return {-a.v, -a.d1, -a.d2}; }
template <class S> Jet2<S> operator*(const Jet2<S>& a, const Jet2<S>& b) {
  return {a.v * b.v, a.d1 * b.v + a.v * b.d1, a.d2 * b.v + S(2) * a.d1 * b.d1 + a.v * b.d2};
}
template <class S> Jet2<S> operator*(double c, const Jet2<S>& a) { return {c * a.v, c * a.d1, c * a.d2}; }
template <class S> Jet2<S> operator+(const Jet2<S>& a, double c) { return {a.v + c, a.d1, a.d2}; }
template <class S> Jet2<S> inverse(const Jet2<S>& a) {
  const S i = S(1) / a.v;
  return Jet2<S>::apply(a, i, -i * i, S(2) * i * i * i);
}
template <class S> Jet2<S> operator/(const Jet2<S>& a, const Jet2<S>& b) { return a * inverse(b); }
template <class S> Jet2<S> sin(const Jet2<S>& a) {
  using std::cos; using std::sin;
  const S s = sin(a.v), c = cos(a.v);
  return Jet2<S>::apply(a, s, c, -s);
}
template <class S> Jet2<S> cos(const Jet2<S>& a) {
  using std::cos; using std::sin;
  const S s = sin(a.v), c = cos(a.v);
  return Jet2<S>::apply(a, c, -s, -c);
}
template <class S> Jet2<S> atan(const Jet2<S>& a) {
  using std::atan;
  const S den = S(1) / (S(1) + a.v * a.v);
  return Jet2<S>::apply(a, atan(a.v), den, S(-2) * a.v * den * den);
}

}  // namespace quadid
