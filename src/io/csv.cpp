// Flight-log CSV (docs/file-formats.md, "Flight log"): '#' comments, one header line,
// then one row per sample.
//
// Memory: a 20-minute log at 1 kHz is 1.2 million rows, and a simulator log may
// carry 18-30 columns (~0.5-0.8 GB of text). The reader therefore never holds
// the whole text: it reads fixed-size chunks and parses each complete line
// straight into a column-major matrix, sized after the first chunk from the
// file's size (growing by half if the estimate falls short) and shrunk in place
// at the end. The lines of a chunk are parsed on two threads,
// each half into its own rows. Skipped columns are not parsed, only counted.
#include "quadid/io.hpp"

#include "quadid/core/parallel.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <system_error>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <istream>
#include <string>
#include <unordered_map>

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

void read_columns_later(FlightLog& log, const std::vector<std::string>& names, double delay) {
  if (delay == 0.0 || log.rows() < 2) return;
  const Eigen::VectorXd t = log.column("t");
  const Eigen::Index n = t.size();
  for (const auto& name : names) {
    const int c = log.find(name);
    if (c < 0) continue;
    const Eigen::VectorXd x = log.data.col(c);
    Eigen::Index j = 0;  // t(j) <= t_k + delay < t(j + 1), advancing with k
    for (Eigen::Index k = 0; k < n; ++k) {
      const double tk = t(k) + delay;
      if (tk <= t(0)) { log.data(k, c) = x(0); continue; }
      if (tk >= t(n - 1)) { log.data(k, c) = x(n - 1); continue; }
      while (t(j + 1) <= tk) ++j;
      const double a = (tk - t(j)) / (t(j + 1) - t(j));
      log.data(k, c) = (1.0 - a) * x(j) + a * x(j + 1);
    }
  }
}

