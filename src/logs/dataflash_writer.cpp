// DataFlash writer for tests (logs.hpp): FMT, FMTU, UNIT and PARM records as
// ArduPilot writes them (LogStructure.h), data records packed from numbers.
#include "quadid/logs.hpp"

#include "bytes.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace quadid::logs {
namespace {

using detail::put;

// Type ids as ArduPilot numbers them (LogMessages in LogStructure.h); the
// reader finds them by name, not by these numbers.
constexpr std::uint8_t kParm = 64, kUnit = 177, kFmtu = 193;

void put_text(std::string& out, std::string_view s, std::size_t n) {
  std::string field(n, '\0');
  std::memcpy(field.data(), s.data(), std::min(n, s.size()));
  out += field;
}

template <class T>
T rounded(double v) {
  return static_cast<T>(std::llround(v));
}

void put_number(std::string& out, char c, double v) {
  switch (c) {
    case 'b': put(out, rounded<std::int8_t>(v)); break;
    case 'B': case 'M': put(out, rounded<std::uint8_t>(v)); break;
    case 'h': put(out, rounded<std::int16_t>(v)); break;
    case 'H': put(out, rounded<std::uint16_t>(v)); break;
    case 'i': put(out, rounded<std::int32_t>(v)); break;
    case 'I': put(out, rounded<std::uint32_t>(v)); break;
    case 'f': put(out, static_cast<float>(v)); break;
    case 'd': put(out, v); break;
    case 'c': put(out, rounded<std::int16_t>(v * 100.0)); break;
    case 'C': put(out, rounded<std::uint16_t>(v * 100.0)); break;
    case 'e': put(out, rounded<std::int32_t>(v * 100.0)); break;
    case 'E': put(out, rounded<std::uint32_t>(v * 100.0)); break;
    case 'L': put(out, rounded<std::int32_t>(v * 1e7)); break;
    case 'q': put(out, static_cast<std::int64_t>(std::llround(v))); break;
    case 'Q':  // beyond long long's range: round as a double, then convert
      if (!(v >= 0.0 && v < 18446744073709551616.0)) throw std::invalid_argument("DataFlashWriter: Q out of range");
      put(out, static_cast<std::uint64_t>(std::round(v)));
      break;
    default: throw std::invalid_argument(fmt::format("DataFlashWriter: '{}' is not a numeric format character", c));
  }
}

}  // namespace

DataFlashWriter::DataFlashWriter() { defined_[128] = {"BBnNZ", 89}; }

void DataFlashWriter::define(std::uint8_t type, std::string_view name, std::string_view format,
                             std::string_view columns, const std::vector<std::string>& units) {
  if (name.size() > 4 || format.size() > 16 || columns.size() > 64)
    throw std::invalid_argument("DataFlashWriter: FMT holds at most 4 name, 16 format and 64 column characters");
  std::size_t len = 3;
  for (const char c : format) {
    const int s = dataflash_type_size(c);
    if (s == 0) throw std::invalid_argument(fmt::format("DataFlashWriter: format character '{}'", c));
    len += static_cast<std::size_t>(s);
  }
  if (len > 255) throw std::invalid_argument("DataFlashWriter: a record longer than 255 bytes");
  out_ += "\xA3\x95\x80";
  put(out_, type);
  put(out_, static_cast<std::uint8_t>(len));
  put_text(out_, name, 4);
  put_text(out_, format, 16);
  put_text(out_, columns, 64);
  defined_[type] = {std::string(format), len};
  if (units.empty()) return;
  if (!defined_.contains(kUnit)) define(kUnit, "UNIT", "QbZ", "TimeUS,Id,Label");
  if (!defined_.contains(kFmtu)) define(kFmtu, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds");
  std::string ids;
  for (const std::string& u : units) {
    if (u.empty()) {
      ids += '-';
      continue;
    }
    auto it = unit_ids_.find(u);
    if (it == unit_ids_.end()) {
      const char id = static_cast<char>('A' + unit_ids_.size());
      it = unit_ids_.emplace(u, id).first;
      out_ += "\xA3\x95";
      put(out_, kUnit);
      put(out_, std::uint64_t{0});
      put(out_, static_cast<std::int8_t>(id));
      put_text(out_, u, 64);
    }
    ids += it->second;
  }
  out_ += "\xA3\x95";
  put(out_, kFmtu);
  put(out_, std::uint64_t{0});
  put(out_, type);
  put_text(out_, ids, 16);
  put_text(out_, std::string(ids.size(), '-'), 16);
}

void DataFlashWriter::record(std::uint8_t type, const std::vector<double>& numbers,
                             const std::vector<std::string>& texts) {
  const auto it = defined_.find(type);
  if (it == defined_.end()) throw std::invalid_argument(fmt::format("DataFlashWriter: type {} is not defined", type));
  const std::string& format = it->second.first;
  std::size_t ni = 0, ti = 0;
  std::string rec = "\xA3\x95";
  put(rec, type);
  for (const char c : format) {
    if (c == 'n' || c == 'N' || c == 'Z') {
      if (ti >= texts.size()) throw std::invalid_argument("DataFlashWriter: too few texts");
      put_text(rec, texts[ti++], static_cast<std::size_t>(dataflash_type_size(c)));
    } else if (c == 'a') {
      for (int k = 0; k < 32; ++k) {
        if (ni >= numbers.size()) throw std::invalid_argument("DataFlashWriter: too few numbers");
        put(rec, rounded<std::int16_t>(numbers[ni++]));
      }
    } else {
      if (ni >= numbers.size()) throw std::invalid_argument("DataFlashWriter: too few numbers");
      put_number(rec, c, numbers[ni++]);
    }
  }
  if (ni != numbers.size() || ti != texts.size())
    throw std::invalid_argument(fmt::format("DataFlashWriter: type {} takes {} numbers and {} texts", type, ni, ti));
  out_ += rec;
}

void DataFlashWriter::parameter(std::uint64_t time_us, std::string_view name, float value) {
  if (!defined_.contains(kParm)) define(kParm, "PARM", "QNf", "TimeUS,Name,Value");
  out_ += "\xA3\x95";
  put(out_, kParm);
  put(out_, time_us);
  put_text(out_, name, 16);
  put(out_, value);
}

void DataFlashWriter::raw(std::string_view bytes) { out_ += bytes; }

}  // namespace quadid::logs
