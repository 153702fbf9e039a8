// Flight-log CSV (DESIGN.md, "Flight log"): '#' comments, one header line,
// then one row per sample.
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstring>

namespace quadid {

const std::vector<std::string>& standard_log_columns() {
  static const std::vector<std::string> cols = {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q",
                                                "r", "Fz", "tau_phi", "tau_theta", "tau_psi"};
  return cols;
}

int FlightLog::find(std::string_view name) const {
  for (size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return static_cast<int>(i);
  return -1;
}

Eigen::VectorXd FlightLog::column(std::string_view name) const {
  const int i = find(name);
  if (i < 0) throw InputError(fmt::format("flight log has no column '{}'", name));
  return data.col(i);
}

std::map<std::string, std::string> parse_column_map(const std::vector<std::string>& items) {
  std::map<std::string, std::string> m;
  for (const auto& it : items) {
    const auto eq = it.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == it.size())
      throw std::invalid_argument(
          fmt::format("--map '{}': expected CANONICAL=NAME, e.g. tau_phi=tau_x", it));
    m[it.substr(0, eq)] = it.substr(eq + 1);
  }
  return m;
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

}  // namespace

FlightLog read_flight_log(const std::filesystem::path& path, const CsvReadOptions& opt) {
  const std::string text = read_file(path);
  const std::string file = path.string();
  FlightLog log;
  const char* p = text.data();
  const char* end = p + text.size();
  size_t line_no = 0;

  auto next_line = [&](std::string_view& line) {
    if (p >= end) return false;
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
    const char* e = nl ? nl : end;
    line = std::string_view(p, static_cast<size_t>(e - p));
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    p = nl ? nl + 1 : end;
    ++line_no;
    return true;
  };

  // Comments and header.
  std::string_view line;
  bool have_header = false;
  while (next_line(line)) {
    if (trim(line).empty()) continue;
    if (line.front() == '#') {
      log.comments.emplace_back(trim(line.substr(1)));
      continue;
    }
    size_t start = 0;
    while (true) {
      const size_t comma = line.find(',', start);
      log.columns.emplace_back(trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    have_header = true;
    break;
  }
  if (!have_header) throw InputError(fmt::format("{}: no header line (expected column names such as t,x,y,z,...)", file));
  const size_t header_line = line_no;
  for (size_t i = 0; i < log.columns.size(); ++i) {
    if (log.columns[i].empty())
      throw InputError(fmt::format("{}:{}: column {} has an empty name", file, header_line, i + 1));
    for (size_t j = 0; j < i; ++j)
      if (log.columns[j] == log.columns[i])
        throw InputError(fmt::format("{}:{}: column '{}' appears twice", file, header_line, log.columns[i]));
  }
  // --map canonical=name: rename the file's column to the canonical one.
  for (const auto& [canon, name] : opt.map) {
    const int i = log.find(name);
    if (i < 0)
      throw InputError(fmt::format("{}:{}: --map {}={}: the file has no column '{}'", file, header_line, canon, name, name));
    if (log.find(canon) >= 0 && canon != name)
      throw InputError(fmt::format("{}:{}: --map {}={}: the file already has a column '{}'", file, header_line, canon, name, canon));
    log.columns[static_cast<size_t>(i)] = canon;
  }
  std::vector<std::string> missing;
  for (const auto& r : opt.required)
    if (log.find(r) < 0) missing.push_back(r);
  if (!missing.empty())
    throw InputError(fmt::format("{}:{}: missing required column(s): {} (use --map CANONICAL=NAME for other names)",
                                 file, header_line, fmt::join(missing, ", ")));

  // Rows: parse into a row-major buffer, then transpose into the matrix.
  const size_t ncol = log.columns.size();
  std::vector<double> buf;
  buf.reserve(static_cast<size_t>(end - p) / 8 + ncol);
  size_t nrow = 0;
  std::vector<size_t> row_line;  // file line of each data row, for messages
  row_line.reserve(buf.capacity() / ncol + 1);
  while (next_line(line)) {
    if (line.empty() || line.front() == '#') continue;
    row_line.push_back(line_no);
    const char* q = line.data();
    const char* le = q + line.size();
    for (size_t c = 0; c < ncol; ++c) {
      while (q < le && (*q == ' ' || *q == '\t')) ++q;
      double val = 0.0;
      const char* numstart = q;
      if (q < le && *q == '+') ++q;
      auto [ptr, ec] = std::from_chars(q, le, val);
      if (ec != std::errc() || !std::isfinite(val)) {
        const char* fe = static_cast<const char*>(std::memchr(numstart, ',', static_cast<size_t>(le - numstart)));
        const std::string_view field = trim(std::string_view(numstart, static_cast<size_t>((fe ? fe : le) - numstart)));
        if (field.empty() && numstart >= le)
          throw InputError(fmt::format("{}:{}: row has {} fields, expected {} ({})", file, line_no, c, ncol,
                                       "one per header column"));
        throw InputError(fmt::format("{}:{}: column {} ('{}'): '{}' is not a finite number", file, line_no, c + 1,
                                     log.columns[c], field));
      }
      q = ptr;
      while (q < le && (*q == ' ' || *q == '\t')) ++q;
      buf.push_back(val);
      if (c + 1 < ncol) {
        if (q >= le || *q != ',')
          throw InputError(fmt::format("{}:{}: row has {} fields, expected {}", file, line_no, c + 1, ncol));
        ++q;
      } else if (q < le) {
        throw InputError(fmt::format("{}:{}: row has more than {} fields (or junk after the last one)", file,
                                     line_no, ncol));
      }
    }
    ++nrow;
  }
  if (nrow < 2) throw InputError(fmt::format("{}: only {} data row(s); a flight log needs many samples", file, nrow));
  log.data = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      buf.data(), static_cast<Eigen::Index>(nrow), static_cast<Eigen::Index>(ncol));

  // Time: strictly increasing and uniform (the filters assume one period).
  const int ti = log.find("t");
  if (ti >= 0) {
    const auto t = log.data.col(ti);
    const double T = (t(t.size() - 1) - t(0)) / static_cast<double>(t.size() - 1);
    for (Eigen::Index k = 1; k < t.size(); ++k) {
      const double dt = t(k) - t(k - 1);
      const size_t ln = row_line[static_cast<size_t>(k)];
      if (!(dt > 0.0))
        throw InputError(fmt::format("{}:{}: column 't': time {} is not after the previous sample's {}; time must be "
                                     "strictly increasing", file, ln, t(k), t(k - 1)));
      if (std::abs(dt - T) > opt.period_tolerance * T + 1e-9)
        throw InputError(fmt::format(
            "{}:{}: column 't': sample period {} s differs from the mean period {} s; the log must be "
            "uniformly sampled (resample it first)",
            file, ln, dt, T));
    }
  }
  return log;
}

void write_flight_log(const FlightLog& log, const std::filesystem::path& path) {
  fmt::memory_buffer out;
  for (const auto& c : log.comments) fmt::format_to(std::back_inserter(out), "# {}\n", c);
  fmt::format_to(std::back_inserter(out), "{}\n", fmt::join(log.columns, ","));
  const Eigen::Index nc = log.data.cols();
  for (Eigen::Index r = 0; r < log.data.rows(); ++r) {
    for (Eigen::Index c = 0; c < nc; ++c) {
      const double v = log.data(r, c);
      if (!std::isfinite(v))
        throw InputError(fmt::format("{}: refusing to write non-finite value in row {} column '{}'", path.string(),
                                     r + 1, log.columns[static_cast<size_t>(c)]));
      fmt::format_to(std::back_inserter(out), "{}", v);
      out.push_back(c + 1 < nc ? ',' : '\n');
    }
  }
  write_file_atomic(path, std::string_view(out.data(), out.size()));
}

}  // namespace quadid
