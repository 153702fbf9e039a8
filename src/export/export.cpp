// Export of a designed trajectory for an autopilot: the flight plan (take-off,
// settle, excitation, settle, landing), its setpoints, its degree-7 piecewise
// polynomial (Crazyflie poly4d) and a MAVSDK-Python offboard script.
#include "quadid/export.hpp"

#include "quadid/io.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace quadid {
namespace {

// s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7 and its derivatives in u, orders 0..4:
// rest to rest (s' = s'' = s''' = 0 at u = 0 and 1), s(0) = 0, s(1) = 1.
std::array<double, 5> smoothstep7(double u) {
  const double u2 = u * u, u3 = u2 * u, u4 = u3 * u, u5 = u4 * u, u6 = u5 * u, u7 = u6 * u;
  return {35 * u4 - 84 * u5 + 70 * u6 - 20 * u7, 140 * u3 - 420 * u4 + 420 * u5 - 140 * u6,
          420 * u2 - 1680 * u3 + 2100 * u4 - 840 * u5, 840 * u - 5040 * u2 + 8400 * u3 - 4200 * u4,
          840 - 10080 * u + 25200 * u2 - 16800 * u3};
}

constexpr double kPeakOfSmoothstep = 35.0 / 16.0;  // max s'(u), at u = 1/2

FlatOutput hover(const FlatOutput& at) {
  FlatOutput f = FlatOutput::Zero();
  f.col(0) = at.col(0);
  return f;
}

// Degree-7 Hermite interpolant on [0, h] matching orders 0..3 at both ends;
// solved in u = tau / h (well conditioned for any h), returned in powers of tau.
Eigen::Matrix<double, 8, 1> hermite7(const Eigen::Matrix<double, 1, 5>& f0, const Eigen::Matrix<double, 1, 5>& f1,
                                     double h) {
  Eigen::Matrix<double, 8, 1> b;  // coefficients in u
  double hk = 1.0, fact = 1.0;
  for (int k = 0; k < 4; ++k) {
    b(k) = f0(k) * hk / fact;  // d^k/du^k = h^k d^k/dtau^k
    hk *= h;
    fact *= static_cast<double>(k + 1);
  }
  Eigen::Matrix4d M;
  Eigen::Vector4d rhs;
  hk = 1.0;
  for (int k = 0; k < 4; ++k) {
    double known = 0.0;
    for (int i = k; i < 4; ++i) known += b(i) * falling_factorial(i, k);
    for (int i = 4; i < 8; ++i) M(k, i - 4) = falling_factorial(i, k);
    rhs(k) = f1(k) * hk - known;
    hk *= h;
  }
  b.tail<4>() = M.colPivHouseholderQr().solve(rhs);
  Eigen::Matrix<double, 8, 1> c;
  double hi = 1.0;
  for (int i = 0; i < 8; ++i) {
    c(i) = b(i) / hi;
    hi *= h;
  }
  return c;
}

const char* const kAxisPoly[4] = {"x", "y", "z", "yaw"};

}  // namespace

void FlightPlanOptions::validate() const {
  if (!std::isfinite(ground_z)) throw std::invalid_argument("--ground-z must be finite");
  if (!(climb_speed > 0.0) || !std::isfinite(climb_speed))
    throw std::invalid_argument(fmt::format("--climb-speed = {} must be > 0 m/s", climb_speed));
  if (!(min_climb_time > 0.0) || !std::isfinite(min_climb_time))
    throw std::invalid_argument(fmt::format("--min-climb-time = {} must be > 0 s", min_climb_time));
  if (!(settle >= 0.0) || !std::isfinite(settle))
    throw std::invalid_argument(fmt::format("--settle = {} must be >= 0 s", settle));
  if (cycles < 1 || cycles > 1000) throw std::invalid_argument(fmt::format("--cycles = {} must be in 1..1000", cycles));
  if (!(rest_tol > 0.0)) throw std::invalid_argument(fmt::format("rest_tol = {} must be > 0", rest_tol));
}

