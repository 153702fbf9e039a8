// Excitation-trajectory optimizer (paper section II-B2, eq. 21 with the
// limits of eqs. 22-27): NLopt SLSQP, the analogue of the paper's fmincon,
// over the Fourier coefficients of eq. (18), from random starts.
//
// Choices (docs/design.md explains them):
// - The 12 start conditions are linear equalities A x = b; the search runs in
//   their null space x = x_h + Z y (x_h the hover, Z orthonormal), so every
//   iterate meets them to rounding and SLSQP sees 32 instead of 44 variables.
// - The semi-infinite limits are imposed on the fine check grid (check_dt)
//   itself, aggregated per cell of cell_dt: one constraint per limit, sign and
//   cell, the largest value over the cell (see Round). A result that meets
//   them passes the final check by construction; a small relative margin
//   absorbs SLSQP's constraint tolerance. A start that ends infeasible is
//   re-polished from its last point (refine_rounds).
// - The criterion is sampled every grid_dt: the periodic rectangle rule of
//   eq. (20) converges spectrally, so 100 ms gives the 2 ms value to ~1e-15.
// - Starts are drawn in sequence from one seeded std::mt19937_64 before any
//   thread runs, and each start is deterministic, so the result does not
//   depend on the number of threads.
#include "design_internal.hpp"
#include "quadid/core.hpp"
#include "quadid/core/parallel.hpp"

#include <Eigen/QR>
#include <fmt/format.h>
#include <nlopt.hpp>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <random>
#include <stdexcept>

namespace quadid {

using design_detail::Family;

// SQP iterates meet active constraints only in the limit: a point counts as
// feasible for a round when every normalized constraint is below its margin
// (1e-4 relative by default, fading to 0 where a limit is pinned) and below
// this where the margin is smaller.
constexpr double kFeasTol = 1e-9;
// Spacing of the coarse search for each cell's worst instant, s. Every limit
// is a smooth function whose fastest part is the N-th harmonic (period 2 s for
// the paper's problem), so on this scale a fine-grid maximum lies next to a
// coarse local maximum; it is then found exactly on the fine grid.
constexpr double kCoarseDt = 0.01;
// Beyond this multiple of the tilt limit a cell is searched on the whole fine grid.
constexpr double kExhaustiveTilt = 2.0;

void DesignOptions::validate() const {
  auto require = [](bool ok, const std::string& msg) {
    if (!ok) throw std::invalid_argument(msg);
  };
  // Names are quadid design's options (CLI spelling); --wf is in deg/s there.
  limits.validate();
  require(harmonics >= 1, fmt::format("--harmonics = {} must be at least 1", harmonics));
  require(harmonics >= 2, fmt::format("--harmonics = {} leaves no freedom: the 12 start conditions fix all "
                                      "3 coefficients per axis; use 2 to 50", harmonics));
  require(harmonics <= 50, fmt::format("--harmonics = {} is too many (2 to 50)", harmonics));
  require(std::isfinite(wf) && wf >= 2.0 * M_PI / kMaxPeriod && wf <= 2.0 * M_PI / kMinPeriod,
          fmt::format("--wf = {:g} deg/s must be in [{:g}, {:g}] deg/s (a period of {:g} to {:g} s)", wf / kDeg,
                      360.0 / kMaxPeriod, 360.0 / kMinPeriod, kMinPeriod, kMaxPeriod));
  require(starts >= 1 && starts <= 10000, fmt::format("--starts = {} must be in [1, 10000]", starts));
  require(threads >= 0 && threads <= 1024, fmt::format("--threads = {} must be in [0, 1024] (0 = automatic)", threads));
  const double period = 2.0 * M_PI / wf;
  const double resolve = period / (8.0 * harmonics);  // 8 points per period of the highest harmonic
  require(std::isfinite(grid_dt) && grid_dt >= CheckOptions::kMinStep && grid_dt <= resolve,
          fmt::format("grid_dt = {:g} s must be in [{:g}, {:g}] s (the upper bound resolves the highest harmonic)",
                      grid_dt, CheckOptions::kMinStep, resolve));
  require(std::isfinite(check_dt) && check_dt >= CheckOptions::kMinStep && check_dt <= resolve,
          fmt::format("--check-dt = {:g} s must be in [{:g}, {:g}] s (the upper bound resolves the highest harmonic)",
                      check_dt, CheckOptions::kMinStep, resolve));
  require(std::isfinite(cell_dt) && cell_dt >= check_dt && cell_dt <= period / 4.0,
          fmt::format("cell_dt = {:g} s must be between --check-dt = {:g} s and a quarter period", cell_dt, check_dt));
  require(std::isfinite(cond_dt) && cond_dt >= CheckOptions::kMinStep && cond_dt <= resolve,
          fmt::format("--cond-dt = {:g} s must be in [{:g}, {:g}] s (the upper bound resolves the highest harmonic)",
                      cond_dt, CheckOptions::kMinStep, resolve));
  require(std::isfinite(margin) && margin >= 1e-8 && margin < 0.1,
          fmt::format("margin = {:g} must be in [1e-8, 0.1)", margin));
  require(max_evals >= 1 && max_evals <= 1000000, fmt::format("--max-evals = {} must be in [1, 1e6]", max_evals));
  require(refine_rounds >= 0, fmt::format("refine_rounds = {} must be >= 0", refine_rounds));
  require(std::isfinite(ftol_rel) && ftol_rel > 0.0, fmt::format("ftol_rel = {:g} must be positive", ftol_rel));
  require(std::isfinite(start_fill) && start_fill > 0.0 && start_fill <= 1.0,
          fmt::format("start_fill = {:g} must be in (0, 1]", start_fill));
  require(std::isfinite(g) && g > 0.0, fmt::format("--g = {:g} m/s^2 must be positive", g));
  require(std::isfinite(product_floor) && product_floor > 0.0,
          fmt::format("product_floor = {:g} must be positive", product_floor));
  reference.validate("reference parameters (--reference)");
  if (criterion == Criterion::Precision) row_noise.validate();
}

namespace {

// What every start shares (read-only once built).
struct Setup {
  const DesignOptions& opt;
  ExcitationProblem problem;  // the criterion on grid_dt
  std::vector<Family> fams;
  int n = 0, n1 = 0, ny = 0;
  double period = 0.0;
  Eigen::VectorXd xh;  // hover: a = b = 0, c = q0; meets the start conditions
  Eigen::MatrixXd Z;   // orthonormal null space of the start conditions
  std::vector<double> fine_t;                 // the check grid, 0..period
  std::array<Eigen::MatrixXd, 5> fine_basis;  // orders 0..2 on the fine grid (0..4 with vehicle limits)
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  std::array<RowMajor, 5> fine_rows;          // the same, row-major: one instant's row is contiguous
  std::vector<Eigen::Index> cell_begin;       // cells of the fine grid (last entry = end)
  std::vector<Eigen::VectorXd> bound;         // per family and fine instant: the tightened limit
  // Coarse search grid: every `stride`-th fine instant of each cell and the
  // cell's last instant; a cell's maximum is searched there first, then on
  // the fine grid around each coarse local maximum (see Round::constraints).
  Eigen::Index stride = 1;
  std::vector<Eigen::Index> coarse_k;         // fine indices of the coarse instants, cell by cell
  std::vector<size_t> cell_coarse;            // per cell: its first entry in coarse_k (last entry = end)
  std::array<Eigen::MatrixXd, 5> coarse_basis;  // rows of fine_basis at coarse_k
  bool has_tilt = false, has_vehicle = false;
  design_detail::VehicleLimits vlim;
  int orders = 3;  // basis orders kept: 0..2, or 0..4 for the vehicle limits