std::map<std::string, std::string> parse_column_map(const std::vector<std::string>& items) {
  std::map<std::string, std::string> m;
  for (const auto& it : items) {
    const auto eq = it.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == it.size())
      throw std::invalid_argument(
          fmt::format("--map '{}': expected CANONICAL=NAME or CANONICAL=-NAME (negated), e.g. tau_phi=tau_x", it));
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

// " (t looks like it is in ms: ...)" when a median step of `median` (in the
// units read, as seconds) is too long for a flight log in seconds and one of
// ms, us or ns would make it a plausible rate (20 Hz to 100 kHz); else "".
std::string time_unit_hint(double median) {
  if (!(median > kSlowestLogPeriod)) return {};
  for (const auto& [name, per_s] : {std::pair{"ms", 1e3}, std::pair{"us", 1e6}, std::pair{"ns", 1e9}}) {
    const double rate = per_s / median;
    if (rate >= 20.0 && rate <= 1e5)
      return fmt::format(" (t looks like it is in {}: a rate of {:.4g} Hz; give --time-unit {}, or convert t to seconds)",
                         name, rate, name);
  }
  return " (t must be in seconds; see --time-unit)";
}

// "--map CANONICAL=NAME" for each missing standard column whose usual other
// name the header has (case aside): a hint only, as the units and the axes
// of a column named "yaw" or "thrust" are the user's to check.
std::vector<std::string> suggested_maps(const std::vector<std::string>& missing,
                                        const std::vector<std::string>& header) {
  static const std::vector<std::pair<std::string_view, std::vector<std::string_view>>> kAliases = {
      {"t", {"time", "timestamp", "time_s", "t_s", "sec", "seconds"}},
      {"phi", {"roll"}},
      {"theta", {"pitch"}},
      {"psi", {"yaw", "heading"}},
      {"p", {"wx", "omega_x", "gyro_x", "roll_rate"}},
      {"q", {"wy", "omega_y", "gyro_y", "pitch_rate"}},
      {"r", {"wz", "omega_z", "gyro_z", "yaw_rate"}},
      {"Fz", {"thrust", "fz_n", "force_z"}},
      {"tau_phi", {"tau_x", "mx", "torque_x", "roll_torque"}},
      {"tau_theta", {"tau_y", "my", "torque_y", "pitch_torque"}},
      {"tau_psi", {"tau_z", "mz", "torque_z", "yaw_torque"}},
  };
  auto lower = [](std::string_view s) {
    std::string l(s);
    for (char& ch : l) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return l;
  };
  // The attitude as a quaternion under other names, for missing Euler angles.
  static const std::vector<std::pair<std::string_view, std::vector<std::string_view>>> kQuaternionAliases = {
      {"qw", {"q0", "quat_w", "q_w", "orientation_w", "w"}},
      {"qx", {"q1", "quat_x", "q_x", "orientation_x"}},
      {"qy", {"q2", "quat_y", "q_y", "orientation_y"}},
      {"qz", {"q3", "quat_z", "q_z", "orientation_z"}},
  };
  // The header's column with one of these names (case aside), or null.
  auto alias_in_header = [&](const std::vector<std::string_view>& aliases) -> const std::string* {
    for (const auto& h : header)
      if (std::find(aliases.begin(), aliases.end(), lower(h)) != aliases.end()) return &h;
    return nullptr;
  };
  std::vector<std::string> out;
  for (const auto& m : missing)
    for (const auto& [canon, aliases] : kAliases)
      if (canon == m)
        if (const std::string* h = alias_in_header(aliases)) out.push_back(fmt::format("--map {}={}", canon, *h));
  const auto is_missing = [&](std::string_view n) { return std::find(missing.begin(), missing.end(), n) != missing.end(); };
  if (is_missing("phi") && is_missing("theta") && is_missing("psi")) {
    std::vector<std::string> quaternion;  // all four, or none
    for (const auto& [canon, aliases] : kQuaternionAliases) {
      const std::string* h = alias_in_header(aliases);
      if (!h) {
        quaternion.clear();
        break;
      }
      quaternion.push_back(fmt::format("--map {}={}", canon, *h));
    }
    out.insert(out.end(), quaternion.begin(), quaternion.end());
  }
  return out;
}

// The attitude quaternion's columns: scalar first, body FLU -> world z up.
const std::array<std::string, 4> kQuaternionColumns = {"qw", "qx", "qy", "qz"};

// Replaces the columns qw qx qy qz by phi theta psi (ZYX, psi unwrapped), at
// qw's place. `where(k)` names data row k ("file:line") for a bad norm.
template <class Where>
void attitude_from_quaternion(FlightLog& log, Where&& where) {
  std::array<Eigen::Index, 4> qc{};
  for (size_t j = 0; j < 4; ++j) qc[j] = log.find(kQuaternionColumns[j]);
  Eigen::MatrixXd q(log.rows(), 4);
  for (size_t j = 0; j < 4; ++j) q.col(static_cast<Eigen::Index>(j)) = log.data.col(qc[j]);
  for (Eigen::Index k = 0; k < q.rows(); ++k) {
    const double norm = q.row(k).norm();
    // A unit quaternion, as logged (rounded or slightly drifted): within 10 %.
    if (!(norm > 0.9 && norm < 1.1))
      throw InputError(fmt::format("{}: columns qw qx qy qz: the quaternion's norm is {:.6g}; expected a unit "
                                   "attitude quaternion (scalar first, body FLU -> world z up)",
                                   where(k), norm));
  }
  const Eigen::MatrixXd eta = euler_zyx_series(q);
  std::vector<std::string> columns;
  Eigen::MatrixXd data(log.rows(), log.data.cols() - 1);
  for (Eigen::Index c = 0; c < log.data.cols(); ++c) {
    if (c == qc[0]) {
      for (int j = 0; j < 3; ++j) data.col(static_cast<Eigen::Index>(columns.size()) + j) = eta.col(j);
      columns.insert(columns.end(), {"phi", "theta", "psi"});
    } else if (std::find(qc.begin(), qc.end(), c) == qc.end()) {
      data.col(static_cast<Eigen::Index>(columns.size())) = log.data.col(c);
      columns.push_back(log.columns[static_cast<size_t>(c)]);
    }
  }
  log.columns = std::move(columns);
  log.data = std::move(data);
}

// The field separator, from the header line: a comma (docs/file-formats.md);
// a header without one but with tabs or semicolons (as spreadsheets save
// "CSV" in some locales) names its separator.
char header_delimiter(std::string_view header) {
  if (header.find(',') != std::string_view::npos) return ',';
  if (header.find('\t') != std::string_view::npos) return '\t';
  if (header.find(';') != std::string_view::npos) return ';';
  return ',';
}

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};

// Lines of a file; a line is valid until the next call. A regular file is
// mapped into memory (no copy through a buffer: the copy cost as much as
// finding the lines, issue 13), anything else (a pipe) read in chunks.
// The header line's names, split at `delim` and unquoted (the one split of a header).
std::vector<std::string> split_header(std::string_view line, char delim) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t end = line.find(delim, start);
    out.emplace_back(unquote(line.substr(start, end == std::string_view::npos ? line.npos : end - start)));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return out;
}