FlightPlan::FlightPlan(std::shared_ptr<const Trajectory> excitation, const FlightPlanOptions& opt)
    : exc_(std::move(excitation)), opt_(opt) {
  opt.validate();
  if (!exc_) throw std::invalid_argument("FlightPlan: no trajectory");
  const double len = static_cast<double>(opt.cycles) * exc_->period();
  start_ = exc_->eval(0.0);
  end_ = exc_->eval(len);
  for (const auto& [f, when] : {std::pair{&start_, "start (t = 0)"}, std::pair{&end_, "end"}})
    for (int a = 0; a < 4; ++a)
      for (int k = 1; k <= 2; ++k)
        if (std::abs((*f)(a, k)) > opt.rest_tol)
          throw std::invalid_argument(fmt::format(
              "the trajectory is not at rest at its {}: {} {} = {:.4g} (|.| <= {:g} needed to hover there; a designed "
              "trajectory starts and ends at rest after whole periods)",
              when, kAxisNames[static_cast<size_t>(a)], k == 1 ? "velocity" : "acceleration", (*f)(a, k), opt.rest_tol));
  const double climb_up = start_(kZ, 0) - opt.ground_z, climb_down = end_(kZ, 0) - opt.ground_z;
  if (!(climb_up > 0.0) || !(climb_down > 0.0))
    throw std::invalid_argument(fmt::format("the trajectory starts or ends at z = {:.4g} m, not above the ground "
                                            "(--ground-z = {:g} m)",
                                            std::min(start_(kZ, 0), end_(kZ, 0)), opt.ground_z));
  // Peak speed of the rest-to-rest polynomial: 35/16 d / T.
  climb_ = std::max(opt.min_climb_time, kPeakOfSmoothstep * std::max(climb_up, climb_down) / opt.climb_speed);
  double t = 0.0;
  auto add = [&](const char* name, double len_s, bool poly) {
    segments_.push_back({name, t, t + len_s, poly});
    t += len_s;
  };
  add("takeoff", climb_, true);
  add("settle", opt.settle, true);
  add("excitation", len, false);
  add("settle", opt.settle, true);
  add("landing", climb_, true);
  total_ = t;
}

FlatOutput FlightPlan::eval(double t) const {
  size_t i = 0;
  while (i + 1 < segments_.size() && t >= segments_[i].t1) ++i;
  return eval_segment(i, t - segments_[i].t0);
}

FlatOutput FlightPlan::eval_segment(size_t i, double tau_in) const {
  const Segment& s = segments_.at(i);
  const double tau = std::clamp(tau_in, 0.0, s.t1 - s.t0);
  if (s.name == "excitation") return exc_->eval(tau);
  if (s.name == "settle") return hover(i < 2 ? start_ : end_);
  const bool up = s.name == "takeoff";
  const FlatOutput at = up ? start_ : end_;
  FlatOutput f = hover(at);
  const double d = at(kZ, 0) - opt_.ground_z;
  const auto sv = smoothstep7(up ? tau / climb_ : 1.0 - tau / climb_);
  double scale = 1.0;
  for (int k = 0; k <= 4; ++k) {
    // z = z_g + d s(u), u = tau/T (up) or 1 - tau/T (down): d^k z/dt^k = d s^(k) (+-1/T)^k.
    f(kZ, k) = (k == 0 ? opt_.ground_z : 0.0) + d * sv[static_cast<size_t>(k)] * scale;
    scale *= (up ? 1.0 : -1.0) / climb_;
  }
  return f;
}

std::string FlightPlan::describe() const {
  return fmt::format("flight plan: take-off {:.3g} s, settle {:g} s, {} x ({}), settle {:g} s, landing {:.3g} s",
                     climb_, opt_.settle, opt_.cycles, exc_->describe(), opt_.settle, climb_);
}

std::vector<PolyPiece> fit_polynomial(const FlightPlan& plan, double piece) {
  if (!(piece > 0.0) || !std::isfinite(piece)) throw std::invalid_argument(fmt::format("--piece = {} must be > 0 s", piece));
  std::vector<PolyPiece> out;
  const auto& segs = plan.segments();
  for (size_t i = 0; i < segs.size(); ++i) {
    const double len = segs[i].t1 - segs[i].t0;
    if (!(len > 0.0)) continue;
    const int n = segs[i].polynomial ? 1 : std::max(1, static_cast<int>(std::ceil(len / piece - 1e-9)));
    const double h = len / n;
    for (int j = 0; j < n; ++j) {
      // The segment's own formula at both ends (the jerk jumps between segments).
      const double a = j * h, b = (j + 1 == n) ? len : a + h;
      const FlatOutput f0 = plan.eval_segment(i, a), f1 = plan.eval_segment(i, b);
      PolyPiece p;
      p.duration = b - a;
      for (int ax = 0; ax < 4; ++ax) p.coeffs[static_cast<size_t>(ax)] = hermite7(f0.row(ax), f1.row(ax), p.duration);
      out.push_back(p);
    }
  }
  return out;
}

