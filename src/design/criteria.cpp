// Excitation criteria of the regressor stack W (eq. 20) and their exact
// gradients with respect to the Fourier coefficients of eq. (18).
//
// Phi_k depends on the coefficients only through 15 flat derivatives per
// sample u_k (x, y, z orders 1..4, psi orders 0..2), each linear in the
// coefficients. The criterion's sensitivity to Phi_k is closed form (below),
// G_k = dJ/dPhi_k; regressor_vjp gives dPhi_k/du_k^T vec(G_k) exactly without
// forming the Jacobian (a forward-mode dual over all 15 inputs, which the
// vehicle limits still use, costs three times as much), and the chain to the
// coefficients is a product with the precomputed basis.
#include "design_internal.hpp"

#include "quadid/model/regressor.hpp"

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace quadid {

using design_detail::kInputs;

std::string_view criterion_name(Criterion c) {
  switch (c) {
    case Criterion::Cond: return "cond";
    case Criterion::CondScaled: return "cond-scaled";
    case Criterion::DOpt: return "dopt";
    case Criterion::Precision: return "precision";
  }
  return "?";
}

Criterion parse_criterion(std::string_view name) {
  for (Criterion c : {Criterion::Cond, Criterion::CondScaled, Criterion::DOpt, Criterion::Precision})
    if (name == criterion_name(c)) return c;
  throw std::invalid_argument(
      fmt::format("unknown criterion '{}' (expected cond, cond-scaled, dopt or precision)", name));
}

void RowNoise::validate() const {
  if (!(sigma.allFinite() && sigma.minCoeff() > 0.0))
    throw std::invalid_argument(fmt::format("row noise [{}] (N, N m) must be positive", fmt::join(sigma, ", ")));
  if (!(std::isfinite(samples) && samples >= 1.0))
    throw std::invalid_argument(fmt::format("row noise samples = {:g} must be at least 1", samples));
}

Theta parameter_scales(const Params& ref, double product_floor) {
  const Mat3& I = ref.I;
  auto product = [&](int i, int j) {
    return std::max(std::abs(I(i, j)), product_floor * std::sqrt(std::abs(I(i, i) * I(j, j))));
  };
  Theta s;
  s << std::abs(ref.m), std::abs(I(0, 0)), product(0, 1), product(0, 2), std::abs(I(1, 1)), product(1, 2),
      std::abs(I(2, 2));
  return s;
}

double CriterionValues::value(Criterion c) const {
  switch (c) {
    case Criterion::Cond: return cond;
    case Criterion::CondScaled: return cond_scaled;
    case Criterion::DOpt: return dopt;
    case Criterion::Precision: return precision;
  }
  return cond;
}

namespace design_detail {

Eigen::Matrix<double, 4, 7> regressor_sample(const FlatOutput& d, double g,
                                             Eigen::Matrix<double, 28, kInputs>* jac) {
  if (!jac) {
    const Reference r = reference_from_flat<double>(d, g);
    return regressor<double>(r.v, r.omega, r.eta, r.v_dot, r.omega_dot, g);
  }
  using D = Dual<kInputs>;
  Eigen::Matrix<D, 4, 5> dd;
  for (int i = 0; i < 4; ++i)
    for (int n = 0; n < 5; ++n)
      dd(i, n) = is_input(i, n) ? D::seed(d(i, n), input_index(i, n)) : D(d(i, n));
  const ReferenceT<D> r = reference_from_flat<D>(dd, g);  // eqs. (26)-(27) and below eq. (20)
  const Regressor<D> P = regressor<D>(r.v, r.omega, r.eta, r.v_dot, r.omega_dot, g);  // eq. (12)
  Eigen::Matrix<double, 4, 7> out;
  for (int rr = 0; rr < 4; ++rr)
    for (int c = 0; c < 7; ++c) {
      out(rr, c) = P(rr, c).v;
      for (int j = 0; j < kInputs; ++j) (*jac)(7 * rr + c, j) = P(rr, c).d[static_cast<size_t>(j)];
    }
  return out;
}

Eigen::Matrix<double, kInputs, 1> regressor_vjp(const FlatOutput& d, double g, const Eigen::Matrix<double, 4, 7>& G) {
  // (1) Roll and pitch (eqs. 26-27) are functions of q = (a_x, a_y, a_z + g, psi)
  // alone; their time jets are forward-differentiated over q only (4
  // directions). For f = F(q(t)) the jets' other derivatives follow from
  // these (differentiate f_dot = F'(q) q_dot and f_ddot = q_dot^T F'' q_dot + F' q_ddot):
  //   d f_dot / d q_dot = d f / d q,  d f_ddot / d q_dot = 2 d f_dot / d q,  d f_ddot / d q_ddot = d f / d q.
  using D4 = Dual<4>;
  const auto ax = time_jet<D4>(D4::seed(d(0, 2), 0), D4(d(0, 3)), D4(d(0, 4)));
  const auto ay = time_jet<D4>(D4::seed(d(1, 2), 1), D4(d(1, 3)), D4(d(1, 4)));
  const auto az = time_jet<D4>(D4::seed(d(2, 2) + g, 2), D4(d(2, 3)), D4(d(2, 4)));
  const auto psi4 = time_jet<D4>(D4::seed(d(3, 0), 3), D4(d(3, 1)), D4(d(3, 2)));
  const auto [spsi, cpsi] = sin_cos(psi4);
  const auto tilt = tilt_from_force(ax, ay, az, cpsi, spsi);  // {phi, theta}
  // jet[f][n]: derivative n (0, 1, 2) of angle f (phi, theta) with its d/dq.
  std::array<std::array<D4, 3>, 2> jet;
  for (size_t f = 0; f < 2; ++f) jet[f] = {tilt[f].v.v, tilt[f].d[0].v, tilt[f].d[0].d[0]};

  // (2) The rest backwards, by hand: s = <G, Phi> through the regressor (eq. 12),
  // the body rates (eq. 4) and velocity (eq. 3), to the attitude jets, p_dot and
  // p_ddot. Angles f = phi, t = theta, y = psi; 1 and 2 mark their rates and
  // accelerations.
  const double f = jet[0][0].v, f1 = jet[0][1].v;  // phi_ddot enters omega_dot linearly: no value needed
  const double t = jet[1][0].v, t1 = jet[1][1].v, t2 = jet[1][2].v;
  const double y = d(3, 0), y1 = d(3, 1), y2 = d(3, 2);
  const double sf = std::sin(f), cf = std::cos(f), st = std::sin(t), ct = std::cos(t), sy = std::sin(y), cy = std::cos(y);
  const Eigen::Vector3d P(d(0, 1), d(1, 1), d(2, 1)), A(d(0, 2), d(1, 2), d(2, 2));  // p_dot, p_ddot
  const Eigen::Vector3d R0(ct * cy, ct * sy, -st), R1(st * cy * sf - sy * cf, st * sy * sf + cy * cf, ct * sf),
      R2(st * cy * cf + sy * sf, st * sy * cf - cy * sf, ct * cf);  // rows of R(eta)^T
  const double p = f1 - st * y1, q = cf * t1 + ct * sf * y1, r = ct * cf * y1 - sf * t1;  // eq. (4)
  const double v0 = R0.dot(P), v1 = R1.dot(P);                                             // eq. (3)
  // Regressor (rows 7-10) backwards: adjoints of p, q, r, their rates, v_x, v_y, v_z_dot, g_bz.
  const double E = G(0, 0);  // of v_z_dot and g_bz
  const double gp = E * v1 - G(1, 2) * r + G(1, 3) * q + G(2, 1) * r - 2.0 * G(2, 3) * p - G(2, 5) * q -
                    G(2, 6) * r - G(3, 1) * q + 2.0 * G(3, 2) * p + G(3, 4) * q + G(3, 5) * r;
  const double gq = -E * v0 + G(1, 3) * p - G(1, 4) * r + 2.0 * G(1, 5) * q + G(1, 6) * r + G(2, 2) * r -
                    G(2, 5) * p - G(3, 1) * p - 2.0 * G(3, 2) * q - G(3, 3) * r + G(3, 4) * p;
  const double gr = -G(1, 2) * p - G(1, 4) * q - 2.0 * G(1, 5) * r + G(1, 6) * q + G(2, 1) * p + G(2, 2) * q +
                    2.0 * G(2, 3) * r - G(2, 6) * p - G(3, 3) * q + G(3, 5) * p;
  const double gpd = G(1, 1) + G(2, 2) + G(3, 3), gqd = G(1, 2) + G(2, 4) + G(3, 5), grd = G(1, 3) + G(2, 5) + G(3, 6);
  double gv0 = -E * q, gv1 = E * p;  // v_x, v_y in Phi(0, 0); v_z_dot's adjoint is E
  std::array<double, 9> gs{};        // ds / d(f, f1, f2, t, t1, t2, y, y1, y2)
  enum { F0, F1, F2, T0, T1, T2, Y0, Y1, Y2 };
  // omega = (p, q, r), eq. (4)
  gs[F1] += gp;
  gs[T0] += -gp * ct * y1;
  gs[Y1] += -gp * st;
  gs[F0] += gq * (-sf * t1 + ct * cf * y1) + gr * (-ct * sf * y1 - cf * t1);
  gs[T0] += gq * (-st * sf * y1) + gr * (-st * cf * y1);
  gs[T1] += gq * cf - gr * sf;
  gs[Y1] += gq * ct * sf + gr * ct * cf;
  // omega_dot, the time derivative of eq. (4)
  gs[F2] += gpd;
  gs[T0] += gpd * (st * t1 * y1 - ct * y2);
  gs[T1] += -gpd * ct * y1;
  gs[Y1] += -gpd * ct * t1;
  gs[Y2] += -gpd * st;
  gs[F0] += gqd * (-cf * f1 * t1 - sf * t2 - st * t1 * cf * y1 - ct * sf * f1 * y1 + ct * cf * y2) +
            grd * (st * t1 * sf * y1 - ct * cf * f1 * y1 - ct * sf * y2 + sf * f1 * t1 - cf * t2);
  gs[T0] += gqd * (-ct * t1 * sf * y1 - st * cf * f1 * y1 - st * sf * y2) +
            grd * (-ct * t1 * cf * y1 + st * sf * f1 * y1 - st * cf * y2);
  gs[F1] += gqd * (-sf * t1 + ct * cf * y1) + grd * (-ct * sf * y1 - cf * t1);
  gs[T1] += gqd * (-sf * f1 - st * sf * y1) + grd * (-st * cf * y1 - cf * f1);
  gs[T2] += gqd * cf - grd * sf;
  gs[Y1] += gqd * (-st * t1 * sf + ct * cf * f1) + grd * (-st * t1 * cf - ct * sf * f1);
  gs[Y2] += gqd * ct * sf + grd * ct * cf;
  // g_bz = g cos(theta) cos(phi)
  gs[F0] += -E * g * ct * sf;
  gs[T0] += -E * g * st * cf;
  // v_z_dot = d/dt (R2 . p_dot) = -v_y f1 + cos(phi) v_x t1 + u_y y1 + R2 . p_ddot, with
  // u_y = d(R2 . p_dot)/dpsi (dR2/dphi = -R1, dR2/dtheta = cos(phi) R0).
  const Eigen::Vector3d Ry(-st * sy * cf + cy * sf, st * cy * cf + sy * sf, 0.0);  // dR2/dpsi
  const double uy = Ry.dot(P);
  gs[F1] += -E * v1;
  gs[T1] += E * cf * v0;
  gs[Y1] += E * uy;
  gv1 += -E * f1;
  gv0 += E * cf * t1;
  gs[F0] += -E * sf * v0 * t1;
  // u_y y1: derivatives of dR2/dpsi . p_dot
  const Eigen::Vector3d Ryf(st * sy * sf + cy * cf, -st * cy * sf + sy * cf, 0.0), Ryt(-ct * sy * cf, ct * cy * cf, 0.0),
      Ryy(-st * cy * cf - sy * sf, -st * sy * cf + cy * sf, 0.0);
  gs[F0] += E * y1 * Ryf.dot(P);
  gs[T0] += E * y1 * Ryt.dot(P);
  gs[Y0] += E * y1 * Ryy.dot(P);
  // R2 . p_ddot
  gs[F0] += -E * R1.dot(A);
  gs[T0] += E * cf * R0.dot(A);
  gs[Y0] += E * Ry.dot(A);
  // v_x = R0 . p_dot, v_y = R1 . p_dot
  gs[T0] += gv0 * (-st * cy * P(0) - st * sy * P(1) - ct * P(2)) + gv1 * sf * v0;
  gs[Y0] += gv0 * (-ct * sy * P(0) + ct * cy * P(1)) + gv1 * ((-st * sy * sf - cy * cf) * P(0) + (st * cy * sf - sy * cf) * P(1));
  gs[F0] += gv1 * R2.dot(P);
  const Eigen::Vector3d gP = gv0 * R0 + gv1 * R1 + E * y1 * Ry, gA = E * R2;  // p_dot's and p_ddot's adjoints

  Eigen::Matrix<double, kInputs, 1> out = Eigen::Matrix<double, kInputs, 1>::Zero();
  // (1) backwards: q = (a, psi) at orders 0, 1, 2 of q (flat orders 2, 3, 4 of x, y, z; 0, 1, 2 of psi).
  auto at = [](int i, int n) { return i < 3 ? input_index(i, n + 2) : input_index(kPsi, n); };
  for (size_t a = 0; a < 2; ++a) {
    const double g0 = gs[3 * a], g1 = gs[3 * a + 1], g2 = gs[3 * a + 2];
    for (int i = 0; i < 4; ++i) {
      const auto ii = static_cast<size_t>(i);
      const double J0 = jet[a][0].d[ii], J1 = jet[a][1].d[ii], J2 = jet[a][2].d[ii];
      out(at(i, 0)) += g0 * J0 + g1 * J1 + g2 * J2;
      out(at(i, 1)) += g1 * J0 + 2.0 * g2 * J1;
      out(at(i, 2)) += g2 * J0;
    }
  }
  for (int n = 0; n < 3; ++n) out(input_index(kPsi, n)) += gs[static_cast<size_t>(Y0 + n)];
  for (int j = 0; j < 3; ++j) {
    out(input_index(j, 1)) += gP(j);
    out(input_index(j, 2)) += gA(j);
  }
  return out;
}

namespace {

// p, q and the rotors' thrust fractions of the reference (see VehicleLimits).
template <class S>
void vehicle_values(const Eigen::Matrix<S, 4, 5>& dd, double g, const VehicleLimits& v, S* out) {
  const ReferenceT<S> r = reference_from_flat<S>(dd, g);  // eqs. (26)-(27) and below eq. (20)
  out[0] = r.omega(0);
  out[1] = r.omega(1);
  if (v.mixer.rows() == 0) return;
  const Regressor<S> P = regressor<S>(r.v, r.omega, r.eta, r.v_dot, r.omega_dot, g);  // eq. (12)
  std::array<S, 4> w;  // [Fz tau_phi tau_theta tau_psi] = Phi Theta (eq. 11)
  for (int i = 0; i < 4; ++i) {
    w[static_cast<size_t>(i)] = S(0.0);
    for (int c = 0; c < 7; ++c) w[static_cast<size_t>(i)] = w[static_cast<size_t>(i)] + P(i, c) * v.theta(c);
  }
  for (Eigen::Index k = 0; k < v.mixer.rows(); ++k) {
    S t(0.0);
    for (int i = 0; i < 4; ++i) t = t + w[static_cast<size_t>(i)] * v.mixer(k, i);
    out[2 + k] = t;
  }
}

}  // namespace

Eigen::VectorXd vehicle_sample(const FlatOutput& d, double g, const VehicleLimits& v, Eigen::MatrixXd* jac) {
  const int n = v.size();
  Eigen::VectorXd out(n);
  if (!jac) {
    vehicle_values<double>(d, g, v, out.data());
    return out;
  }
  using D = Dual<kInputs>;
  Eigen::Matrix<D, 4, 5> dd;
  for (int i = 0; i < 4; ++i)
    for (int o = 0; o < 5; ++o) dd(i, o) = is_input(i, o) ? D::seed(d(i, o), input_index(i, o)) : D(d(i, o));
  std::vector<D> val(static_cast<size_t>(n));
  vehicle_values<D>(dd, g, v, val.data());
  jac->resize(n, kInputs);
  for (int k = 0; k < n; ++k) {
    out(k) = val[static_cast<size_t>(k)].v;
    for (int j = 0; j < kInputs; ++j) (*jac)(k, j) = val[static_cast<size_t>(k)].d[static_cast<size_t>(j)];
  }
  return out;
}

}  // namespace design_detail

namespace {

using Mat7 = Eigen::Matrix<double, 7, 7>;

// The criterion J of the information matrix M = sum Phi_k^T Phi_k (K samples)
// and, when H is non-null, the symmetric H with dJ/dPhi_k = Phi_k H for every k.
//   cond:  J = sqrt(l_max / l_min) of S M S;  d l_i = u_i^T dM u_i, so
//          dJ/dPhi_k = Phi_k S J (u_max u_max^T / l_max - u_min u_min^T / l_min) S.
//   dopt:  J = -(1/7) log det(S M S / K);  d log det M = tr(M^-1 dM), so
//          dJ/dPhi_k = -(2/7) Phi_k M^-1 (the scaling only adds a constant).
//   precision: r_i = [M^-1]_ii (K / samples) / s_i^2 (squared relative standard errors,
//          M weighted by the rows' noise), J = (sum_i r_i^p)^(1/(2p)); with
//          dr_i = -(K / samples) / s_i^2 (M^-1 e_i)^T dM (M^-1 e_i),
//          dJ/dPhi_k = -2 Phi_k M^-1 diag(w) M^-1, w_i = dJ/dr_i (K / samples) / s_i^2.
//          Computed with r / max r so that r^p neither underflows nor overflows.
double precision_of(const Mat7& M, int K, const Theta& s, double samples, Mat7* H, Theta* rel_std) {
  const Eigen::LDLT<Mat7> ldlt(M);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) {
    if (H) H->setZero();
    if (rel_std) rel_std->setConstant(kInf);
    return kInf;
  }
  const Mat7 Minv = ldlt.solve(Mat7::Identity());
  const double c = static_cast<double>(K) / samples;
  const Theta r = (Minv.diagonal() * c).cwiseQuotient(s.cwiseAbs2());
  if (rel_std) *rel_std = r.cwiseSqrt();
  const double rmax = r.maxCoeff();
  const double p = kPrecisionNorm;
  const Theta q = r / rmax;
  const double Sp = q.array().pow(p).sum();
  const double J = std::sqrt(rmax) * std::pow(Sp, 1.0 / (2.0 * p));
  if (H) {
    Theta w;
    for (int i = 0; i < 7; ++i) w(i) = J * std::pow(q(i), p - 1.0) / (2.0 * rmax * Sp) * c / (s(i) * s(i));
    *H = -2.0 * Minv * w.asDiagonal() * Minv;
  }
  return J;
}

double criterion_of(const Mat7& M, int K, Criterion crit, const Theta& s, Mat7* H, double samples = 0.0) {
  if (crit == Criterion::Precision) return precision_of(M, K, s, samples, H, nullptr);
  const Eigen::DiagonalMatrix<double, 7> S(crit == Criterion::Cond ? Theta::Ones() : s);
  const Mat7 Ms = S * M * S;
  if (crit == Criterion::DOpt) {
    const Eigen::LDLT<Mat7> ldlt(Ms / K);
    const Eigen::Matrix<double, 7, 1> dg = ldlt.vectorD();
    if (!(dg.minCoeff() > 0.0)) {
      if (H) H->setZero();
      return kInf;
    }
    if (H) *H = -(2.0 / 7.0) * M.inverse();
    return -dg.array().log().sum() / 7.0;
  }
  const Eigen::SelfAdjointEigenSolver<Mat7> es(Ms);
  const auto& l = es.eigenvalues();
  if (!(l(0) > 0.0)) {
    if (H) H->setZero();
    return kInf;
  }
  const double J = std::sqrt(l(6) / l(0));
  if (H) {
    const auto umax = es.eigenvectors().col(6), umin = es.eigenvectors().col(0);
    *H = S * (J * (umax * umax.transpose() / l(6) - umin * umin.transpose() / l(0))) * S;
  }
  return J;
}

}  // namespace