  explicit Setup(const DesignOptions& o)
      : opt(o), problem(o, o.grid_dt), fams(design_detail::families(o.limits)), vlim(o.limits) {
    for (const auto& f : fams) has_vehicle = has_vehicle || f.vehicle;
    orders = has_vehicle ? 5 : 3;
    n1 = 2 * o.harmonics + 1;
    n = 4 * n1;
    period = 2.0 * M_PI / o.wf;
    Eigen::MatrixXd A;
    Eigen::VectorXd b;
    problem.start_conditions(A, b);
    xh = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < 4; ++i) xh(i * n1 + n1 - 1) = b(3 * i);
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A.transpose());
    const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, n);
    ny = n - 12;
    Z = Q.rightCols(ny);
    fine_t = design_detail::closed_grid(period, o.check_dt);
    const auto K = static_cast<Eigen::Index>(fine_t.size());
    for (int ord = 0; ord < orders; ++ord) {
      fine_basis[static_cast<size_t>(ord)] = basis_at(fine_t, ord);
      fine_rows[static_cast<size_t>(ord)] = fine_basis[static_cast<size_t>(ord)];
    }
    const auto per_cell = std::max<Eigen::Index>(1, std::lround(o.cell_dt / o.check_dt));
    for (Eigen::Index k = 0; k < K; k += per_cell) cell_begin.push_back(k);
    if (K - cell_begin.back() < per_cell / 2 && cell_begin.size() > 1) cell_begin.pop_back();  // no tiny last cell
    cell_begin.push_back(K);
    stride = std::max<Eigen::Index>(1, std::lround(kCoarseDt / o.check_dt));
    for (int c = 0; c < cells(); ++c) {
      cell_coarse.push_back(coarse_k.size());
      const Eigen::Index b0 = cell_begin[static_cast<size_t>(c)], b1 = cell_begin[static_cast<size_t>(c) + 1];
      for (Eigen::Index k = b0; k < b1; k += stride) coarse_k.push_back(k);
      if (coarse_k.back() != b1 - 1) coarse_k.push_back(b1 - 1);
    }
    cell_coarse.push_back(coarse_k.size());
    for (size_t ord = 0; ord < static_cast<size_t>(orders); ++ord) {
      coarse_basis[ord].resize(static_cast<Eigen::Index>(coarse_k.size()), n1);
      for (size_t j = 0; j < coarse_k.size(); ++j)
        coarse_basis[ord].row(static_cast<Eigen::Index>(j)) = fine_basis[ord].row(coarse_k[j]);
    }
    for (const auto& f : fams) {
      has_tilt = has_tilt || f.tilt;
      Eigen::VectorXd bd(K);
      for (Eigen::Index k = 0; k < K; ++k) {
        const double m = margin_at(f, fine_t[static_cast<size_t>(k)]);
        bd(k) = f.kind == Family::Min ? f.limit + m : f.limit - m;
      }
      bound.push_back(bd);
    }
  }

  int cells() const { return static_cast<int>(cell_begin.size()) - 1; }

  Eigen::MatrixXd basis_at(const std::vector<double>& t, int order) const {
    Eigen::MatrixXd B(static_cast<Eigen::Index>(t.size()), n1);
    for (size_t k = 0; k < t.size(); ++k)
      B.row(static_cast<Eigen::Index>(k)) = FourierTrajectory::basis(opt.wf, opt.harmonics, t[k], order);
    return B;
  }

  // Margin of one instant. Where the limit equals the start value (z_min =
  // z0 = 0.7 m) the trajectory touches it at t = 0, so the tightening fades
  // out towards both ends of the period.
  double margin_at(const Family& f, double t) const {
    const double m = opt.margin * f.scale;
    if (!f.pinned) return m;
    const double tau = 0.1 * period, dist = std::min(t, period - t);
    return m * std::min(1.0, std::pow(dist / tau, 4));
  }

  // Every family's value at the instants whose basis rows B(order) gives
  // (columns = families; only column `only` is filled when it is >= 0).
  // Always a matrix-vector product over the rows, so a value does not depend
  // on which other instants are evaluated with it.
  template <class Basis>
  Eigen::MatrixXd values_on(const Basis& B, const Eigen::VectorXd& x, int only = -1) const {
    const Eigen::Index K = B(0).rows();
    Eigen::MatrixXd V(K, static_cast<Eigen::Index>(fams.size()));
    const bool tilt_wanted = only < 0 ? has_tilt : fams[static_cast<size_t>(only)].tilt;
    Eigen::VectorXd phi, theta;
    if (tilt_wanted) {
      const Eigen::VectorXd ax = B(2) * x.segment(0, n1), ay = B(2) * x.segment(n1, n1),
                            az = B(2) * x.segment(2 * n1, n1), psi = B(0) * x.segment(3 * n1, n1);
      phi.resize(K);
      theta.resize(K);
      for (Eigen::Index k = 0; k < K; ++k) {
        if (az(k) + opt.g > 0.0) {
          const auto a = design_detail::tilt_angles(ax(k), ay(k), az(k), psi(k), opt.g);
          phi(k) = a[0];
          theta(k) = a[1];
        } else {  // no upward thrust (kNoThrustTilt)
          phi(k) = theta(k) = kNoThrustTilt;
        }
      }
    }
    const bool vehicle_wanted = only < 0 ? has_vehicle : fams[static_cast<size_t>(only)].vehicle;
    Eigen::MatrixXd VV;  // vehicle_sample() at every row (rows x vlim.size())
    if (vehicle_wanted) {
      Eigen::MatrixXd F(K, 20);  // flat output derivatives, column 5 axis + order
      for (int i = 0; i < 4; ++i)
        for (int ord = 0; ord < 5; ++ord) F.col(5 * i + ord).noalias() = B(ord) * x.segment(i * n1, n1);
      VV.resize(K, vlim.size());
      for (Eigen::Index k = 0; k < K; ++k) {
        FlatOutput d;
        for (int i = 0; i < 4; ++i)
          for (int ord = 0; ord < 5; ++ord) d(i, ord) = F(k, 5 * i + ord);
        if (d(kZ, 2) + opt.g > 0.0)
          VV.row(k) = design_detail::vehicle_sample(d, opt.g, vlim, nullptr).transpose();
        else  // no upward thrust (no_thrust_vehicle_value)
          for (Eigen::Index j = 0; j < VV.cols(); ++j)
            VV(k, j) = no_thrust_vehicle_value(j);
      }
    }
    for (size_t f = 0; f < fams.size(); ++f) {
      if (only >= 0 && static_cast<int>(f) != only) continue;
      const Family& fam = fams[f];
      const auto c = static_cast<Eigen::Index>(f);
      if (fam.tilt)
        V.col(c) = fam.axis == 0 ? phi : theta;
      else if (fam.vehicle)
        V.col(c) = VV.col(fam.axis);
      else
        V.col(c).noalias() = B(fam.order) * x.segment(fam.axis * n1, n1);
    }
    return V;
  }

  // Where the reference has no upward thrust (z_ddot <= -g) eqs. (26)-(27) are
  // undefined: the tilt counts as 90 deg, the rotors as pulling (rotor_min
  // violated) and the rates as 10x their limit.
  static constexpr double kNoThrustTilt = M_PI / 2;
  double no_thrust_vehicle_value(Eigen::Index j) const {
    return j >= 2 ? -1.0 : std::isfinite(opt.limits.rate_max) ? 10.0 * opt.limits.rate_max : 0.0;
  }

  // Values at single fine instants, cached for one evaluation of the
  // constraints (both signs of a limit and neighbouring cells search the same
  // instants). Each is bit for bit what values_on gives for that row: the same
  // multiply-adds in the same order as a row of Eigen's column-major product
  // (accumulated from 0 over the columns), then the same tilt or vehicle map.
  struct FineCache {
    std::vector<double> val;      // family-major: f K + k
    std::vector<unsigned> stamp;  // the evaluation that filled val
    unsigned now = 0;
  };
  void start_evaluation(FineCache& c) const {
    const size_t size = fams.size() * fine_t.size();
    if (c.val.size() != size) {
      c.val.assign(size, 0.0);
      c.stamp.assign(size, 0);
      c.now = 0;
    }
    if (++c.now == 0) {  // wrapped: forget everything
      std::fill(c.stamp.begin(), c.stamp.end(), 0u);
      c.now = 1;
    }
  }
  double row_dot(int order, Eigen::Index k, const Eigen::VectorXd& x, int axis) const {
    const double* b = fine_rows[static_cast<size_t>(order)].row(k).data();
    const double* xs = x.data() + axis * n1;
    double acc = 0.0;
    for (int j = 0; j < n1; ++j) acc += b[j] * xs[j];
    return acc;
  }
  double fine_value(int f, Eigen::Index k, const Eigen::VectorXd& x, FineCache& c) const {
    const auto K = fine_t.size();
    const size_t at = static_cast<size_t>(f) * K + static_cast<size_t>(k);
    if (c.stamp[at] == c.now) return c.val[at];
    const Family& fam = fams[static_cast<size_t>(f)];
    auto store = [&](size_t g, double v) {
      const size_t i = g * K + static_cast<size_t>(k);
      c.val[i] = v;
      c.stamp[i] = c.now;
    };
    if (fam.tilt) {  // both angles at once
      const double ax = row_dot(2, k, x, 0), ay = row_dot(2, k, x, 1), az = row_dot(2, k, x, 2),
                   psi = row_dot(0, k, x, 3);
      std::array<double, 2> a{kNoThrustTilt, kNoThrustTilt};
      if (az + opt.g > 0.0) a = design_detail::tilt_angles(ax, ay, az, psi, opt.g);
      for (size_t g = 0; g < fams.size(); ++g)
        if (fams[g].tilt) store(g, a[static_cast<size_t>(fams[g].axis)]);
    } else if (fam.vehicle) {  // every vehicle limit at once
      FlatOutput d;
      for (int i = 0; i < 4; ++i)
        for (int ord = 0; ord < 5; ++ord) d(i, ord) = row_dot(ord, k, x, i);
      Eigen::VectorXd vv(vlim.size());
      if (d(kZ, 2) + opt.g > 0.0)
        vv = design_detail::vehicle_sample(d, opt.g, vlim, nullptr);
      else
        for (Eigen::Index j = 0; j < vv.size(); ++j) vv(j) = no_thrust_vehicle_value(j);
      for (size_t g = 0; g < fams.size(); ++g)
        if (fams[g].vehicle) store(g, vv(fams[g].axis));
    } else {
      store(static_cast<size_t>(f), row_dot(fam.order, k, x, fam.axis));
    }
    return c.val[at];
  }

  // Every family's value at every fine instant.
  Eigen::MatrixXd fine_values(const Eigen::VectorXd& x) const {
    return values_on([&](int o) -> const Eigen::MatrixXd& { return fine_basis[static_cast<size_t>(o)]; }, x);
  }
  // Every family's value at the coarse search instants.
  Eigen::MatrixXd coarse_values(const Eigen::VectorXd& x) const {
    return values_on([&](int o) -> const Eigen::MatrixXd& { return coarse_basis[static_cast<size_t>(o)]; }, x);
  }

  // Largest relative excess over the (untightened) limits on the fine grid; 0 when all hold.
  double worst_violation(const Eigen::VectorXd& x) const {
    const Eigen::MatrixXd V = fine_values(x);
    double worst = 0.0;
    for (size_t f = 0; f < fams.size(); ++f) {
      const double tolf = design_detail::kCheckRoundoff * std::max(1.0, std::abs(fams[f].limit));
      for (Eigen::Index k = 0; k < V.rows(); ++k) {
        const double e = design_detail::excess(fams[f], V(k, static_cast<Eigen::Index>(f)));
        if (e > tolf) worst = std::max(worst, e / fams[f].scale);
      }
    }
    return worst;
  }
};

