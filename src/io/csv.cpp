// Flight-log CSV (DESIGN.md, "Flight log"): '#' comments, one header line,
// then one row per sample.
//
// Memory: a 20-minute log at 1 kHz is 1.2 million rows, and a simulator log may
// carry 30+ columns (~0.8 GB of text). The reader therefore never holds the
// whole text: it reads fixed-size chunks, parses each complete line, stores the
// kept columns in row blocks, and assembles the column-major matrix block by
// block at the end (freeing each block as it goes), so the peak is about the
// final matrix plus one block. Skipped columns are not parsed, only counted.
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <unistd.h>

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
    const std::string canon = it.substr(0, eq);
    if (m.count(canon))
      throw std::invalid_argument(fmt::format("--map '{}': '{}' is mapped twice", it, canon));
    m[canon] = it.substr(eq + 1);
  }
  return m;
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Header names may be quoted ("t","x",...) by spreadsheet tools.
std::string_view unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = trim(s.substr(1, s.size() - 2));
  return s;
}

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};

// Lines of a file, read in chunks; a line is valid until the next call.
class LineReader {
 public:
  explicit LineReader(const std::filesystem::path& path) : file_(path.string()) {
    f_.reset(std::fopen(file_.c_str(), "rb"));
    if (!f_) throw InputError(fmt::format("{}: cannot open file for reading", file_));
    buf_.resize(kChunk);
  }

  bool next(std::string_view& line) {
    while (true) {
      const char* nl = static_cast<const char*>(std::memchr(buf_.data() + pos_, '\n', len_ - pos_));
      if (nl || (eof_ && pos_ < len_)) {
        const char* b = buf_.data() + pos_;
        const char* e = nl ? nl : buf_.data() + len_;
        line = std::string_view(b, static_cast<size_t>(e - b));
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        pos_ = nl ? static_cast<size_t>(nl - buf_.data()) + 1 : len_;
        if (++line_no_ == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // UTF-8 BOM
        return true;
      }
      if (eof_) return false;
      refill();
    }
  }
  size_t line_no() const { return line_no_; }

 private:
  static constexpr size_t kChunk = size_t{1} << 20;

  void refill() {
    // Keep the incomplete tail line; grow the buffer only for a line longer than it.
    const size_t keep = len_ - pos_;
    if (pos_ > 0) std::memmove(buf_.data(), buf_.data() + pos_, keep);
    pos_ = 0;
    len_ = keep;
    if (buf_.size() - len_ < kChunk / 2) buf_.resize(buf_.size() * 2);
    const size_t got = std::fread(buf_.data() + len_, 1, buf_.size() - len_, f_.get());
    if (got == 0) {
      if (std::ferror(f_.get())) throw InputError(fmt::format("{}: read error", file_));
      eof_ = true;
    }
    len_ += got;
  }

  std::string file_;
  std::unique_ptr<std::FILE, FileCloser> f_;
  std::vector<char> buf_;
  size_t pos_ = 0, len_ = 0, line_no_ = 0;
  bool eof_ = false;
};

// Row-major blocks of the kept columns; assembled into one column-major matrix.
class RowBlocks {
 public:
  explicit RowBlocks(size_t ncol) : ncol_(ncol) {}
  double* new_row() {
    if (blocks_.empty() || used_ == kRows) {
      blocks_.emplace_back(kRows * ncol_);
      used_ = 0;
    }
    ++rows_;
    return blocks_.back().data() + (used_++) * ncol_;
  }
  size_t rows() const { return rows_; }
  Eigen::MatrixXd assemble() {
    Eigen::MatrixXd m(static_cast<Eigen::Index>(rows_), static_cast<Eigen::Index>(ncol_));
    size_t r0 = 0;
    for (auto& b : blocks_) {
      const size_t nr = std::min(kRows, rows_ - r0);
      m.middleRows(static_cast<Eigen::Index>(r0), static_cast<Eigen::Index>(nr)) =
          Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
              b.data(), static_cast<Eigen::Index>(nr), static_cast<Eigen::Index>(ncol_));
      r0 += nr;
      std::vector<double>().swap(b);  // free as we go: peak ~ matrix + one block
    }
    blocks_.clear();
    return m;
  }

 private:
  static constexpr size_t kRows = 8192;
  size_t ncol_, used_ = 0, rows_ = 0;
  std::vector<std::vector<double>> blocks_;
};

