// The Crazyflie's piecewise polynomial (poly4d) as a trajectory, its one-line
// JSON spec and Crazyswarm's CSV layout (include/quadid/trajectory.hpp).
#include "quadid/trajectory.hpp"

#include "quadid/io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace quadid {

PolynomialTrajectory::PolynomialTrajectory(std::vector<PolyPiece> pieces) : pieces_(std::move(pieces)) {
  if (pieces_.empty()) throw std::invalid_argument("polynomial trajectory: no pieces");
  for (const auto& p : pieces_) {
    if (!(p.duration > 0.0)) throw std::invalid_argument("polynomial trajectory: a piece's duration must be > 0");
    starts_.push_back(total_);
    total_ += p.duration;
  }
}

FlatOutput PolynomialTrajectory::eval(double t) const {
  size_t i = static_cast<size_t>(std::upper_bound(starts_.begin(), starts_.end(), t) - starts_.begin());
  i = i == 0 ? 0 : i - 1;
  const PolyPiece& p = pieces_[i];
  const double tau = std::clamp(t - starts_[i], 0.0, p.duration);
  FlatOutput f = FlatOutput::Zero();
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k <= 4; ++k) {
      double v = 0.0;  // Horner on the k-th derivative
      for (int c = 7; c >= k; --c) v = v * tau + p.coeffs[static_cast<size_t>(a)](c) * falling_factorial(c, k);
      f(a, k) = v;
    }
  return f;
}

std::string PolynomialTrajectory::describe() const {
  return fmt::format("piecewise polynomial: {} pieces of degree 7, {:.4g} s", pieces_.size(), total_);
}

nlohmann::ordered_json to_json(const PolynomialTrajectory& p) {
  nlohmann::ordered_json pieces = nlohmann::ordered_json::array();
  for (const auto& piece : p.pieces()) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array({piece.duration});
    for (const auto& c : piece.coeffs)
      for (int i = 0; i < 8; ++i) row.push_back(c(i));
    pieces.push_back(row);
  }
  return {{"type", "poly4d"}, {"pieces", pieces}};
}

PolynomialTrajectory polynomial_from_json(const nlohmann::ordered_json& j, const std::string& source) {
  if (!j.is_object() || j.value("type", "") != "poly4d" || !j.contains("pieces") || !j["pieces"].is_array())
    throw InputError(fmt::format("{}: expected {{\"type\": \"poly4d\", \"pieces\": [...]}}", source));
  std::vector<PolyPiece> pieces;
  for (size_t r = 0; r < j["pieces"].size(); ++r) {
    const auto& row = j["pieces"][r];
    if (!row.is_array() || row.size() != 33)
      throw InputError(fmt::format("{}: pieces[{}]: expected 33 numbers (duration, 8 coefficients of x, y, z, yaw)",
                                   source, r));
    PolyPiece p;
    for (size_t i = 0; i < 33; ++i) {
      if (!row[i].is_number() || !std::isfinite(row[i].get<double>()))
        throw InputError(fmt::format("{}: pieces[{}][{}]: not a finite number", source, r, i));
      const double v = row[i].get<double>();
      if (i == 0) p.duration = v;
      else p.coeffs[(i - 1) / 8]((i - 1) % 8) = v;
    }
    if (!(p.duration > 0.0)) throw InputError(fmt::format("{}: pieces[{}]: duration must be > 0 s", source, r));
    pieces.push_back(p);
  }
  if (pieces.empty()) throw InputError(fmt::format("{}: no pieces", source));
  return PolynomialTrajectory(std::move(pieces));
}

std::vector<PolyPiece> read_crazyflie_poly_csv(const std::filesystem::path& path) {
  const std::string text = read_file(path);
  std::istringstream in(text);
  std::string line;
  std::vector<PolyPiece> out;
  int lineno = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string_view> f;
    std::string_view rest(line);
    for (;;) {
      const auto c = rest.find(',');
      f.push_back(rest.substr(0, c));
      if (c == std::string_view::npos) break;
      rest.remove_prefix(c + 1);
    }
    if (f.size() != 33)
      throw InputError(fmt::format("{}:{}: {} fields where a poly4d row has 33 (Duration, then 8 coefficients for each "
                                   "of x, y, z, yaw)",
                                   path.string(), lineno, f.size()));
    if (!header) {
      header = true;
      double v;
      if (!parse_finite_double(f[0], v)) continue;  // a header line
    }
    PolyPiece p;
    for (size_t i = 0; i < 33; ++i) {
      double v;
      if (!parse_finite_double(f[i], v))
        throw InputError(fmt::format("{}:{}: column {}: '{}' is not a finite number", path.string(), lineno, i + 1,
                                     std::string(f[i])));
      if (i == 0) p.duration = v;
      else p.coeffs[(i - 1) / 8]((i - 1) % 8) = v;
    }
    if (!(p.duration > 0.0))
      throw InputError(fmt::format("{}:{}: column 1: Duration {} must be > 0 s", path.string(), lineno, p.duration));
    out.push_back(p);
  }
  if (out.empty()) throw InputError(fmt::format("{}: no polynomial pieces", path.string()));
  return out;
}

}  // namespace quadid