FitError max_fit_error(const Trajectory& traj, const Trajectory& fit, double dt) {
  FitError e;
  const double T = traj.period();
  const long n = static_cast<long>(std::ceil(T / dt));
  for (long k = 0; k <= n; ++k) {
    const double t = std::min(T, static_cast<double>(k) * dt);
    const FlatOutput a = traj.eval(t), b = fit.eval(t);
    e.position = std::max(e.position, (a.block<3, 1>(0, 0) - b.block<3, 1>(0, 0)).norm());
    e.velocity = std::max(e.velocity, (a.block<3, 1>(0, 1) - b.block<3, 1>(0, 1)).norm());
    e.yaw = std::max(e.yaw, std::abs(a(kPsi, 0) - b(kPsi, 0)));
  }
  return e;
}

std::string setpoints_csv(const FlightPlan& plan, double rate, const std::vector<std::string>& comments) {
  if (!(rate > 0.0) || !std::isfinite(rate)) throw std::invalid_argument(fmt::format("--export-rate = {} must be > 0 Hz", rate));
  std::string s;
  for (const auto& c : comments) s += "# " + c + "\n";
  s += fmt::format("# {}\n", plan.describe());
  for (const auto& seg : plan.segments()) s += fmt::format("# segment {} {} {}\n", seg.name, seg.t0, seg.t1);
  s += "# units: s, m, m/s, m/s^2, rad, rad/s; inertial frame z up (x forward, y left), yaw about +z\n";
  s += "t,x,y,z,vx,vy,vz,ax,ay,az,yaw,yaw_rate\n";
  const long n = setpoint_count(plan, rate);
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / rate;
    const FlatOutput f = plan.eval(t);  // past the end: landed, at rest
    s += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{}\n", t, f(0, 0), f(1, 0), f(2, 0), f(0, 1), f(1, 1), f(2, 1),
                     f(0, 2), f(1, 2), f(2, 2), f(3, 0), f(3, 1));
  }
  return s;
}

long setpoint_count(const FlightPlan& plan, double rate) {
  // A uniform grid from 0 to the first sample at or after the end.
  return static_cast<long>(std::ceil(plan.period() * rate - 1e-9)) + 1;
}

std::string crazyflie_poly_csv(const std::vector<PolyPiece>& pieces) {
  std::string s = "Duration";
  for (const char* a : kAxisPoly)
    for (int i = 0; i < 8; ++i) s += fmt::format(",{}^{}", a, i);
  s += "\n";
  for (const auto& p : pieces) {
    s += fmt::format("{}", p.duration);
    for (const auto& c : p.coeffs)
      for (int i = 0; i < 8; ++i) s += fmt::format(",{}", c(i));
    s += "\n";
  }
  return s;
}