Eigen::VectorXd vehicle_limit_values(const Trajectory& traj, double t, const Constraints& c, double g) {
  const FlatOutput d = traj.eval(t);
  if (!(d(kZ, 2) + g > 0.0))
    throw std::invalid_argument(fmt::format("at t = {:g} s the reference falls faster than gravity (z_ddot = {:g} "
                                            "m/s^2): no thrust direction, eqs. (26)-(27)",
                                            t, d(kZ, 2)));
  return design_detail::vehicle_sample(d, g, design_detail::VehicleLimits(c), nullptr);
}

CriterionValues evaluate_criteria(const Trajectory& traj, double dt, double g, const Theta& scales,
                                  const RowNoise* noise, const Params* reference) {
  if (!(dt > 0.0)) throw std::invalid_argument(fmt::format("sampling period T = {} s must be positive", dt));
  if (noise && !reference) throw std::invalid_argument("evaluate_criteria: the precision criterion needs parameters");
  if (noise) noise->validate();
  Mat7 M = Mat7::Zero(), Mw = Mat7::Zero();
  const auto times = design_detail::periodic_grid(traj.period(), dt);
  for (double t : times) {
    const auto Phi = design_detail::regressor_sample(traj.eval(t), g, nullptr);
    M.noalias() += Phi.transpose() * Phi;  // W^T W of eq. (20), row block by row block
    if (noise) {
      const Eigen::Matrix<double, 4, 7> Pw = noise->sigma.cwiseInverse().asDiagonal() * Phi;
      Mw.noalias() += Pw.transpose() * Pw;
    }
  }
  CriterionValues v;
  v.samples = static_cast<int>(times.size());
  v.eigenvalues = Eigen::SelfAdjointEigenSolver<Mat7>(M, Eigen::EigenvaluesOnly).eigenvalues();
  v.cond = criterion_of(M, v.samples, Criterion::Cond, scales, nullptr);
  v.cond_scaled = criterion_of(M, v.samples, Criterion::CondScaled, scales, nullptr);
  v.dopt = criterion_of(M, v.samples, Criterion::DOpt, scales, nullptr);
  if (noise) {
    v.precision = precision_of(Mw, v.samples, determinedness_scale(reference->theta()), noise->samples, nullptr,
                               &v.relative_std);
    v.worst_relative_std = v.relative_std.maxCoeff();
  }
  return v;
}