// One SLSQP round. Each limit, sign and cell of the check grid gives one
// constraint: the largest c = (sigma f - bound) / scale over the cell's fine
// instants, with the gradient at that instant. Meeting them is meeting the
// final check on the fine grid. The maximum is continuous in x; its gradient
// jumps only when the worst instant of a cell jumps, which for cells much
// shorter than the fastest harmonic happens only at cell boundaries.
// A cell whose worst instant is its first one, with the previous cell still
// rising towards it, repeats its neighbour's constraint: it is replaced by
// its value at its centre, which keeps the constraints well separated.
//
// The cell's worst instant is found without evaluating every fine instant:
// on a coarse grid (kCoarseDt) first, then on the fine grid between the
// coarse neighbours of every coarse local maximum of the cell, which is
// where the fine-grid maximum of a smooth function lies.
//
// Stopping is ours: NLopt 2.7's SLSQP may stop on ftol at an infeasible
// iterate, so its ftol/xtol are off. Every evaluated point whose constraints
// all hold to the margin (the untightened limits hold at every cell's worst
// instant) is a candidate; the round stops when the best feasible criterion
// has not improved by ftol_rel for `patience` evaluations. The round's point
// is then checked on the whole fine grid (worst_violation), and re-polished
// when a limit fails there. SLSQP's iterates near the optimum sit within the
// tightening, between half and all of it above the tightened limits: asking
// for half the margin, as before, left 4 of seed 1's 8 starts with no
// candidate in their first round, and 3 of them re-polished (1961 of the
// 3343 evaluations).
struct Round {
  const Setup& s;
  unsigned m = 0;
  nlopt::opt* solver = nullptr;
  int evals = 0;
  double f_last = kInf;  // criterion at the point last evaluated
  double best_f = kInf, anchor_f = kInf;
  Eigen::VectorXd best_y;
  int stall = 0;
  static constexpr int patience = 40;