std::string mavsdk_script(const std::string& csv_name) {
  std::string s = R"PY(#!/usr/bin/env python3
"""Fly a quadid setpoint CSV in PX4 offboard mode with MAVSDK-Python.

Written by `quadid export`. The CSV is in quadid's frame (inertial z up,
x forward, y left, yaw about +z, SI units and radians); PX4 wants NED
(north, east, down) and yaw clockwise from north in degrees: north = x,
east = -y, down = -z, yaw_ned = -yaw (docs/conventions.md, docs/fly-it.md).
The plan starts on the ground at the take-off point: the CSV's positions are
sent relative to the vehicle's position when offboard starts.

    pip install mavsdk
    python3 THIS_SCRIPT.py [--connect udp://:14540] [CSV]

Fly it in the simulator (PX4 SITL) before a real vehicle, with a safety pilot.
"""
import argparse
import asyncio
import csv
import math
import os
import sys

DEFAULT_CSV = ")PY";
  s += csv_name;
  s += R"PY("


def read_setpoints(path):
    rows = []
    with open(path, newline="") as f:
        lines = [line for line in f if not line.startswith("#")]
    for r in csv.DictReader(lines):
        rows.append({k: float(v) for k, v in r.items()})
    if not rows:
        sys.exit(f"{path}: no setpoints")
    return rows


def ned(r, origin, z0):
    """quadid (z up, y left) -> PX4 NED, the first setpoint at `origin` (north, east, down)."""
    return (origin[0] + r["x"], origin[1] - r["y"], origin[2] - (r["z"] - z0),
            r["vx"], -r["vy"], -r["vz"], r["ax"], -r["ay"], -r["az"],
            -math.degrees(r["yaw"]), -math.degrees(r["yaw_rate"]))


async def fly(address, path):
    from mavsdk import System
    from mavsdk.offboard import (AccelerationNed, OffboardError, PositionNedYaw, VelocityNedYaw)

    rows = read_setpoints(path)
    drone = System()
    await drone.connect(system_address=address)
    async for state in drone.core.connection_state():
        if state.is_connected:
            break
    async for health in drone.telemetry.health():
        if health.is_local_position_ok:
            break
    async for pv in drone.telemetry.position_velocity_ned():
        origin = (pv.position.north_m - rows[0]["x"], pv.position.east_m + rows[0]["y"], pv.position.down_m)
        break

    def setpoint(r):
        n, e, d, vn, ve, vd, an, ae, ad, yaw, _ = ned(r, origin, rows[0]["z"])
        return PositionNedYaw(n, e, d, yaw), VelocityNedYaw(vn, ve, vd, yaw), AccelerationNed(an, ae, ad)

    pos, vel, acc = setpoint(rows[0])
    await drone.action.arm()
    await drone.offboard.set_position_velocity_ned(pos, vel)
    try:
        await drone.offboard.start()
    except OffboardError as err:
        await drone.action.disarm()
        sys.exit(f"offboard did not start: {err._result.result}")
    loop = asyncio.get_running_loop()
    t0 = loop.time()
    send_acc = hasattr(drone.offboard, "set_position_velocity_acceleration_ned")
    for r in rows:
        delay = t0 + r["t"] - loop.time()
        if delay > 0:
            await asyncio.sleep(delay)
        pos, vel, acc = setpoint(r)
        if send_acc:
            await drone.offboard.set_position_velocity_acceleration_ned(pos, vel, acc)
        else:
            await drone.offboard.set_position_velocity_ned(pos, vel)
    await drone.offboard.stop()
    await drone.action.land()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", nargs="?", default=None, help="setpoint CSV (default: the one written beside this script)")
    ap.add_argument("--connect", default="udp://:14540", help="MAVSDK connection address")
    ap.add_argument("--check", action="store_true", help="read and check the CSV, print its length, do not fly")
    a = ap.parse_args()
    path = a.csv or os.path.join(os.path.dirname(os.path.abspath(__file__)), DEFAULT_CSV)
    if a.check:
        rows = read_setpoints(path)
        print(f"{path}: {len(rows)} setpoints over {rows[-1]['t'] - rows[0]['t']:.2f} s")
        return
    asyncio.run(fly(a.connect, path))


if __name__ == "__main__":
    main()
)PY";
  return s;
}

ExportFormat parse_export_format(std::string_view name) {
  if (name == "setpoints") return ExportFormat::Setpoints;
  if (name == "crazyflie") return ExportFormat::Crazyflie;
  if (name == "mavsdk") return ExportFormat::Mavsdk;
  throw std::invalid_argument(fmt::format("--export-format '{}': expected setpoints, crazyflie or mavsdk", name));
}

ExportFormat export_format_for(const std::filesystem::path& path, std::string_view option) {
  const std::string name = path.filename().string();
  auto ends = [&](std::string_view suf) {
    return name.size() >= suf.size() && name.compare(name.size() - suf.size(), suf.size(), suf) == 0;
  };
  if (ends(".py")) return ExportFormat::Mavsdk;
  if (ends(".poly.csv") || ends(".poly")) return ExportFormat::Crazyflie;
  if (ends(".csv")) return ExportFormat::Setpoints;
  throw std::invalid_argument(fmt::format(
      "{} '{}': cannot tell the format from the name (.csv: setpoints, .poly.csv: Crazyflie polynomial, .py: MAVSDK "
      "script); give --export-format",
      option, path.string()));
}

void ExportOptions::validate() const {
  plan.validate();
  if (!(rate > 0.0) || !std::isfinite(rate) || rate > 1000.0)
    throw std::invalid_argument(fmt::format("--export-rate = {} must be in (0, 1000] Hz", rate));
  if (!(piece >= 0.05) || !std::isfinite(piece) || piece > 60.0)
    throw std::invalid_argument(fmt::format("--piece = {} must be in [0.05, 60] s", piece));
  if (!format.empty()) parse_export_format(format);
}