// File line of data row k: rows are consecutive lines except where blank or
// comment lines interrupt; only the interruptions are recorded.
class RowLines {
 public:
  void add(size_t row, size_t line) {
    if (starts_.empty() || line != starts_.back().second + (row - starts_.back().first))
      starts_.emplace_back(row, line);
  }
  size_t line_of(size_t row) const {
    auto it = std::upper_bound(starts_.begin(), starts_.end(), row,
                               [](size_t r, const std::pair<size_t, size_t>& s) { return r < s.first; });
    --it;
    return it->second + (row - it->first);
  }

 private:
  std::vector<std::pair<size_t, size_t>> starts_;
};

}  // namespace

FlightLog read_flight_log(const std::filesystem::path& path, const CsvReadOptions& opt) {
  const std::string file = path.string();
  if (!(opt.period_tolerance >= 0.0))
    throw std::invalid_argument(fmt::format("CsvReadOptions: period_tolerance={} must be >= 0", opt.period_tolerance));
  LineReader in(path);
  FlightLog log;

  // Comments and header.
  std::string_view line;
  bool have_header = false;
  std::vector<std::string> header;
  while (in.next(line)) {
    if (trim(line).empty()) continue;
    if (line.front() == '#') {
      log.comments.emplace_back(trim(line.substr(1)));
      continue;
    }
    size_t start = 0;
    while (true) {
      const size_t comma = line.find(',', start);
      header.emplace_back(unquote(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    have_header = true;
    break;
  }
  if (!have_header)
    throw InputError(fmt::format("{}: no header line (expected column names such as t,x,y,z,...)", file));
  const size_t header_line = in.line_no();
  auto find_in = [&](std::string_view name) -> int {
    for (size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return static_cast<int>(i);
    return -1;
  };
  for (size_t i = 0; i < header.size(); ++i) {
    if (header[i].empty())
      throw InputError(fmt::format("{}:{}: column {} has an empty name", file, header_line, i + 1));
    for (size_t j = 0; j < i; ++j)
      if (header[j] == header[i])
        throw InputError(fmt::format("{}:{}: column '{}' appears twice (columns {} and {})", file, header_line,
                                     header[i], j + 1, i + 1));
  }
  // --map canonical=name: rename the file's column to the canonical one. All
  // renames are checked against the original header, so they cannot chain.
  std::vector<std::string> renamed = header;
  std::vector<std::string> sources;  // file columns renamed away by the map
  for (const auto& kv : opt.map) sources.push_back(kv.second);
  for (const auto& [canon, name] : opt.map) {
    const int i = find_in(name);
    if (i < 0)
      throw InputError(fmt::format("{}:{}: --map {}={}: the file has no column '{}' (it has: {})", file,
                                   header_line, canon, name, name, fmt::join(header, ",")));
    const int j = find_in(canon);
    if (j >= 0 && canon != name && std::find(sources.begin(), sources.end(), canon) == sources.end())
      throw InputError(fmt::format("{}:{}: --map {}={}: the file already has a column '{}'", file, header_line,
                                   canon, name, canon));
    renamed[static_cast<size_t>(i)] = canon;
  }
  header = std::move(renamed);
  std::vector<std::string> missing;
  for (const auto& r : opt.required)
    if (find_in(r) < 0) missing.push_back(r);
  if (!missing.empty())
    throw InputError(fmt::format("{}:{}: missing required column(s): {} (the file has: {}; use --map CANONICAL=NAME "
                                 "for other names)",
                                 file, header_line, fmt::join(missing, ", "), fmt::join(header, ",")));

  // Which file columns are stored, and where.
  const size_t nfile = header.size();
  std::vector<int> slot(nfile, -1);
  for (size_t i = 0; i < nfile; ++i) {
    const bool keep = opt.keep_extra_columns ||
                      std::find(opt.required.begin(), opt.required.end(), header[i]) != opt.required.end();
    if (keep) {
      slot[i] = static_cast<int>(log.columns.size());
      log.columns.push_back(header[i]);
    }
  }
  const size_t nkeep = log.columns.size();

  RowBlocks blocks(nkeep);
  RowLines row_lines;
  while (in.next(line)) {
    if (trim(line).empty() || line.front() == '#') continue;
    const size_t line_no = in.line_no();
    row_lines.add(blocks.rows(), line_no);
    double* row = blocks.new_row();
    const char* q = line.data();
    const char* le = q + line.size();
    for (size_t c = 0; c < nfile; ++c) {
      const char* fe = static_cast<const char*>(std::memchr(q, ',', static_cast<size_t>(le - q)));
      const char* field_end = fe ? fe : le;
      if (!fe && c + 1 < nfile)
        throw InputError(fmt::format("{}:{}: row has {} field(s), expected {} (one per header column)", file,
                                     line_no, c + 1, nfile));
      if (fe && c + 1 == nfile)
        throw InputError(fmt::format("{}:{}: row has more than {} fields", file, line_no, nfile));
      if (slot[c] >= 0) {
        const char* s = q;
        const char* e = field_end;
        while (s < e && (*s == ' ' || *s == '\t')) ++s;
        while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) --e;
        if (s < e && *s == '+') ++s;
        double val = 0.0;
        const auto [ptr, ec] = std::from_chars(s, e, val);
        if (ec != std::errc() || ptr != e || !std::isfinite(val)) {
          const std::string_view field = trim(std::string_view(q, static_cast<size_t>(field_end - q)));
          throw InputError(fmt::format("{}:{}: column {} ('{}'): {} is not a finite number", file, line_no, c + 1,
                                       header[c], field.empty() ? "an empty field" : fmt::format("'{}'", field)));
        }
        row[slot[c]] = val;
      }
      q = field_end + 1;
    }
  }
  const size_t nrow = blocks.rows();
  if (nrow < 2)
    throw InputError(fmt::format("{}: only {} data row(s); a flight log needs many samples", file, nrow));
  log.data = blocks.assemble();

  // Time: strictly increasing and uniform (the filters assume one period).
  const int ti = log.find("t");
  if (ti >= 0) {
    const auto t = log.data.col(ti);
    const double T = (t(t.size() - 1) - t(0)) / static_cast<double>(t.size() - 1);
    for (Eigen::Index k = 1; k < t.size(); ++k) {
      const double dt = t(k) - t(k - 1);
      if (!(dt > 0.0))
        throw InputError(fmt::format("{}:{}: column 't': time {} is not after the previous sample's {}; time must be "
                                     "strictly increasing",
                                     file, row_lines.line_of(static_cast<size_t>(k)), t(k), t(k - 1)));
      if (std::abs(dt - T) > opt.period_tolerance * T + 1e-9)
        throw InputError(fmt::format(
            "{}:{}: column 't': sample period {} s (from {} to {}) differs from the mean period {} s by more than "
            "{}%; the log must be uniformly sampled (resample it first)",
            file, row_lines.line_of(static_cast<size_t>(k)), dt, t(k - 1), t(k), T, 100.0 * opt.period_tolerance));
    }
  }
  return log;
}

void write_flight_log(const FlightLog& log, const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  // Streamed to a temporary file beside the target, then renamed: atomic like
  // write_file_atomic, without holding the whole text (a long log is ~1 GB).
  static std::atomic<unsigned> counter{0};
  if (path.has_parent_path() && !fs::exists(path.parent_path()))
    throw InputError(fmt::format("{}: directory {} does not exist", path.string(), path.parent_path().string()));
  const Eigen::Index nc = log.data.cols();
  if (static_cast<size_t>(nc) != log.columns.size())
    throw std::invalid_argument(fmt::format("write_flight_log: {} column names for {} data columns",
                                            log.columns.size(), nc));
  for (Eigen::Index c = 0; c < nc; ++c)
    for (Eigen::Index r = 0; r < log.data.rows(); ++r)
      if (!std::isfinite(log.data(r, c)))
        throw InputError(fmt::format("{}: refusing to write non-finite value in row {} column '{}'", path.string(),
                                     r + 1, log.columns[static_cast<size_t>(c)]));
  const fs::path tmp = path.string() + fmt::format(".tmp.{}.{}", static_cast<long>(::getpid()), counter++);
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(tmp.string().c_str(), "wb"));
  if (!f) throw InputError(fmt::format("{}: cannot open for writing", tmp.string()));
  bool ok = true;
  fmt::memory_buffer out;
  auto flush = [&] {
    if (out.size() && std::fwrite(out.data(), 1, out.size(), f.get()) != out.size()) ok = false;
    out.clear();
  };
  for (const auto& c : log.comments) fmt::format_to(std::back_inserter(out), "# {}\n", c);
  fmt::format_to(std::back_inserter(out), "{}\n", fmt::join(log.columns, ","));
  for (Eigen::Index r = 0; r < log.data.rows() && ok; ++r) {
    for (Eigen::Index c = 0; c < nc; ++c) {
      fmt::format_to(std::back_inserter(out), "{}", log.data(r, c));
      out.push_back(c + 1 < nc ? ',' : '\n');
    }
    if (out.size() > (size_t{1} << 20)) flush();
  }
  flush();
  if (std::fflush(f.get()) != 0) ok = false;
  if (std::fclose(f.release()) != 0) ok = false;
  std::error_code ec;
  if (!ok) {
    fs::remove(tmp, ec);
    throw InputError(fmt::format("{}: write failed (disk full?)", path.string()));
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError(fmt::format("{}: cannot replace file: {}", path.string(), ec.message()));
  }
}

}  // namespace quadid