ExcitationProblem::ExcitationProblem(const DesignOptions& opt, double grid_dt)
    : N_(opt.harmonics), wf_(opt.wf), g_(opt.g), crit_(opt.criterion),
      scales_(opt.criterion == Criterion::Precision ? determinedness_scale(opt.reference.theta())
                                                    : parameter_scales(opt.reference, opt.product_floor)),
      row_w_(opt.criterion == Criterion::Precision ? opt.row_noise.sigma.cwiseInverse().eval()
                                                   : Eigen::Vector4d::Ones()),
      samples_(opt.row_noise.samples),
      q0_{opt.limits.x0, opt.limits.y0, opt.limits.z0, opt.limits.psi0} {
  if (N_ < 1) throw std::invalid_argument(fmt::format("harmonics = {} must be at least 1", N_));
  if (!(wf_ > 0.0)) throw std::invalid_argument(fmt::format("wf = {} rad/s must be positive", wf_));
  if (!(grid_dt > 0.0)) throw std::invalid_argument(fmt::format("grid_dt = {} s must be positive", grid_dt));
  times_ = design_detail::periodic_grid(2.0 * M_PI / wf_, grid_dt);
  const auto K = static_cast<Eigen::Index>(times_.size());
  for (int o = 0; o < 5; ++o) {
    basis_[static_cast<size_t>(o)].resize(K, 2 * N_ + 1);
    for (Eigen::Index k = 0; k < K; ++k)
      basis_[static_cast<size_t>(o)].row(k) = FourierTrajectory::basis(wf_, N_, times_[static_cast<size_t>(k)], o);
  }
}