ExportSummary export_flight(const std::shared_ptr<const Trajectory>& traj, const std::filesystem::path& path,
                            const ExportOptions& opt, const std::vector<std::string>& comments) {
  opt.validate();
  ExportSummary sum;
  sum.format = opt.format.empty() ? export_format_for(path, "--export") : parse_export_format(opt.format);
  const FlightPlan plan(traj, opt.plan);
  sum.duration = plan.period();
  sum.segments = plan.segments();
  std::vector<std::pair<std::filesystem::path, std::string>> files;
  if (sum.format == ExportFormat::Crazyflie) {
    const auto pieces = fit_polynomial(plan, opt.piece);
    sum.pieces = static_cast<int>(pieces.size());
    sum.fit = max_fit_error(plan, PolynomialTrajectory(pieces));
    files.emplace_back(path, crazyflie_poly_csv(pieces));
  } else {
    const std::string csv = setpoints_csv(plan, opt.rate, comments);
    sum.setpoints = setpoint_count(plan, opt.rate);
    if (sum.format == ExportFormat::Mavsdk) {
      std::filesystem::path csv_path = path;
      csv_path.replace_extension(".csv");
      files.emplace_back(csv_path, csv);
      files.emplace_back(path, mavsdk_script(csv_path.filename().string()));
    } else {
      files.emplace_back(path, csv);
    }
  }
  for (const auto& [p, text] : files) check_output_file(p, "--export");
  for (const auto& [p, text] : files) {
    write_file_atomic(p, text);
    sum.files.push_back(p);
  }
  return sum;
}

nlohmann::ordered_json to_json(const ExportSummary& s) {
  static const char* names[] = {"setpoints", "crazyflie", "mavsdk"};
  nlohmann::ordered_json j;
  j["format"] = names[static_cast<int>(s.format)];
  j["files"] = nlohmann::ordered_json::array();
  for (const auto& f : s.files) j["files"].push_back(f.string());
  j["duration"] = s.duration;
  j["segments"] = nlohmann::ordered_json::array();
  for (const auto& seg : s.segments) j["segments"].push_back({{"name", seg.name}, {"t0", seg.t0}, {"t1", seg.t1}});
  if (s.format == ExportFormat::Crazyflie) {
    j["pieces"] = s.pieces;
    j["bytes"] = s.pieces * kPoly4dBytesPerPiece;
    j["fits_crazyflie_memory"] = s.pieces * kPoly4dBytesPerPiece <= kCrazyflieTrajectoryMemory;
    j["fit"] = {{"position", s.fit.position}, {"velocity", s.fit.velocity}, {"yaw", s.fit.yaw}};
  } else {
    j["setpoints"] = s.setpoints;
  }
  return j;
}

std::string format_export_summary(const ExportSummary& s) {
  static const char* names[] = {"setpoints CSV", "Crazyflie piecewise polynomial (poly4d, Crazyswarm CSV)",
                                "MAVSDK-Python offboard script + setpoint CSV"};
  std::string out = fmt::format("export: {}, {:.2f} s of flight:", names[static_cast<int>(s.format)], s.duration);
  for (const auto& seg : s.segments) out += fmt::format(" {} {:.2f}-{:.2f} s;", seg.name, seg.t0, seg.t1);
  out += "\n";
  if (s.format == ExportFormat::Crazyflie) {
    const int bytes = s.pieces * kPoly4dBytesPerPiece;
    out += fmt::format("  {} pieces ({} bytes; the Crazyflie's trajectory memory holds {}{}), largest deviation from "
                       "the plan {:.2e} m, {:.2e} m/s, {:.2e} rad yaw\n",
                       s.pieces, bytes, kCrazyflieTrajectoryMemory,
                       bytes > kCrazyflieTrajectoryMemory ? ": TOO LARGE for one upload, use a longer --piece or "
                                                            "fewer --cycles and start it repeatedly"
                                                          : "",
                       s.fit.position, s.fit.velocity, s.fit.yaw);
  } else {
    out += fmt::format("  {} setpoints\n", s.setpoints);
  }
  for (const auto& f : s.files) out += fmt::format("  wrote {}\n", f.string());
  return out;
}

}  // namespace quadid
