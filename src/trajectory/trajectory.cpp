#include "quadid/trajectory.hpp"

#include <fmt/format.h>
#include <stdexcept>

namespace quadid {

FourierTrajectory::FourierTrajectory(double wf, std::array<AxisCoeffs, 4> axes)
    : wf_(wf), axes_(std::move(axes)) {
  if (!(wf_ > 0.0) || !std::isfinite(wf_))
    throw std::invalid_argument(fmt::format("fundamental frequency wf = {} rad/s must be positive", wf_));
  const auto n = axes_[0].a.size();
  if (n < 1) throw std::invalid_argument("a Fourier trajectory needs at least one harmonic");
  for (int i = 0; i < 4; ++i) {
    const auto& ax = axes_[static_cast<size_t>(i)];
    if (ax.a.size() != n || ax.b.size() != n)
      throw std::invalid_argument(fmt::format(
          "axis {}: coefficient arrays a and b must both have {} entries (got {} and {})",
          kAxisNames[static_cast<size_t>(i)], n, ax.a.size(), ax.b.size()));
    if (!ax.a.allFinite() || !ax.b.allFinite() || !std::isfinite(ax.c))
      throw std::invalid_argument(
          fmt::format("axis {}: coefficients must be finite", kAxisNames[static_cast<size_t>(i)]));
  }
}

Eigen::RowVectorXd FourierTrajectory::basis(double wf, int N, double t, int order) {
  Eigen::RowVectorXd B = Eigen::RowVectorXd::Zero(2 * N + 1);
  const double shift = order * M_PI / 2.0;
  for (int l = 1; l <= N; ++l) {
    const double wl = wf * l;
    const double th = wl * t + shift;
    const double scale = std::pow(wl, order - 1);  // (wf l)^(n-1), eq. (18) and its derivatives
    B(l - 1) = scale * std::sin(th);
    B(N + l - 1) = -scale * std::cos(th);
  }
  B(2 * N) = order == 0 ? 1.0 : 0.0;
  return B;
}

FlatOutput FourierTrajectory::eval(double t) const {
  FlatOutput d = FlatOutput::Zero();
  const int N = harmonics();
  for (int l = 1; l <= N; ++l) {
    const double wl = wf_ * l;
    const double s = std::sin(wl * t), c = std::cos(wl * t);
    // sin(th + n pi/2) cycles s, c, -s, -c; cos(th + n pi/2) cycles c, -s, -c, s.
    const double sn[4] = {s, c, -s, -c};
    const double cn[4] = {c, -s, -c, s};
    for (int i = 0; i < 4; ++i) {
      const double a = axes_[static_cast<size_t>(i)].a(l - 1);
      const double b = axes_[static_cast<size_t>(i)].b(l - 1);
      double scale = 1.0 / wl;
      for (int n = 0; n <= 4; ++n) {
        const double term = scale * (a * sn[n % 4] - b * cn[n % 4]);
        d(i, n) += term;
        scale *= wl;
      }
    }
  }
  for (int i = 0; i < 4; ++i) d(i, 0) += axes_[static_cast<size_t>(i)].c;
  return d;
}

std::string FourierTrajectory::describe() const {
  return fmt::format("fourier N={} wf={:.6g} rad/s (period {:.6g} s)", harmonics(), wf_, period());
}

double FourierTrajectory::period() const { return 2.0 * M_PI / wf_; }

Eigen::VectorXd FourierTrajectory::coefficients() const {
  const int N = harmonics();
  Eigen::VectorXd c(4 * (2 * N + 1));
  for (int i = 0; i < 4; ++i) {
    const auto& ax = axes_[static_cast<size_t>(i)];
    c.segment(i * (2 * N + 1), N) = ax.a;
    c.segment(i * (2 * N + 1) + N, N) = ax.b;
    c(i * (2 * N + 1) + 2 * N) = ax.c;
  }
  return c;
}

FourierTrajectory FourierTrajectory::from_coefficients(double wf, int N, const Eigen::VectorXd& c) {
  if (N < 1) throw std::invalid_argument(fmt::format("harmonics = {} must be at least 1", N));
  if (c.size() != 4 * (2 * N + 1))
    throw std::invalid_argument(fmt::format("expected {} Fourier coefficients for N = {}, got {}",
                                            4 * (2 * N + 1), N, c.size()));
  std::array<AxisCoeffs, 4> axes;
  for (int i = 0; i < 4; ++i) {
    auto& ax = axes[static_cast<size_t>(i)];
    ax.a = c.segment(i * (2 * N + 1), N);
    ax.b = c.segment(i * (2 * N + 1) + N, N);
    ax.c = c(i * (2 * N + 1) + 2 * N);
  }
  return FourierTrajectory(wf, std::move(axes));
}

FourierTrajectory FourierTrajectory::table2() {
  // Table 2 of the paper; wf = 36 deg/s (period 10 s), N = 5.
  auto axis = [](std::array<double, 5> a, std::array<double, 5> b, double c) {
    AxisCoeffs ax;
    ax.a = Eigen::Map<const Eigen::VectorXd>(a.data(), 5);
    ax.b = Eigen::Map<const Eigen::VectorXd>(b.data(), 5);
    ax.c = c;
    return ax;
  };
  std::array<AxisCoeffs, 4> axes = {
      axis({-0.1000, -0.0386, -0.0828, -0.0698, 0.2911}, {-0.0712, 0.0290, 0.0218, 0.0249, -0.0304}, -0.0784),
      axis({-0.0163, 0.0418, -0.0079, 0.0147, -0.0322}, {0.2112, 0.0830, 0.0954, 0.1418, -0.2462}, 0.4310),
      axis({-0.0338, -0.1039, 0.2224, -0.0738, -0.0108}, {0.0833, 0.0414, 0.2020, -0.1457, -0.0379}, 0.9026),
      axis({0.1959, 0.1709, -0.0586, -0.2600, -0.0483}, {0.1136, -0.2140, 0.1724, -0.0428, -0.0063}, 0.0830)};
  return FourierTrajectory(36.0 * M_PI / 180.0, std::move(axes));
}

CircleTrajectory::CircleTrajectory(double radius, double rho, double period, double psi_amplitude)
    : radius_(radius), rho_(rho), period_(period), psi_amp_(psi_amplitude) {
  if (!(radius >= 0.0) || !std::isfinite(radius))
    throw std::invalid_argument(fmt::format("circle radius = {} m must be non-negative", radius));
  if (!(rho > 0.0) || !std::isfinite(rho))
    throw std::invalid_argument(fmt::format("circle altitude rho = {} m must be positive", rho));
  if (!(period > 0.0) || !std::isfinite(period))
    throw std::invalid_argument(fmt::format("circle period = {} s must be positive", period));
}

CircleTrajectory CircleTrajectory::experiment(int k) {
  switch (k) {  // section IV-C
    case 1: return CircleTrajectory(0.5, 1.0);
    case 2: return CircleTrajectory(0.8, 0.9);
    case 3: return CircleTrajectory(1.0, 1.0);
    default: throw std::invalid_argument(fmt::format("circle experiment {} does not exist (1, 2 or 3)", k));
  }
}

FlatOutput CircleTrajectory::eval(double t) const {
  FlatOutput d;
  const double W = 2.0 * M_PI / period_;
  double wn = 1.0;
  for (int n = 0; n <= 4; ++n) {  // eq. (44); d^n/dt^n cos(Wt) = W^n cos(Wt + n pi/2)
    const double ph = W * t + n * M_PI / 2.0;
    d(kX, n) = radius_ * wn * std::cos(ph);
    d(kY, n) = radius_ * wn * std::sin(ph);
    d(kPsi, n) = psi_amp_ * wn * std::sin(ph);
    d(kZ, n) = 0.1 * wn * std::sin(ph);
    wn *= W;
  }
  if (t >= 5.0) {
    d(kZ, 0) += rho_;
  } else {
    // z = rho - (rho - 0.3) e^u with u = -0.1 t^3; derivatives of e^u by Faa di Bruno.
    const double u1 = -0.3 * t * t, u2 = -0.6 * t, u3 = -0.6;
    const double e = std::exp(-0.1 * t * t * t);
    const double k = -(rho_ - 0.3);
    d(kZ, 0) = rho_ + k * e;
    d(kZ, 1) = k * e * u1;
    d(kZ, 2) = k * e * (u2 + u1 * u1);
    d(kZ, 3) = k * e * (u3 + 3.0 * u1 * u2 + u1 * u1 * u1);
    d(kZ, 4) = k * e * (4.0 * u1 * u3 + 3.0 * u2 * u2 + 6.0 * u1 * u1 * u2 + u1 * u1 * u1 * u1);
  }
  return d;
}

std::string CircleTrajectory::describe() const {
  return fmt::format("circle radius {:.3g} m, altitude {:.3g} m, period {:.3g} s", radius_, rho_, period_);
}

std::unique_ptr<Trajectory> builtin_trajectory(std::string_view name) {
  if (name == "table2") return std::make_unique<FourierTrajectory>(FourierTrajectory::table2());
  if (name == "circle1") return std::make_unique<CircleTrajectory>(CircleTrajectory::experiment(1));
  if (name == "circle2") return std::make_unique<CircleTrajectory>(CircleTrajectory::experiment(2));
  if (name == "circle3") return std::make_unique<CircleTrajectory>(CircleTrajectory::experiment(3));
  return nullptr;
}

std::vector<std::string> builtin_trajectory_names() { return {"table2", "circle1", "circle2", "circle3"}; }

Reference reference_at(const Trajectory& traj, double t, double g) {
  return reference_from_flat<double>(traj.eval(t), g);
}

}  // namespace quadid