double ExcitationProblem::criterion(const Eigen::VectorXd& x, Eigen::VectorXd* grad) const {
  const int n1 = 2 * N_ + 1;
  const auto K = static_cast<Eigen::Index>(times_.size());
  // Flat derivatives at every sample: column 5 axis + order.
  Eigen::MatrixXd F(K, 20);
  for (int i = 0; i < 4; ++i)
    for (int o = 0; o < 5; ++o) F.col(5 * i + o) = basis_[static_cast<size_t>(o)] * x.segment(i * n1, n1);

  std::vector<Eigen::Matrix<double, 4, 7>> Phi(static_cast<size_t>(K));
  auto flat_at = [&](Eigen::Index k) {
    FlatOutput d;
    for (int i = 0; i < 4; ++i)
      for (int o = 0; o < 5; ++o) d(i, o) = F(k, 5 * i + o);
    return d;
  };
  Mat7 M = Mat7::Zero();
  for (Eigen::Index k = 0; k < K; ++k) {
    auto& P = Phi[static_cast<size_t>(k)];
    P = design_detail::regressor_sample(flat_at(k), g_, nullptr);
    if (crit_ == Criterion::Precision) P = row_w_.asDiagonal() * P;  // rows weighted by 1 / sigma
    M.noalias() += P.transpose() * P;
  }
  Mat7 H;
  const double J = criterion_of(M, static_cast<int>(K), crit_, scales_, grad ? &H : nullptr, samples_);
  if (!grad) return J;

  // dJ/du_k = dPhi_k/du^T vec(Phi_k H) (the rows' weights folded into G), then
  // through the linear basis to the coefficients.
  Eigen::MatrixXd dJdu(K, kInputs);
  for (Eigen::Index k = 0; k < K; ++k) {
    Eigen::Matrix<double, 4, 7> G = Phi[static_cast<size_t>(k)] * H;
    if (crit_ == Criterion::Precision) G = row_w_.asDiagonal() * G;
    dJdu.row(k) = design_detail::regressor_vjp(flat_at(k), g_, G).transpose();
  }
  grad->setZero(dimension());
  for (int i = 0; i < 4; ++i)
    for (int o = 0; o < 5; ++o)
      if (design_detail::is_input(i, o))
        grad->segment(i * n1, n1).noalias() +=
            basis_[static_cast<size_t>(o)].transpose() * dJdu.col(design_detail::input_index(i, o));
  return J;
}