class LineReader {
 public:
  explicit LineReader(const std::filesystem::path& path) : file_(path.string()) {
    f_.reset(std::fopen(file_.c_str(), "rb"));
    if (!f_) throw InputError(fmt::format("{}: cannot open file for reading", file_));
    struct stat st {};
    if (::fstat(::fileno(f_.get()), &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
      const size_t size = static_cast<size_t>(st.st_size);
      // Populated up front when small enough to be in memory anyway: one
      // system call instead of a fault per 64 KiB.
      const int flags = MAP_PRIVATE | (size <= kPopulateBytes ? MAP_POPULATE : 0);
      void* p = ::mmap(nullptr, size, PROT_READ, flags, ::fileno(f_.get()), 0);
      if (p != MAP_FAILED) {
        ::madvise(p, size, MADV_SEQUENTIAL);
        map_ = static_cast<const char*>(p);
        map_size_ = size;
        data_ = map_;
        len_ = read_ = size;
        eof_ = true;
        return;
      }
    }
    buf_.reset(new char[kChunk]);
    cap_ = kChunk;
    data_ = buf_.get();
  }
  ~LineReader() {
    if (map_) ::munmap(const_cast<char*>(map_), map_size_);
  }
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  bool next(std::string_view& line) {
    while (true) {
      const char* nl = static_cast<const char*>(std::memchr(data_ + pos_, '\n', len_ - pos_));
      if (nl || (eof_ && pos_ < len_)) {
        const char* b = data_ + pos_;
        const char* e = nl ? nl : data_ + len_;
        line = std::string_view(b, static_cast<size_t>(e - b));
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        const size_t next = nl ? static_cast<size_t>(nl - data_) + 1 : len_;
        pos_ = next;
        if (++line_no_ == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // UTF-8 BOM
        return true;
      }
      if (eof_) return false;
      refill();
    }
  }
  size_t line_no() const { return line_no_; }
  /// Bytes of the file consumed by the lines returned so far.
  std::uint64_t consumed() const { return read_ - (len_ - pos_); }
  /// The file's size in bytes, or 0 when unknown (e.g. a pipe).
  std::uint64_t file_size() const {
    std::error_code ec;
    const std::uintmax_t n = std::filesystem::file_size(file_, ec);
    return ec ? 0 : static_cast<std::uint64_t>(n);
  }

  // The text of the next complete lines, at most ~kChunk bytes unless one
  // line is longer (at the end of the file the last line need not end in a
  // newline), valid until the next call; `first_line` is its first line's
  // number. The caller splits it into lines and reports their count with
  // lines_taken(). False at the end of the file.
  bool next_text(std::string_view& text, size_t& first_line) {
    while (true) {
      const char* b = data_ + pos_;
      const char* end = data_ + len_;
      const char* stop = end;
      if (!eof_ || static_cast<size_t>(end - b) > kChunk) {
        // Up to the last newline within kChunk (or the first beyond it); an
        // incomplete line at the end of the buffer waits for the next refill.
        const size_t window = std::min(static_cast<size_t>(end - b), kChunk);
        const void* nl = memrchr(b, '\n', window);
        if (!nl && window < static_cast<size_t>(end - b)) nl = std::memchr(b + window, '\n', static_cast<size_t>(end - b) - window);
        stop = nl ? static_cast<const char*>(nl) + 1 : (eof_ ? end : b);
      }
      if (stop > b) {
        text = std::string_view(b, static_cast<size_t>(stop - b));
        first_line = line_no_ + 1;
        pos_ = static_cast<size_t>(stop - data_);
        return true;
      }
      if (eof_) return false;
      refill();
    }
  }
  void lines_taken(size_t n) { line_no_ += n; }

 private:
  // 4 MiB: a block of lines large enough to split between two threads
  // (issue 13); the buffer grows beyond it only for a longer line.
  static constexpr size_t kChunk = size_t{1} << 22;
  static constexpr size_t kPopulateBytes = size_t{1} << 28;

  void refill() {  // the chunked reader only
    // Keep the incomplete tail line; grow the buffer only for a line longer than it.
    const size_t keep = len_ - pos_;
    if (pos_ > 0) std::memmove(buf_.get(), buf_.get() + pos_, keep);
    pos_ = 0;
    len_ = keep;
    if (cap_ - len_ < kChunk / 2) {
      std::unique_ptr<char[]> bigger(new char[2 * cap_]);
      std::memcpy(bigger.get(), buf_.get(), len_);
      buf_ = std::move(bigger);
      cap_ *= 2;
    }
    data_ = buf_.get();
    const size_t got = std::fread(buf_.get() + len_, 1, cap_ - len_, f_.get());
    if (got == 0) {
      if (std::ferror(f_.get())) throw InputError(fmt::format("{}: read error", file_));
      eof_ = true;
    }
    len_ += got;
    read_ += got;
  }

  std::string file_;
  std::unique_ptr<std::FILE, FileCloser> f_;
  std::unique_ptr<char[]> buf_;  // uninitialized: zeroing it would only cost time
  const char* map_ = nullptr;    // the mapped file, or null
  size_t map_size_ = 0;
  const char* data_ = nullptr;   // map_ or buf_
  size_t cap_ = 0, pos_ = 0, len_ = 0, line_no_ = 0;
  std::uint64_t read_ = 0;  // bytes read from the file
  bool eof_ = false;
};

// The kept columns, written straight into a column-major matrix whose row
// capacity grows by half when full; at the end the columns are packed and the
// buffer shrunk in place (no second copy of the data).
class ColumnStore {
 public:
  explicit ColumnStore(Eigen::Index ncol) : ncol_(ncol) {}
  Eigen::Index rows() const { return rows_; }
  Eigen::Index capacity() const { return cap_; }
  void reserve(Eigen::Index cap) {
    if (cap <= cap_) return;
    Eigen::MatrixXd bigger(cap, ncol_);
    for (Eigen::Index j = 0; j < ncol_; ++j)
      std::copy(m_.data() + j * cap_, m_.data() + j * cap_ + rows_, bigger.data() + j * cap);
    m_.swap(bigger);
    cap_ = cap;
  }
  // Appends `count` rows and returns a pointer to element (first new row, 0);
  // column j is at offset j * capacity().
  double* add_rows(Eigen::Index count) {
    if (rows_ + count > cap_) reserve(std::max<Eigen::Index>({1024, cap_ + cap_ / 2, rows_ + count}));
    double* p = m_.data() + rows_;
    rows_ += count;
    return p;
  }
  Eigen::MatrixXd take() {
    // Pack column j from offset j*cap to j*rows (never overlapping a later
    // column's unread data), then shrink: resize() with an unchanged
    // coefficient count keeps the values (documented), and conservativeResize
    // of a column-major matrix that only loses columns reallocates in place.
    if (rows_ < cap_) {
      double* d = m_.data();
      for (Eigen::Index j = 1; j < ncol_; ++j) std::memmove(d + j * rows_, d + j * cap_, sizeof(double) * rows_);
      m_.resize(1, cap_ * ncol_);
      m_.conservativeResize(1, rows_ * ncol_);
    }
    m_.resize(rows_, ncol_);
    cap_ = rows_ = 0;
    return std::move(m_);
  }

 private:
  Eigen::Index ncol_, rows_ = 0, cap_ = 0;
  Eigen::MatrixXd m_;
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

namespace {

// The options' own ranges, before any file is touched.
void validate_read_options(const CsvReadOptions& opt) {
  if (!(opt.period_tolerance >= 0.0 && opt.period_tolerance < 0.5))
    throw std::invalid_argument(
        fmt::format("CsvReadOptions: period_tolerance={} must be in [0, 0.5)", opt.period_tolerance));
  if (opt.threads < 0 || opt.threads > 2)
    throw std::invalid_argument(fmt::format("CsvReadOptions: threads={} must be 0 (automatic), 1 or 2", opt.threads));
  if (!(opt.time_units_per_second > 0.0) || !std::isfinite(opt.time_units_per_second))
    throw std::invalid_argument(fmt::format("CsvReadOptions: time_units_per_second={} must be positive",
                                            opt.time_units_per_second));
  if (!(std::abs(opt.gyro_delay) <= 1.0))
    throw std::invalid_argument(fmt::format("CsvReadOptions: gyro_delay={} s must be within [-1, 1]",
                                            opt.gyro_delay));
}

// A block of text split into lines: the data lines are kept (blank and comment
// lines skipped), with their numbers counted from the part's first line.
struct TextPart {
  std::string_view text;
  std::vector<std::string_view> lines;  // the data lines
  std::vector<size_t> line_no;          // their line numbers, counted from the part's first line (0)
  size_t count = 0;                     // all lines, data or not
  size_t first_line = 0, first_row = 0;  // of the part's first line and first data line (block-relative row)

  void split() {
    lines.clear();
    line_no.clear();
    count = 0;
    const char* b = text.data();
    const char* end = b + text.size();
    while (b < end) {
      const char* nl = static_cast<const char*>(std::memchr(b, '\n', static_cast<size_t>(end - b)));
      std::string_view line(b, static_cast<size_t>((nl ? nl : end) - b));
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      if (!trim(line).empty() && line.front() != '#') {
        lines.push_back(line);
        line_no.push_back(count);
      }
      ++count;
      b = nl ? nl + 1 : end;
    }
  }
};

// One read of a flight-log CSV, in the file's order: comments and header, the
// header's checks and --map, the required columns, the rows, then the time column.
class CsvRead {
 public:
  CsvRead(const std::filesystem::path& path, const CsvReadOptions& opt) : file_(path.string()), opt_(opt), in_(path) {}

  FlightLog run() {
    read_header();
    check_header_names();
    apply_map();
    check_required_columns();
    choose_columns();
    read_rows();
    const auto nrow = store_.rows();
    if (nrow < 2)
      throw InputError(fmt::format("{}: only {} data row(s); a flight log needs many samples", file_, nrow));
    log_.data = store_.take();
    for (const auto& c : negated_)
      if (const int k = log_.find(c); k >= 0) log_.data.col(k) = -log_.data.col(k);
    if (from_quaternion_) attitude_from_quaternion(log_, [&](Eigen::Index k) {
        return fmt::format("{}:{}", file_, row_lines_.line_of(static_cast<size_t>(k)));
      });
    check_time();
    read_columns_later(log_, {"p", "q", "r"}, opt_.gyro_delay);
    return std::move(log_);
  }

 private:
  int find_in(std::string_view name) const {
    for (size_t i = 0; i < header_.size(); ++i)
      if (header_[i] == name) return static_cast<int>(i);
    return -1;
  }
  bool requires_column(std::string_view n) const {
    return std::find(required_.begin(), required_.end(), n) != required_.end();
  }

  // Comments, then the header line; its separator names the file's.
  void read_header() {
    std::string_view line;
    bool have_header = false;
    while (in_.next(line)) {
      if (trim(line).empty()) continue;
      if (line.front() == '#') {
        log_.comments.emplace_back(trim(line.substr(1)));
        continue;
      }
      delim_ = header_delimiter(line);
      header_ = split_header(line, delim_);
      have_header = true;
      break;
    }
    if (!have_header)
      throw InputError(fmt::format("{}: no header line (expected column names such as t,x,y,z,...)", file_));
    header_line_ = in_.line_no();
  }

  // Every column named, and no name twice.
  void check_header_names() const {
    std::unordered_map<std::string_view, size_t> seen;  // wide logs have thousands of columns
    for (size_t i = 0; i < header_.size(); ++i) {
      if (header_[i].empty())
        throw InputError(fmt::format("{}:{}: column {} has an empty name{}", file_, header_line_, i + 1,
                                     i + 1 == header_.size() && i > 0
                                         ? " (a separator at the end of the header line? remove it from every line)"
                                         : ""));
      const auto [it, fresh] = seen.emplace(header_[i], i);
      if (!fresh)
        throw InputError(fmt::format("{}:{}: column '{}' appears twice (columns {} and {})", file_, header_line_,
                                     header_[i], it->second + 1, i + 1));
    }
  }

  // --map canonical=name: rename the file's column to the canonical one
  // (map_columns); canonical=-name takes the column negated.
  void apply_map() {
    ColumnMapping m;
    try {
      m = map_columns(header_, opt_.map, true, "the file");
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}:{}: {}", file_, header_line_, e.what()));
    }
    header_ = std::move(m.header);
    for (int i : m.negated) negated_.push_back(header_[static_cast<size_t>(i)]);
  }

  // The attitude as a quaternion (docs/file-formats.md): qw qx qy qz stand for
  // phi theta psi when the file has none of the three. Then every required
  // column must be there, with a hint for the usual other names.
  void check_required_columns() {
    required_ = opt_.required;
    if (requires_column("phi") && requires_column("theta") && requires_column("psi") && find_in("phi") < 0 &&
        find_in("theta") < 0 && find_in("psi") < 0 && find_in("qw") >= 0) {
      std::erase_if(required_, [](const std::string& n) { return n == "phi" || n == "theta" || n == "psi"; });
      required_.insert(required_.end(), kQuaternionColumns.begin(), kQuaternionColumns.end());
      from_quaternion_ = true;
    }
    std::vector<std::string> missing;
    for (const auto& r : required_)
      if (find_in(r) < 0) missing.push_back(r);
    if (missing.empty()) return;
    const std::vector<std::string> maps = suggested_maps(missing, header_);
    throw InputError(fmt::format("{}:{}: missing required column(s): {} (the file has: {}; use --map CANONICAL=NAME "
                                 "for other names{})",
                                 file_, header_line_, fmt::join(missing, ", "), fmt::join(header_, ","),
                                 maps.empty() ? std::string()
                                              : fmt::format("; perhaps {} (check their units and axes against "
                                                            "the flight-log format: SI, body FLU, z up)",
                                                            fmt::join(maps, " "))));
  }

  // Which file columns are stored, and where.
  void choose_columns() {
    nfile_ = header_.size();
    slot_.assign(nfile_, -1);
    for (size_t i = 0; i < nfile_; ++i) {
      const bool keep = opt_.keep_extra_columns || requires_column(header_[i]);
      if (keep) {
        slot_[i] = static_cast<int>(log_.columns.size());
        log_.columns.push_back(header_[i]);
      }
    }
    store_ = ColumnStore(static_cast<Eigen::Index>(log_.columns.size()));
  }

  // Blanks around a number are allowed; a tab only when it does not separate the fields.
  bool blank(char ch) const { return ch == ' ' || (ch == '\t' && delim_ != '\t'); }

  // One data row into row[slot * stride]; throws InputError naming the line.
  void parse_row(std::string_view line, size_t line_no, double* row, Eigen::Index stride) const {
    const char* q = line.data();
    const char* le = q + line.size();
    for (size_t c = 0; c < nfile_; ++c) {
      const char* field_end;
      if (slot_[c] >= 0) {
        // Parse in place: from_chars stops at the separator, then only blanks may follow.
        const char* s = q;
        while (s < le && blank(*s)) ++s;
        if (s < le && *s == '+') ++s;
        double val = 0.0;
        const auto [ptr, ec] = std::from_chars(s, le, val);
        const char* e = ptr;
        while (e < le && blank(*e)) ++e;
        if (ec != std::errc() || (e < le && *e != delim_) || !std::isfinite(val)) bad_field(q, le, c, line_no);
        row[slot_[c] * stride] = val;
        field_end = e;
      } else {
        const char* fe = static_cast<const char*>(std::memchr(q, delim_, static_cast<size_t>(le - q)));
        field_end = fe ? fe : le;
      }
      const bool more = field_end < le;  // a separator follows
      if (!more && c + 1 < nfile_)
        throw InputError(fmt::format("{}:{}: row has {} field(s), expected {} (one per header column)", file_,
                                     line_no, c + 1, nfile_));
      if (more && c + 1 == nfile_)
        throw InputError(fmt::format("{}:{}: row has more than {} fields", file_, line_no, nfile_));
      q = field_end + 1;
    }
  }

  // The error of field c (from q to the line's end le), which is no finite number.
  [[noreturn]] void bad_field(const char* q, const char* le, size_t c, size_t line_no) const {
    const char* fe = static_cast<const char*>(std::memchr(q, delim_, static_cast<size_t>(le - q)));
    const std::string_view field = trim(std::string_view(q, static_cast<size_t>((fe ? fe : le) - q)));
    if (q >= le && c > 0)
      throw InputError(fmt::format("{}:{}: row has {} field(s), expected {} (one per header column)", file_, line_no,
                                   c, nfile_));
    const bool decimal_comma = delim_ != ',' && field.find(',') != std::string_view::npos;
    throw InputError(fmt::format("{}:{}: column {} ('{}'): {} is not a finite number{}", file_, line_no, c + 1,
                                 header_[c], field.empty() ? "an empty field" : fmt::format("'{}'", field),
                                 decimal_comma ? " (a decimal comma? write numbers with a decimal point)" : ""));
  }

  // The rows, a buffer's worth of text at a time, in two phases each split
  // between two threads when allowed (the halves cut at a newline): the data
  // lines are picked out (blank and comment lines skipped), then given their
  // rows and parsed. Each half stops at its first bad line; the first half's
  // error is the earlier one.
  void read_rows() {
    const bool two = detail::use_second_thread(opt_.threads);
    constexpr size_t kParallelBytes = size_t{1} << 17;  // below this a second thread costs more than it saves
    std::array<TextPart, 2> parts;
    // Capacity: after the first block, the rest of the file at the first rows'
    // mean length, with 10% to spare (growing by copies costs time and fresh
    // pages; capacity never written is never touched, so the spare costs little).
    const std::uint64_t data_start = in_.consumed(), file_bytes = in_.file_size();
    bool estimated = false;
    std::string_view text;
    size_t first_line_no = 0;
    while (in_.next_text(text, first_line_no)) {
      const bool parallel = two && text.size() >= kParallelBytes;
      size_t cut = text.size();
      if (parallel) {  // just after the newline nearest the middle
        const size_t nl = text.rfind('\n', text.size() / 2);
        cut = nl == std::string_view::npos ? text.size() : nl + 1;
      }
      parts[0].text = text.substr(0, cut);
      parts[1].text = text.substr(cut);
      detail::run_both(parallel, [&] { parts[0].split(); }, [&] { parts[1].split(); });
      in_.lines_taken(parts[0].count + parts[1].count);
      parts[0].first_line = first_line_no;
      parts[1].first_line = first_line_no + parts[0].count;
      parts[1].first_row = parts[0].lines.size();
      const size_t n0 = parts[0].lines.size(), n1 = parts[1].lines.size();
      if (n0 + n1 == 0) continue;
      for (const TextPart& part : parts)
        for (size_t r = 0; r < part.lines.size(); ++r)
          row_lines_.add(static_cast<size_t>(store_.rows()) + part.first_row + r, part.first_line + part.line_no[r]);
      const Eigen::Index count = static_cast<Eigen::Index>(n0 + n1);
      if (!estimated) {
        estimated = true;
        const std::uint64_t used = in_.consumed() - data_start;
        if (file_bytes > in_.consumed() && used > 0) {
          const double per_row = static_cast<double>(used) / static_cast<double>(count);
          const double left = static_cast<double>(file_bytes - in_.consumed());
          store_.reserve(count + 16 + static_cast<Eigen::Index>(1.1 * left / per_row));
        }
      }
      double* base = store_.add_rows(count);
      const Eigen::Index stride = store_.capacity();
      auto parse_part = [&](const TextPart& part) {
        for (size_t r = 0; r < part.lines.size(); ++r)
          parse_row(part.lines[r], part.first_line + part.line_no[r],
                    base + static_cast<Eigen::Index>(part.first_row + r), stride);
      };
      detail::run_both(parallel && n0 > 0 && n1 > 0, [&] { parse_part(parts[0]); }, [&] { parse_part(parts[1]); });
    }
  }

  // Time: strictly increasing and uniform (the filters assume one period).
  void check_time() {
    const int ti = log_.find("t");
    if (ti < 0) return;
    // Divided, not multiplied by 1e-3: integer milliseconds then give the
    // doubles that the same instants written in seconds would.
    if (opt_.time_units_per_second != 1.0) log_.data.col(ti) /= opt_.time_units_per_second;
    const auto t = log_.data.col(ti);
    const signal::SamplePeriodCheck chk = signal::check_sample_period(t, opt_.period_tolerance);
    if (!chk.ok()) {
      const Eigen::Index k = chk.bad;
      const size_t line = row_lines_.line_of(static_cast<size_t>(k));
      if (!(chk.step > 0.0))
        throw InputError(fmt::format("{}:{}: column 't': time {} is not after the previous sample's {}; time must be "
                                     "strictly increasing",
                                     file_, line, t(k), t(k - 1)));
      throw InputError(fmt::format(
          "{}:{}: column 't': sample period {:.6g} s (from t = {:.9g} to {:.9g}) where the log's period is {:.6g} s (its median "
          "step): {:+.3g}%, more than the {:g}% tolerated; the log must be uniformly sampled (a gap or a rate "
          "change? resample it first){}",
          file_, line, chk.step, t(k - 1), t(k), chk.median, 100.0 * (chk.step / chk.median - 1.0),
          100.0 * opt_.period_tolerance, time_unit_hint(chk.median)));
    }
    if (chk.median > kSlowestLogPeriod)
      throw InputError(fmt::format("{}: column 't': the median time step is {:.6g} s, a rate of {:.4g} Hz: too slow "
                                   "for a flight log{}",
                                   file_, chk.median, 1.0 / chk.median, time_unit_hint(chk.median)));
  }

  const std::string file_;
  const CsvReadOptions& opt_;
  LineReader in_;
  FlightLog log_;
  std::vector<std::string> header_;  // the file's column names, after --map
  char delim_ = ',';  // the header's (header_delimiter): a spreadsheet may save tabs or semicolons
  size_t header_line_ = 0;
  std::vector<std::string> required_;  // opt.required, with qw qx qy qz for phi theta psi from a quaternion
  bool from_quaternion_ = false;
  std::vector<std::string> negated_;  // canonical columns mapped from -name
  size_t nfile_ = 0;       // columns in the file
  std::vector<int> slot_;  // each file column's column in the log, or -1 (not stored)
  ColumnStore store_{0};
  RowLines row_lines_;
};

}  // namespace

std::vector<std::string> read_csv_header(const std::filesystem::path& path) {
  LineReader in(path);
  std::string_view line;
  std::vector<std::string> out;
  while (in.next(line)) {
    if (trim(line).empty() || line.front() == '#') continue;
    return split_header(line, header_delimiter(line));
  }
  return out;
}

FlightLog read_flight_log(const std::filesystem::path& path, const CsvReadOptions& opt) {
  validate_read_options(opt);
  return CsvRead(path, opt).run();
}

double parse_time_unit(std::string_view name) {
  if (name == "s") return 1.0;
  if (name == "ms") return 1e3;
  if (name == "us") return 1e6;
  if (name == "ns") return 1e9;
  throw std::invalid_argument(fmt::format("--time-unit {}: expected s, ms, us or ns (the unit of column t)", name));
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

CsvRowReader::CsvRowReader(std::istream& in, std::string source, const CsvReadOptions& opt)
    : in_(in), source_(std::move(source)), names_(opt.required) {
  while (std::getline(in_, text_)) {
    ++line_;
    if (!text_.empty() && text_.back() == '\r') text_.pop_back();
    if (text_.empty() || text_[0] == '#') continue;
    delim_ = header_delimiter(text_);
    const std::vector<std::string> raw = split_header(text_, delim_);
    ColumnMapping m;
    try {
      m = map_columns(raw, opt.map, true, "the input");
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}:{}: {}", source_, line_, e.what()));
    }
    width_ = m.header.size();
    for (const auto& name : names_) {
      const auto it = std::find(m.header.begin(), m.header.end(), name);
      if (it == m.header.end())
        throw InputError(fmt::format("{}:{}: the header has no column '{}' (needed: {}; header: {})", source_, line_,
                                     name, fmt::join(names_, " "), fmt::join(raw, " ")));
      const int i = static_cast<int>(it - m.header.begin());
      index_.push_back(i);
      sign_.push_back(std::find(m.negated.begin(), m.negated.end(), i) != m.negated.end() ? -1.0 : 1.0);
    }
    return;
  }
  throw InputError(fmt::format("{}: no header line (expected the flight-log columns: {})", source_,
                               fmt::join(names_, " ")));
}

bool CsvRowReader::next(std::vector<double>& values) {
  while (std::getline(in_, text_)) {
    ++line_;
    if (!text_.empty() && text_.back() == '\r') text_.pop_back();
    if (text_.empty() || text_[0] == '#') continue;
    fields_.clear();
    size_t start = 0;
    while (true) {  // split in place: fields_ reuses its strings' storage
      const size_t end = text_.find(delim_, start);
      fields_.emplace_back(text_, start, end == std::string::npos ? std::string::npos : end - start);
      if (end == std::string::npos) break;
      start = end + 1;
    }
    if (fields_.size() != width_)
      throw InputError(fmt::format("{}:{}: {} fields, the header has {}", source_, line_, fields_.size(), width_));
    values.resize(index_.size());
    for (size_t j = 0; j < index_.size(); ++j) {
      const std::string& f = fields_[static_cast<size_t>(index_[j])];
      double v = 0.0;
      if (!parse_finite_double(f, v))
        throw InputError(fmt::format("{}:{}:{}: '{}' in column {} is not a finite number", source_, line_,
                                     index_[j] + 1, f, names_[j]));
      values[j] = sign_[j] * v;
    }
    return true;
  }
  return false;
}

}  // namespace quadid