  // Per constraint: how far above 0 it may be with the true (untightened)
  // limit still met: the margin at its worst instant.
  mutable std::vector<double> slack;
  mutable Setup::FineCache cache;  // fine-grid values of the point being evaluated
  mutable std::vector<double> cc;  // c of one limit and sign at the coarse instants

  explicit Round(const Setup& setup) : s(setup) {
    for (const auto& f : s.fams) m += static_cast<unsigned>((f.kind == Family::Abs ? 2 : 1) * s.cells());
    slack.assign(m, kFeasTol);
  }

  Eigen::VectorXd x_of(const double* y) const {
    return s.xh + s.Z * Eigen::Map<const Eigen::VectorXd>(y, s.ny);
  }

  double objective(const double* y, double* grad) {
    ++evals;
    const Eigen::VectorXd x = x_of(y);
    if (!grad) return f_last = s.problem.criterion(x);
    Eigen::VectorXd gx;
    f_last = s.problem.criterion(x, &gx);
    Eigen::Map<Eigen::VectorXd>(grad, s.ny) = s.Z.transpose() * gx;
    return f_last;
  }

  void constraints(double* c, const double* y, double* grad) const {
    const Eigen::VectorXd x = x_of(y);
    s.start_evaluation(cache);
    cc.resize(s.coarse_k.size());
    const Eigen::MatrixXd Vc = s.coarse_values(x);
    const auto K = static_cast<Eigen::Index>(s.fine_t.size());
    using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::Map<RowMat> J(grad, grad ? static_cast<Eigen::Index>(m) : 0, s.ny);  // NLopt: row-major dc_i/dy_j
    const int n1 = s.n1;
    Eigen::Index row = 0;
    for (size_t f = 0; f < s.fams.size(); ++f) {
      const Family& fam = s.fams[f];
      const int fi = static_cast<int>(f);
      const auto vc = Vc.col(static_cast<Eigen::Index>(f));
      const Eigen::VectorXd& bd = s.bound[f];
      const int signs = fam.kind == Family::Abs ? 2 : 1;
      for (int sg = 0; sg < signs; ++sg) {
        // sigma f <= bound (Abs, Max) or f >= bound (Min, written -f <= -bound).
        const double sigma = fam.kind == Family::Min ? -1.0 : (sg == 0 ? 1.0 : -1.0);
        const double bsign = fam.kind == Family::Min ? -1.0 : 1.0;
        // Where the limit equals the start value the start conditions hold the
        // value at both ends: no gradient in y there, so those instants are skipped.
        auto cval = [&](Eigen::Index k, double v) {
          if (fam.pinned && (k == 0 || k == K - 1)) return -kInf;
          return sigma * v - bsign * bd(k);
        };
        auto cval_at = [&](Eigen::Index k) { return cval(k, s.fine_value(fi, k, x, cache)); };
        for (size_t j = 0; j < s.coarse_k.size(); ++j) cc[j] = cval(s.coarse_k[j], vc(static_cast<Eigen::Index>(j)));
        for (int cell = 0; cell < s.cells(); ++cell, ++row) {
          const Eigen::Index b0 = s.cell_begin[static_cast<size_t>(cell)];
          const Eigen::Index b1 = s.cell_begin[static_cast<size_t>(cell) + 1];
          const size_t j0 = s.cell_coarse[static_cast<size_t>(cell)], j1 = s.cell_coarse[static_cast<size_t>(cell) + 1];
          auto ccoarse = [&](size_t j) { return cc[j]; };
          // Far outside the tilt limit (near z_ddot = -g) eqs. (26)-(27) change
          // fast: the whole cell is searched on the fine grid there.
          bool exhaustive = false;
          if (fam.tilt)
            for (size_t j = j0; j < j1 && !exhaustive; ++j)
              exhaustive = std::abs(vc(static_cast<Eigen::Index>(j))) > kExhaustiveTilt * fam.limit;
          // The worst fine instant of the cell (the first one on ties): searched
          // on the fine grid between the neighbours of every coarse local maximum.
          Eigen::Index best = b0;
          double best_c = ccoarse(j0);
          for (size_t j = j0; j < j1; ++j) {
            const double cj = ccoarse(j);
            if (!exhaustive && ((j > j0 && ccoarse(j - 1) > cj) || (j + 1 < j1 && ccoarse(j + 1) > cj))) continue;
            const Eigen::Index lo = j > j0 ? s.coarse_k[j - 1] + 1 : s.coarse_k[j];
            const Eigen::Index hi = j + 1 < j1 ? s.coarse_k[j + 1] - 1 : s.coarse_k[j];
            auto consider = [&](Eigen::Index k, double ck) {
              if (ck > best_c || (ck == best_c && k < best)) {
                best = k;
                best_c = ck;
              }
            };
            if (fam.tilt || fam.vehicle || cell == 0 || cell + 1 == s.cells()) {
              for (Eigen::Index k = lo; k <= hi; ++k) consider(k, cval_at(k));
              continue;
            }
            // A position or speed limit is a Fourier sum whose fastest harmonic
            // is far slower than kCoarseDt, so between its coarse neighbours it
            // has one maximum and the climb from the coarse instant ends where
            // the window's scan would: right while rising, else left while not
            // falling (ties go to the earlier instant, as in the scan). Scanned
            // instead: the tilts and rotor limits (nonlinear; in wild iterates
            // they can turn within a window) and the first and last cells (the
            // start conditions flatten every value there to rounding level).
            Eigen::Index k = s.coarse_k[j];
            double ck = cj;
            for (double next; k < hi && (next = cval_at(k + 1)) > ck; ++k) ck = next;
            if (k == s.coarse_k[j])
              for (double prev; k > lo && (prev = cval_at(k - 1)) >= ck; --k) ck = prev;
            consider(k, ck);
          }
          if ((best == b0 && b0 > 0 && cval_at(b0 - 1) < best_c && b1 - b0 > 2) || !std::isfinite(best_c)) {
            best = (b0 + b1) / 2;
            best_c = cval_at(best);
          }
          c[row] = best_c / fam.scale;
          slack[static_cast<size_t>(row)] =
              std::max(kFeasTol, s.margin_at(fam, s.fine_t[static_cast<size_t>(best)]) / fam.scale);
          if (!grad) continue;
          auto Jr = J.row(row);
          if (fam.tilt) {
            const auto& B2 = s.fine_basis[2];
            const auto& B0 = s.fine_basis[0];
            const auto p = design_detail::tilt_point(B2.row(best).dot(x.segment(0, n1)),
                                                     B2.row(best).dot(x.segment(n1, n1)),
                                                     B2.row(best).dot(x.segment(2 * n1, n1)),
                                                     B0.row(best).dot(x.segment(3 * n1, n1)), s.opt.g);
            const Eigen::Vector4d& dv = fam.axis == 0 ? p.dphi : p.dtheta;
            Eigen::RowVectorXd gx(s.n);
            for (int i = 0; i < 3; ++i) gx.segment(i * n1, n1) = dv(i) * B2.row(best);
            gx.segment(3 * n1, n1) = dv(3) * B0.row(best);
            Jr.noalias() = (sigma / fam.scale) * (gx * s.Z);
          } else if (fam.vehicle) {
            FlatOutput d;
            for (int i = 0; i < 4; ++i)
              for (int ord = 0; ord < 5; ++ord)
                d(i, ord) = s.fine_basis[static_cast<size_t>(ord)].row(best).dot(x.segment(i * n1, n1));
            Eigen::MatrixXd dv;
            Eigen::RowVectorXd gx = Eigen::RowVectorXd::Zero(s.n);
            if (d(kZ, 2) + s.opt.g > 0.0) {
              design_detail::vehicle_sample(d, s.opt.g, s.vlim, &dv);
              for (int i = 0; i < 4; ++i)
                for (int ord = 0; ord < 5; ++ord)
                  if (design_detail::is_input(i, ord))
                    gx.segment(i * n1, n1) += dv(fam.axis, design_detail::input_index(i, ord)) *
                                              s.fine_basis[static_cast<size_t>(ord)].row(best);
            }
            Jr.noalias() = (sigma / fam.scale) * (gx * s.Z);
          } else {  // only the family's axis: one block of Z
            Jr.noalias() = (sigma / fam.scale) * (s.fine_basis[static_cast<size_t>(fam.order)].row(best) *
                                                  s.Z.middleRows(fam.axis * n1, n1));
          }
        }
      }
    }
  }