Eigen::MatrixXd ExcitationProblem::tilt(const Eigen::VectorXd& x, Eigen::MatrixXd* jac) const {
  const int n1 = 2 * N_ + 1;
  const auto K = static_cast<Eigen::Index>(times_.size());
  const Eigen::VectorXd ax = basis_[2] * x.segment(0, n1), ay = basis_[2] * x.segment(n1, n1),
                        az = basis_[2] * x.segment(2 * n1, n1), psi = basis_[0] * x.segment(3 * n1, n1);
  Eigen::MatrixXd out(2, K);
  if (jac) jac->setZero(2 * K, dimension());
  for (Eigen::Index k = 0; k < K; ++k) {
    const auto p = design_detail::tilt_point(ax(k), ay(k), az(k), psi(k), g_);
    out(0, k) = p.phi;
    out(1, k) = p.theta;
    if (!jac) continue;
    for (int r = 0; r < 2; ++r) {
      const Eigen::Vector4d& dv = r == 0 ? p.dphi : p.dtheta;
      for (int i = 0; i < 3; ++i) jac->block(2 * k + r, i * n1, 1, n1) = dv(i) * basis_[2].row(k);
      jac->block(2 * k + r, 3 * n1, 1, n1) = dv(3) * basis_[0].row(k);
    }
  }
  return out;
}

