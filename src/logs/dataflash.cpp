// ArduPilot DataFlash (.bin) logs (docs/ardupilot.md). Every record is the
// header 0xA3 0x95, a type byte and a payload; FMT records (type 128, 89
// bytes) define each type's name, format characters and columns, FMTU gives
// each column a unit id and a multiplier id, which UNIT and MULT records
// resolve. Layouts from ArduPilot's libraries/AP_Logger/LogStructure.h.
//
// Reading is one pass: a record of a known type is taken whole; anything else
// (a corrupt byte, a record of a type no FMT defined) is skipped one byte at a
// time until the next header of a known type, and counted. A record cut by
// the end of the file is counted as trailing bytes, not read. Units are
// resolved after the pass, because FMTU and UNIT records may come after the
// data they describe.
#include "quadid/logs.hpp"

#include "bytes.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <variant>

namespace quadid::logs {
namespace {

constexpr std::uint8_t kHead0 = 0xA3, kHead1 = 0x95, kFmtType = 128;
constexpr std::size_t kHeader = 3;
constexpr std::size_t kFmtLength = 89;  // 3 + Type B, Length B, Name n, Format N, Columns Z

template <class T>
T load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// A fixed-size text field: up to its first NUL.
std::string fixed_text(const std::uint8_t* p, std::size_t n) {
  std::size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  return std::string(reinterpret_cast<const char*>(p), len);
}

bool is_text(char c) { return c == 'n' || c == 'N' || c == 'Z'; }

// A numeric field as ArduPilot's own tools (pymavlink's DFReader) scale it.
double decode(char c, const std::uint8_t* p) {
  switch (c) {
    case 'b': return load<std::int8_t>(p);
    case 'B': case 'M': return load<std::uint8_t>(p);
    case 'h': return load<std::int16_t>(p);
    case 'H': return load<std::uint16_t>(p);
    case 'i': return load<std::int32_t>(p);
    case 'I': return load<std::uint32_t>(p);
    case 'f': return load<float>(p);
    case 'd': return load<double>(p);
    case 'c': return load<std::int16_t>(p) / 100.0;
    case 'C': return load<std::uint16_t>(p) / 100.0;
    case 'e': return load<std::int32_t>(p) / 100.0;
    case 'E': return load<std::uint32_t>(p) / 100.0;
    case 'L': return load<std::int32_t>(p) * 1e-7;
    case 'q': return static_cast<double>(load<std::int64_t>(p));
    case 'Q': return static_cast<double>(load<std::uint64_t>(p));
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

std::vector<std::string> split_columns(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t comma = s.find(',', start);
    const std::size_t end = comma == std::string::npos ? s.size() : comma;
    out.push_back(s.substr(start, end - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

// A format from an FMT payload, or the reason it cannot be used.
std::variant<DataFlashFormat, std::string> format_from_fmt(const std::uint8_t* p) {
  DataFlashFormat f;
  f.type = p[0];
  f.length = p[1];
  f.name = fixed_text(p + 2, 4);
  f.format = fixed_text(p + 6, 16);
  f.columns = split_columns(fixed_text(p + 22, 64));
  if (f.name.empty()) return std::string("an FMT record with an empty name");
  if (f.type == kFmtType) return fmt::format("an FMT record redefining type 128 (FMT itself) as '{}'", f.name);
  if (f.columns.size() != f.format.size())
    return fmt::format("FMT of {} (type {}): {} format characters '{}' but {} columns", f.name, f.type,
                       f.format.size(), f.format, f.columns.size());
  std::size_t off = 0;
  for (const char c : f.format) {
    const int size = dataflash_type_size(c);
    if (size == 0)
      return fmt::format("FMT of {} (type {}): format character '{}' is not one ArduPilot defines "
                         "(b B h H i I f d n N Z c C e E L M q Q a)",
                         f.name, f.type, c);
    f.offsets.push_back(off);
    off += static_cast<std::size_t>(size);
  }
  if (off + kHeader != f.length)
    return fmt::format("FMT of {} (type {}): length {} but its format '{}' takes {} bytes + 3 of header", f.name,
                       f.type, f.length, f.format, off);
  f.units.assign(f.columns.size(), "");
  f.multipliers.assign(f.columns.size(), std::numeric_limits<double>::quiet_NaN());
  return f;
}

DataFlashFormat fmt_format() {
  DataFlashFormat f;
  f.type = kFmtType;
  f.length = kFmtLength;
  f.name = "FMT";
  f.format = "BBnNZ";
  f.columns = {"Type", "Length", "Name", "Format", "Columns"};
  f.offsets = {0, 1, 2, 6, 22};
  f.units.assign(5, "");
  f.multipliers.assign(5, std::numeric_limits<double>::quiet_NaN());
  return f;
}

class Reader {
 public:
  Reader(std::span<const std::uint8_t> b, const std::string& src) : b_(b), src_(src) {}

  // Two passes: the first only sizes each type's records (its definitions
  // read as they come), so that the second copies each payload once into
  // storage of its final size.
  DataFlashLog run() {
    reset();
    scan(true);
    std::array<std::size_t, 256> sized = payload_bytes_;
    reset();
    for (std::size_t t = 0; t < sized.size(); ++t)
      if (sized[t] > 0) log_.messages[static_cast<std::uint8_t>(t)].data.reserve(sized[t]);
    scan(false);
    return finish();
  }

 private:
  void reset() {
    log_ = DataFlashLog{};
    log_.bytes = b_.size();
    log_.first_skip_offset = b_.size();
    log_.formats[kFmtType] = fmt_format();
    length_.fill(0);
    length_[kFmtType] = kFmtLength;
    payload_bytes_.fill(0);
    in_skip_ = false;
    skip_start_ = 0;
    parm_type_ = -1;
  }

  void scan(bool sizing) {
    std::size_t pos = 0;
    const std::size_t n = b_.size();
    while (pos < n) {
      const std::size_t len = record_length(pos);
      if (len == 0) {
        skip(pos++);
        continue;
      }
      if (n - pos < len) {  // cut by the end of the file
        log_.trailing_bytes = n - pos;
        log_.trailing_offset = pos;
        break;
      }
      in_skip_ = false;
      take(pos, len, sizing);
      pos += len;
    }
    if (in_skip_ && pos >= n && log_.trailing_bytes == 0 && n - skip_start_ < kHeader) {
      // A header cut by the end of the file: trailing, not corrupt.
      log_.skipped_bytes -= n - skip_start_;
      log_.trailing_bytes = n - skip_start_;
      log_.trailing_offset = skip_start_;
    }
  }

  DataFlashLog finish() {
    if (!log_.messages.contains(kFmtType))
      throw InputError(fmt::format("{}: byte 0: not an ArduPilot DataFlash log: no FMT record (0xA3 0x95 0x80) "
                                   "in its {} bytes",
                                   src_, b_.size()));
    for (auto it = log_.messages.begin(); it != log_.messages.end();)  // reserved, never recorded
      it = it->second.data.empty() ? log_.messages.erase(it) : std::next(it);
    resolve_units();
    for (auto& [type, m] : log_.messages) m.format = log_.formats.at(type);
    return std::move(log_);
  }

  // The length of the record at pos, or 0 when none starts there.
  std::size_t record_length(std::size_t pos) const {
    if (b_.size() - pos < kHeader || b_[pos] != kHead0 || b_[pos + 1] != kHead1) return 0;
    return length_[b_[pos + 2]];
  }

  void skip(std::size_t pos) {
    if (!in_skip_) {
      in_skip_ = true;
      skip_start_ = pos;
      ++log_.resyncs;
      if (log_.first_skip_offset == log_.bytes) log_.first_skip_offset = pos;
    }
    ++log_.skipped_bytes;
  }

  void take(std::size_t pos, std::size_t len, bool sizing) {
    const std::uint8_t type = b_[pos + 2];
    const std::uint8_t* p = b_.data() + pos + kHeader;
    if (type == kFmtType) define(p, pos);
    if (sizing) {
      payload_bytes_[type] += len - kHeader;
      return;
    }
    DataFlashMessages& m = log_.messages[type];
    m.data.insert(m.data.end(), p, p + (len - kHeader));
    if (type == parm_type_) parameter(log_.formats.at(type), p);
  }

  void define(const std::uint8_t* p, std::size_t pos) {
    // ArduPilot logs FMT's own definition first: the built-in one, repeated.
    if (p[0] == kFmtType && p[1] == kFmtLength && fixed_text(p + 2, 4) == "FMT" && fixed_text(p + 6, 16) == "BBnNZ")
      return;
    auto parsed = format_from_fmt(p);
    if (auto* why = std::get_if<std::string>(&parsed)) {
      log_.problems.push_back(fmt::format("byte {}: {}; its records are skipped", pos, *why));
      return;
    }
    DataFlashFormat f = std::get<DataFlashFormat>(std::move(parsed));
    const auto it = log_.formats.find(f.type);
    if (it != log_.formats.end()) {
      const DataFlashFormat& old = it->second;
      if (old.name == f.name && old.format == f.format && old.columns == f.columns) return;  // repeated
      const auto m = log_.messages.find(f.type);
      if (m != log_.messages.end() && !m->second.data.empty()) {
        log_.problems.push_back(fmt::format("byte {}: FMT redefines type {} ({} '{}') as {} '{}' after {} of its "
                                            "records; the first definition is kept",
                                            pos, f.type, old.name, old.format, f.name, f.format,
                                            m->second.data.size() / (old.length - kHeader)));
        return;
      }
    }
    length_[f.type] = f.length;
    if (f.name == "PARM") parm_type_ = f.type;
    log_.formats[f.type] = std::move(f);
  }

  void parameter(const DataFlashFormat& f, const std::uint8_t* p) {
    const int t = f.column("TimeUS"), name = f.column("Name"), value = f.column("Value");
    if (name < 0 || value < 0 || !is_text(f.format[static_cast<std::size_t>(name)])) return;
    DataFlashParameter par;
    if (t >= 0) par.time_us = static_cast<std::uint64_t>(decode(f.format[static_cast<std::size_t>(t)],
                                                                p + f.offsets[static_cast<std::size_t>(t)]));
    par.name = fixed_text(p + f.offsets[static_cast<std::size_t>(name)],
                          static_cast<std::size_t>(dataflash_type_size(f.format[static_cast<std::size_t>(name)])));
    par.value = decode(f.format[static_cast<std::size_t>(value)], p + f.offsets[static_cast<std::size_t>(value)]);
    log_.parameters.push_back(std::move(par));
  }

  // FMTU's unit and multiplier ids per column, resolved through UNIT and MULT
  // (the last record of each id and of each type wins).
  void resolve_units() {
    std::map<char, std::string> unit;
    std::map<char, double> mult;
    if (const DataFlashMessages* u = with_format("UNIT"); u && u->format.column("Id") >= 0 &&
                                                          u->format.column("Label") >= 0) {
      const Eigen::VectorXd id = u->column("Id");
      for (std::size_t i = 0; i < u->count(); ++i)
        unit[static_cast<char>(id(static_cast<Eigen::Index>(i)))] = u->text("Label", i);
    }
    if (const DataFlashMessages* m = with_format("MULT"); m && m->format.column("Id") >= 0 &&
                                                          m->format.column("Mult") >= 0) {
      const Eigen::VectorXd id = m->column("Id"), v = m->column("Mult");
      for (std::size_t i = 0; i < m->count(); ++i)
        mult[static_cast<char>(id(static_cast<Eigen::Index>(i)))] = v(static_cast<Eigen::Index>(i));
    }
    const DataFlashMessages* fu = with_format("FMTU");
    if (!fu || fu->format.column("FmtType") < 0 || fu->format.column("UnitIds") < 0) return;
    const Eigen::VectorXd type = fu->column("FmtType");
    const bool has_mult = fu->format.column("MultIds") >= 0;
    for (std::size_t i = 0; i < fu->count(); ++i) {
      const auto it = log_.formats.find(static_cast<std::uint8_t>(type(static_cast<Eigen::Index>(i))));
      if (it == log_.formats.end()) continue;
      DataFlashFormat& f = it->second;
      const std::string uids = fu->text("UnitIds", i), mids = has_mult ? fu->text("MultIds", i) : "";
      for (std::size_t c = 0; c < f.columns.size(); ++c) {
        if (c < uids.size()) {
          const auto u = unit.find(uids[c]);
          f.units[c] = u == unit.end() ? "" : u->second;
        }
        if (c < mids.size()) {
          const auto m = mult.find(mids[c]);
          f.multipliers[c] = m == mult.end() ? std::numeric_limits<double>::quiet_NaN() : m->second;
        }
      }
    }
  }

  // The records of a type by name, their format filled in (for reading them
  // before the formats are copied into every message).
  const DataFlashMessages* with_format(std::string_view name) {
    for (auto& [type, m] : log_.messages) {
      const DataFlashFormat& f = log_.formats.at(type);
      if (f.name != name) continue;
      m.format = f;
      return &m;
    }
    return nullptr;
  }

  std::span<const std::uint8_t> b_;
  const std::string& src_;
  DataFlashLog log_;
  std::array<std::size_t, 256> length_{};         // record length by type (0: undefined)
  std::array<std::size_t, 256> payload_bytes_{};  // the sizing pass's payload bytes by type
  int parm_type_ = -1;
  bool in_skip_ = false;
  std::size_t skip_start_ = 0;
};

}  // namespace

int dataflash_type_size(char c) {
  switch (c) {
    case 'b': case 'B': case 'M': return 1;
    case 'h': case 'H': case 'c': case 'C': return 2;
    case 'i': case 'I': case 'f': case 'e': case 'E': case 'L': case 'n': return 4;
    case 'd': case 'q': case 'Q': return 8;
    case 'N': return 16;
    case 'Z': case 'a': return 64;
    default: return 0;
  }
}

int DataFlashFormat::column(std::string_view n) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == n) return static_cast<int>(i);
  return -1;
}

std::size_t DataFlashMessages::count() const {
  return format.length > kHeader ? data.size() / (format.length - kHeader) : 0;
}

Eigen::VectorXd DataFlashMessages::column(std::string_view name) const {
  const int c = format.column(name);
  if (c < 0) throw InputError(fmt::format("DataFlash message {} has no column {}", format.name, name));
  const char ch = format.format[static_cast<std::size_t>(c)];
  if (is_text(ch) || ch == 'a')
    throw InputError(fmt::format("DataFlash {}.{} is not a number (format '{}')", format.name, name, ch));
  const std::size_t n = count(), stride = format.length - kHeader, off = format.offsets[static_cast<std::size_t>(c)];
  Eigen::VectorXd v(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) v(static_cast<Eigen::Index>(i)) = decode(ch, data.data() + i * stride + off);
  return v;
}

std::string DataFlashMessages::text(std::string_view name, std::size_t i) const {
  const int c = format.column(name);
  if (c < 0 || i >= count())
    throw InputError(fmt::format("DataFlash message {} has no column {} or no record {}", format.name, name, i));
  const char ch = format.format[static_cast<std::size_t>(c)];
  if (!is_text(ch)) throw InputError(fmt::format("DataFlash {}.{} is not text (format '{}')", format.name, name, ch));
  const std::size_t stride = format.length - kHeader, off = format.offsets[static_cast<std::size_t>(c)];
  return fixed_text(data.data() + i * stride + off, static_cast<std::size_t>(dataflash_type_size(ch)));
}

std::vector<std::uint64_t> DataFlashMessages::time_us() const {
  if (format.columns.empty() || format.columns[0] != "TimeUS" || format.format[0] != 'Q') return {};
  const std::size_t n = count(), stride = format.length - kHeader;
  std::vector<std::uint64_t> t(n);
  for (std::size_t i = 0; i < n; ++i) t[i] = load<std::uint64_t>(data.data() + i * stride);
  return t;
}

const DataFlashMessages* DataFlashLog::find(std::string_view name) const {
  for (const auto& [type, m] : messages)
    if (m.format.name == name) return &m;
  return nullptr;
}

std::optional<double> DataFlashLog::parameter(std::string_view name) const {
  for (auto it = parameters.rbegin(); it != parameters.rend(); ++it)
    if (it->name == name) return it->value;
  return std::nullopt;
}

bool is_dataflash(std::span<const std::uint8_t> head) {
  return head.size() >= 2 && head[0] == kHead0 && head[1] == kHead1;
}

DataFlashLog parse_dataflash(std::span<const std::uint8_t> bytes, const std::string& source) {
  return Reader(bytes, source).run();
}

DataFlashLog read_dataflash(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  return parse_dataflash(detail::as_bytes(bytes), path.string());
}

}  // namespace quadid::logs