  // Called with the constraints of the point whose criterion is f_last
  // (SLSQP evaluates the criterion, then the constraints, at each point).
  void record(const double* y, const double* c) {
    for (unsigned i = 0; i < m; ++i)
      if (!(c[i] <= slack[i])) return;
    if (!std::isfinite(f_last)) return;
    if (f_last < best_f) {
      best_f = f_last;
      best_y = Eigen::Map<const Eigen::VectorXd>(y, s.ny);
    }
    if (!std::isfinite(anchor_f) || best_f < anchor_f - s.opt.ftol_rel * std::abs(anchor_f)) {
      anchor_f = best_f;
      stall = 0;
    } else if (++stall >= patience && solver) {
      solver->force_stop();
    }
  }
};

double objective_cb(unsigned, const double* y, double* grad, void* data) {
  return static_cast<Round*>(data)->objective(y, grad);
}
void constraints_cb(unsigned, double* c, unsigned, const double* y, double* grad, void* data) {
  auto* rd = static_cast<Round*>(data);
  rd->constraints(c, y, grad);
  rd->record(y, c);
}


// A random start in y: velocity amplitudes a, b uniform in [-1, 1] m/s,
// projected onto the start conditions, then shrunk so that the largest
// position, velocity and (through eqs. 26-27, approximately) tilt excursion
// uses start_fill of its limit.
Eigen::VectorXd random_start(const Setup& s, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd x = s.xh;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 2 * s.opt.harmonics; ++j) x(i * s.n1 + j) = U(rng);
  Eigen::VectorXd y = s.Z.transpose() * (x - s.xh);
  const Eigen::VectorXd dx = s.Z * y;
  double ratio = 0.0;
  const auto grid = s.basis_at(s.problem.times(), 0), grid1 = s.basis_at(s.problem.times(), 1),
             grid2 = s.basis_at(s.problem.times(), 2);
  const auto& L = s.opt.limits;
  auto peak = [&](const Eigen::MatrixXd& G, int axis) { return (G * dx.segment(axis * s.n1, s.n1)).cwiseAbs().maxCoeff(); };
  const double tilt_acc = s.opt.g * std::tan(L.tilt_max);
  const std::array<std::pair<double, double>, 10> use = {{
      {peak(grid, kX), L.x_max - std::abs(L.x0)},
      {peak(grid, kY), L.y_max - std::abs(L.y0)},
      {peak(grid, kZ), L.z_max - L.z_min},
      {peak(grid, kPsi), L.psi_max - std::abs(L.psi0)},
      {peak(grid1, kX), L.xdot_max},
      {peak(grid1, kY), L.ydot_max},
      {peak(grid1, kZ), L.zdot_max},
      {peak(grid1, kPsi), L.psidot_max},
      {peak(grid2, kX), tilt_acc},
      {peak(grid2, kY), tilt_acc},
  }};
  for (const auto& [p, avail] : use)
    if (std::isfinite(avail) && avail > 0.0) ratio = std::max(ratio, p / avail);
  if (ratio > 0.0) y *= s.opt.start_fill / ratio;
  return y;
}