Eigen::MatrixXd ExcitationProblem::vehicle_limits(const Eigen::VectorXd& x, const Constraints& c,
                                                  Eigen::MatrixXd* jac) const {
  const int n1 = 2 * N_ + 1;
  const auto K = static_cast<Eigen::Index>(times_.size());
  const design_detail::VehicleLimits v(c);
  Eigen::MatrixXd out(v.size(), K);
  if (jac) jac->setZero(v.size() * K, dimension());
  Eigen::MatrixXd dv;
  for (Eigen::Index k = 0; k < K; ++k) {
    FlatOutput d;
    for (int i = 0; i < 4; ++i)
      for (int o = 0; o < 5; ++o) d(i, o) = basis_[static_cast<size_t>(o)].row(k).dot(x.segment(i * n1, n1));
    out.col(k) = design_detail::vehicle_sample(d, g_, v, jac ? &dv : nullptr);
    if (!jac) continue;
    for (int r = 0; r < v.size(); ++r)
      for (int i = 0; i < 4; ++i)
        for (int o = 0; o < 5; ++o)
          if (design_detail::is_input(i, o))
            jac->block(r * K + k, i * n1, 1, n1) +=
                dv(r, design_detail::input_index(i, o)) * basis_[static_cast<size_t>(o)].row(k);
  }
  return out;
}

void ExcitationProblem::start_conditions(Eigen::MatrixXd& A, Eigen::VectorXd& b) const {
  const int n1 = 2 * N_ + 1;
  A.setZero(12, dimension());
  b.setZero(12);
  for (int i = 0; i < 4; ++i) {
    for (int o = 0; o < 3; ++o) A.block(3 * i + o, i * n1, 1, n1) = FourierTrajectory::basis(wf_, N_, 0.0, o);
    b(3 * i) = q0_[static_cast<size_t>(i)];
  }
}

}  // namespace quadid