StartSummary run_start(const Setup& s, int index, Eigen::VectorXd y, Eigen::VectorXd& x_out) {
  const auto t0 = std::chrono::steady_clock::now();
  StartSummary sum;
  sum.index = index;
  Eigen::VectorXd x = s.xh + s.Z * y;
  for (int round = 0; round <= s.opt.refine_rounds; ++round) {
    Round rd(s);
    nlopt::opt o(nlopt::LD_SLSQP, static_cast<unsigned>(s.ny));
    rd.solver = &o;
    o.set_min_objective(objective_cb, &rd);
    o.add_inequality_mconstraint(constraints_cb, &rd, std::vector<double>(rd.m, kFeasTol));
    o.set_maxeval(s.opt.max_evals);
    std::vector<double> yv(y.data(), y.data() + y.size());
    double f = 0.0;
    try {
      sum.status = nlopt_status(static_cast<int>(o.optimize(yv, f)));
    } catch (const nlopt::forced_stop&) {
      sum.status = "converged";
    } catch (const nlopt::roundoff_limited&) {
      sum.status = "roundoff limited";
    } catch (const std::runtime_error& e) {
      sum.status = fmt::format("failure ({})", e.what());
    }
    y = rd.best_y.size() ? rd.best_y : Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(yv.data(), s.ny));
    sum.evaluations += rd.evals;
    sum.rounds = round + 1;
    x = s.xh + s.Z * y;
    sum.worst_violation = s.worst_violation(x);
    sum.feasible = sum.worst_violation == 0.0;
    if (sum.feasible) break;
  }
  x_out = x;
  const auto traj = FourierTrajectory::from_coefficients(s.opt.wf, s.opt.harmonics, x);
  const bool prec = s.opt.criterion == Criterion::Precision;
  const auto cv = evaluate_criteria(traj, s.opt.cond_dt, s.opt.g, parameter_scales(s.opt.reference, s.opt.product_floor),
                                    prec ? &s.opt.row_noise : nullptr, &s.opt.reference);
  sum.criterion = cv.value(s.opt.criterion);
  sum.cond = cv.cond;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace

DesignResult design_trajectory(const DesignOptions& opt, const DesignProgress& progress) {
  opt.validate();
  const auto t0 = std::chrono::steady_clock::now();
  const Setup setup(opt);

  std::mt19937_64 rng(opt.seed);
  std::vector<Eigen::VectorXd> y0;
  for (int i = 0; i < opt.starts; ++i) y0.push_back(random_start(setup, rng));

  DesignResult res;
  res.starts.resize(static_cast<size_t>(opt.starts));
  std::vector<Eigen::VectorXd> xs(static_cast<size_t>(opt.starts));
  std::mutex mu;  // the progress callback sees one start at a time
  detail::parallel_for(opt.starts, opt.threads, [&](int i) {
    auto sum = run_start(setup, i, y0[static_cast<size_t>(i)], xs[static_cast<size_t>(i)]);
    const std::lock_guard<std::mutex> lock(mu);
    res.starts[static_cast<size_t>(i)] = sum;
    if (progress) progress(sum, opt.starts);
  });

  // Best feasible start by criterion; ties and infeasible runs go by index / least violation.
  for (int i = 0; i < opt.starts; ++i) {
    const auto& s = res.starts[static_cast<size_t>(i)];
    if (res.best < 0) {
      res.best = i;
      continue;
    }
    const auto& b = res.starts[static_cast<size_t>(res.best)];
    const bool better = s.feasible != b.feasible ? s.feasible
                        : s.feasible             ? s.criterion < b.criterion
                                                 : s.worst_violation < b.worst_violation;
    if (better) res.best = i;
  }
  res.trajectory = FourierTrajectory::from_coefficients(opt.wf, opt.harmonics, xs[static_cast<size_t>(res.best)]);
  CheckOptions co;
  co.limits = opt.limits;
  co.constraint_dt = opt.check_dt;
  co.cond_dt = opt.cond_dt;
  co.g = opt.g;
  co.reference = opt.reference;
  co.product_floor = opt.product_floor;
  if (opt.criterion == Criterion::Precision) co.row_noise = opt.row_noise;
  res.check = check_trajectory(res.trajectory, co);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace quadid
