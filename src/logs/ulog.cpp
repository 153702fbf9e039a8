// PX4 ULog reader, written from PX4's format description ("ULog File Format",
// PX4 user guide): a 16-byte header (magic "ULog\x01\x12\x35", version,
// uint64 start time in microseconds), then messages of a 3-byte header
// (uint16 payload size, uint8 type) and their payload:
//   B flag bits (first message only): compat[8], incompat[8], 3 appended-data offsets
//   F format "name:type field;...", I info, M info multiple, P parameter,
//   Q default parameter, A add logged (subscription), R remove logged, D data,
//   L logged string, C tagged logged string, S sync, O dropout.
// The whole file is read at once; data messages are copied per subscription
// into one contiguous buffer, fields are decoded only when asked for.
#include "quadid/logs.hpp"

#include "bytes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

namespace quadid::logs {
namespace {

using detail::Cursor;

constexpr std::uint8_t kMagic[7] = {0x55, 0x4c, 0x6f, 0x67, 0x01, 0x12, 0x35};
constexpr int kMaxNesting = 32;          // nested format depth (a cycle ends here)
constexpr std::size_t kMaxFields = 1u << 16;  // flattened fields of one topic

struct TypeInfo {
  const char* name;
  ULogType type;
  int size;
};
constexpr TypeInfo kTypes[] = {
    {"int8_t", ULogType::Int8, 1},     {"uint8_t", ULogType::UInt8, 1},   {"int16_t", ULogType::Int16, 2},
    {"uint16_t", ULogType::UInt16, 2}, {"int32_t", ULogType::Int32, 4},   {"uint32_t", ULogType::UInt32, 4},
    {"int64_t", ULogType::Int64, 8},   {"uint64_t", ULogType::UInt64, 8}, {"float", ULogType::Float, 4},
    {"double", ULogType::Double, 8},   {"bool", ULogType::Bool, 1},       {"char", ULogType::Char, 1}};

template <class T>
T load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

double decode(ULogType t, const std::uint8_t* p) {
  switch (t) {
    case ULogType::Int8: return load<std::int8_t>(p);
    case ULogType::UInt8: return load<std::uint8_t>(p);
    case ULogType::Int16: return load<std::int16_t>(p);
    case ULogType::UInt16: return load<std::uint16_t>(p);
    case ULogType::Int32: return load<std::int32_t>(p);
    case ULogType::UInt32: return load<std::uint32_t>(p);
    case ULogType::Int64: return static_cast<double>(load<std::int64_t>(p));
    case ULogType::UInt64: return static_cast<double>(load<std::uint64_t>(p));
    case ULogType::Float: return load<float>(p);
    case ULogType::Double: return load<double>(p);
    case ULogType::Bool: return p[0] ? 1.0 : 0.0;
    case ULogType::Char: return static_cast<double>(static_cast<std::int8_t>(p[0]));
  }
  return 0.0;
}

// Python's repr of a float (shortest round trip, always with '.', 'e', inf or nan).
std::string py_float(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

// Python's repr of a str: quotes ' unless the text holds ' and no ".
std::string py_repr(const std::string& s) {
  const bool dq = s.find('\'') != std::string::npos && s.find('"') == std::string::npos;
  const char q = dq ? '"' : '\'';
  std::string out(1, q);
  for (unsigned char c : s) {
    if (c == '\\') out += "\\\\";
    else if (c == static_cast<unsigned char>(q)) { out += '\\'; out += static_cast<char>(c); }
    else if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c == '\t') out += "\\t";
    else if (c < 0x20 || c == 0x7f) out += fmt::format("\\x{:02x}", c);
    else out += static_cast<char>(c);
  }
  out += q;
  return out;
}

struct Layout {
  std::vector<ULogField> fields;
  std::size_t size = 0;       // without trailing padding
  std::size_t full_size = 0;  // as defined
};

class Parser {
 public:
  Parser(std::span<const std::uint8_t> bytes, const std::string& source, const ULogReadOptions& opt)
      : c_(bytes, source), opt_(opt) {}

  ULog run() {
    header();
    topic_of_id_.assign(65536, -1);
    std::vector<std::uint64_t> offsets;  // appended-data offsets still ahead
    bool first = true;
    while (c_.left() > 0) {
      std::size_t limit = c_.size();
      if (!offsets.empty()) limit = std::min<std::size_t>(limit, offsets.front());
      const std::size_t at = c_.pos();
      // A message that does not fit before the next appended-data offset ends
      // that part of the file: the rest of it is continued at the offset.
      bool fits = at + 3 <= limit;
      std::uint16_t size = 0;
      char type = 0;
      if (fits) {
        size = c_.get<std::uint16_t>("message size");
        type = static_cast<char>(c_.get<std::uint8_t>("message type"));
        fits = c_.pos() + size <= limit;
      }
      if (!fits) {
        if (!offsets.empty() && limit == offsets.front()) {
          c_.seek(offsets.front());
          offsets.erase(offsets.begin());
          continue;
        }
        if (opt_.allow_truncated) {
          log_.truncated_at = at;
          log_.truncated_bytes = limit - at;
          break;
        }
        if (at + 3 > limit)
          c_.fail(at, fmt::format("expected a 3-byte message header, the file ends after {} bytes", limit - at));
        c_.fail(at, fmt::format("expected a '{}' message of {} bytes, the file ends after {}", printable(type), size,
                                limit - at - 3));
      }
      const auto payload = c_.take(size, "message payload");
      if (type == 'B') {
        if (!first) c_.fail(at, "a flag-bits message ('B') after the first message");
        flag_bits(payload, at);
        for (auto o : log_.appended_offsets) {
          if (o < c_.pos() || o > c_.size())
            c_.fail(at + 19, fmt::format("appended-data offset {} outside the data section {}..{}", o, c_.pos(),
                                         c_.size()));
          offsets.push_back(o);
        }
        if (!std::is_sorted(offsets.begin(), offsets.end()))
          c_.fail(at + 19, "appended-data offsets not in increasing order");
      } else {
        dispatch(type, payload, at);
      }
      first = false;
    }
    if (!offsets.empty() && opt_.allow_truncated == false && offsets.front() < c_.size())
      c_.fail(c_.pos(), fmt::format("expected appended data at offset {}", offsets.front()));
    finish();
    return std::move(log_);
  }

 private:
  static char printable(char t) { return (t >= 0x20 && t < 0x7f) ? t : '?'; }

  void header() {
    const auto magic = c_.take(7, "the ULog magic \"ULog\\x01\\x12\\x35\"");
    if (!std::equal(magic.begin(), magic.end(), kMagic)) c_.fail(0, "not a ULog file (expected the magic \"ULog\\x01\\x12\\x35\")");
    log_.version = c_.get<std::uint8_t>("the file version");
    log_.start_timestamp = c_.get<std::uint64_t>("the header's start timestamp");
    log_.last_timestamp = log_.start_timestamp;
  }

  void flag_bits(std::span<const std::uint8_t> p, std::size_t at) {
    if (p.size() < 40)
      c_.fail(at, fmt::format("expected a flag-bits message of 40 bytes, it has {}", p.size()));
    std::copy_n(p.begin(), 8, log_.compat_flags.begin());
    std::copy_n(p.begin() + 8, 8, log_.incompat_flags.begin());
    // incompat bit 0 of byte 0: data appended; any other bit: a format we cannot read.
    bool unknown = (log_.incompat_flags[0] & ~1u) != 0;
    for (int i = 1; i < 8; ++i) unknown = unknown || log_.incompat_flags[i] != 0;
    if (unknown) c_.fail(at + 11, "unknown incompatible flag set: this ULog needs a newer reader");
    for (int i = 0; i < 3; ++i) {
      const auto o = load<std::uint64_t>(p.data() + 16 + 8 * i);
      if (o != 0 && (log_.incompat_flags[0] & 1u)) log_.appended_offsets.push_back(o);
    }
  }

  // "type name" key then the value bytes; `skip` leading bytes before the key length.
  std::pair<std::string, ULogValue> key_value(std::span<const std::uint8_t> p, std::size_t at, std::size_t skip) {
    if (p.size() < skip + 1) c_.fail(at, "expected a key length");
    const std::size_t key_len = p[skip];
    if (p.size() < skip + 1 + key_len)
      c_.fail(at + 3 + skip, fmt::format("key of {} bytes longer than its message ({} bytes)", key_len, p.size()));
    const std::string key = detail::as_string(p.subspan(skip + 1, key_len));
    const auto sp = key.find(' ');
    if (sp == std::string::npos || sp == 0 || sp + 1 == key.size())
      c_.fail(at + 4 + skip, fmt::format("expected a key \"type name\", found \"{}\"", key));
    ULogValue v;
    v.type = key.substr(0, sp);
    v.bytes = detail::as_string(p.subspan(skip + 1 + key_len));
    return {key.substr(sp + 1), std::move(v)};
  }

  void dispatch(char type, std::span<const std::uint8_t> p, std::size_t at) {
    switch (type) {
      case 'F': format(p, at); break;
      case 'I': {
        auto [k, v] = key_value(p, at, 0);
        log_.info[k] = std::move(v);
        break;
      }
      case 'M': {
        if (p.empty()) c_.fail(at + 3, "expected the is_continued byte");
        const bool continued = p[0] != 0;
        auto [k, v] = key_value(p, at, 1);
        auto& list = log_.info_multiple[k];
        if (continued && !list.empty()) list.back().push_back(std::move(v));
        else list.push_back({std::move(v)});
        break;
      }
      case 'P': {
        auto [k, v] = key_value(p, at, 0);
        if (in_data_) log_.changed_parameters.push_back({log_.last_timestamp, k, std::move(v)});
        else log_.parameters[k] = std::move(v);
        break;
      }
      case 'Q': {
        if (p.empty()) c_.fail(at + 3, "expected the default_types byte");
        const auto types = p[0];
        auto [k, v] = key_value(p, at, 1);
        if (types & 1u) log_.default_parameters_system[k] = v;
        if (types & 2u) log_.default_parameters_config[k] = v;
        break;
      }
      case 'A': add_logged(p, at); break;
      case 'R': in_data_ = true; break;  // data already logged stays
      case 'D': data(p, at); break;
      case 'L': {
        in_data_ = true;
        if (p.size() < 9) c_.fail(at + 3, "expected a logged string's level and timestamp (9 bytes)");
        log_.logged.push_back({static_cast<char>(p[0]), std::nullopt, load<std::uint64_t>(p.data() + 1),
                               detail::as_string(p.subspan(9))});
        break;
      }
      case 'C': {
        in_data_ = true;
        if (p.size() < 11) c_.fail(at + 3, "expected a tagged string's level, tag and timestamp (11 bytes)");
        log_.logged.push_back({static_cast<char>(p[0]), load<std::uint16_t>(p.data() + 1),
                               load<std::uint64_t>(p.data() + 3), detail::as_string(p.subspan(11))});
        break;
      }
      case 'S': ++log_.sync_count; break;
      case 'O': {
        if (p.size() < 2) c_.fail(at + 3, "expected a dropout's duration (2 bytes)");
        log_.dropouts.push_back({log_.last_timestamp, load<std::uint16_t>(p.data())});
        break;
      }
      default:
        // Unknown types are skipped (the format allows new ones); a header
        // of type 0 or size 0 is not a message at all.
        if (type == 0 || p.empty())
          c_.fail(at, fmt::format("expected a message header, found type {} size {}",
                                  static_cast<int>(static_cast<std::uint8_t>(type)), p.size()));
        ++log_.unknown_messages;
    }
  }

  void format(std::span<const std::uint8_t> p, std::size_t at) {
    std::string text = detail::as_string(p);
    while (!text.empty() && text.back() == '\0') text.pop_back();
    const auto colon = text.find(':');
    if (colon == std::string::npos || colon == 0)
      c_.fail(at + 3, fmt::format("expected a format \"name:type field;...\", found \"{}\"", text.substr(0, 60)));
    ULogFormat f;
    f.name = text.substr(0, colon);
    std::string_view rest(text);
    rest.remove_prefix(colon + 1);
    while (!rest.empty()) {
      const auto semi = rest.find(';');
      std::string_view item = rest.substr(0, semi);
      rest = semi == std::string_view::npos ? std::string_view{} : rest.substr(semi + 1);
      if (item.empty()) continue;
      const auto sp = item.find(' ');
      if (sp == std::string_view::npos || sp == 0 || sp + 1 == item.size())
        c_.fail(at + 3, fmt::format("format '{}': expected \"type name\", found \"{}\"", f.name, item));
      ULogFormatField fld;
      std::string_view type = item.substr(0, sp);
      fld.name = std::string(item.substr(sp + 1));
      const auto br = type.find('[');
      if (br != std::string_view::npos) {
        const auto close = type.find(']', br);
        int n = 0;
        const auto r = std::from_chars(type.data() + br + 1, type.data() + (close == std::string_view::npos ? br + 1 : close), n);
        if (close == std::string_view::npos || r.ec != std::errc{} || r.ptr != type.data() + close || n <= 0 ||
            n > 65535)
          c_.fail(at + 3, fmt::format("format '{}': bad array type \"{}\"", f.name, type));
        fld.array_size = n;
        type = type.substr(0, br);
      }
      fld.type = std::string(type);
      f.fields.push_back(std::move(fld));
    }
    layouts_.erase(f.name);
    log_.formats[f.name] = std::move(f);
  }

  void flatten(const std::string& fmt_name, const std::string& prefix, Layout& out, int depth, std::size_t at) {
    if (depth > kMaxNesting) c_.fail(at, fmt::format("format '{}' nested more than {} deep (a cycle?)", fmt_name, kMaxNesting));
    const auto it = log_.formats.find(fmt_name);
    if (it == log_.formats.end()) c_.fail(at, fmt::format("expected a format definition of '{}' before its use", fmt_name));
    for (const auto& f : it->second.fields) {
      const int n = f.array_size == 0 ? 1 : f.array_size;
      const auto basic = ulog_type_from_name(f.type);
      const bool pad = f.name.rfind("_padding", 0) == 0;
      for (int i = 0; i < n; ++i) {
        // pyulog's names: an index only for arrays of more than one element.
        const std::string name = f.array_size > 1 ? fmt::format("{}{}[{}]", prefix, f.name, i) : prefix + f.name;
        if (basic) {
          if (out.fields.size() >= kMaxFields) c_.fail(at, fmt::format("format '{}' has more than {} fields", fmt_name, kMaxFields));
          out.fields.push_back({name, *basic, out.full_size, pad});
          out.full_size += static_cast<std::size_t>(ulog_type_size(*basic));
          if (out.full_size > 65535) c_.fail(at, fmt::format("format '{}' larger than a message can be", fmt_name));
        } else {
          flatten(f.type, name + ".", out, depth + 1, at);
        }
      }
    }
  }

  void add_logged(std::span<const std::uint8_t> p, std::size_t at) {
    in_data_ = true;
    if (p.size() < 4) c_.fail(at + 3, "expected a subscription: multi id, msg id and a name");
    ULogTopic t;
    t.multi_id = p[0];
    t.msg_id = load<std::uint16_t>(p.data() + 1);
    t.name = detail::as_string(p.subspan(3));
    while (!t.name.empty() && t.name.back() == '\0') t.name.pop_back();
    auto lit = layouts_.find(t.name);
    if (lit == layouts_.end()) {
      Layout L;
      flatten(t.name, "", L, 0, at);
      while (!L.fields.empty() && L.fields.back().name.rfind("_padding", 0) == 0) L.fields.pop_back();
      L.size = L.fields.empty() ? 0 : L.fields.back().offset + static_cast<std::size_t>(ulog_type_size(L.fields.back().type));
      lit = layouts_.emplace(t.name, std::move(L)).first;
    }
    t.fields = lit->second.fields;
    t.size = lit->second.size;
    full_size_of_.resize(65536);
    full_size_of_[t.msg_id] = lit->second.full_size;
    const ULogField* ts = t.find("timestamp");
    if (!ts || ts->type != ULogType::UInt64)
      c_.fail(at, fmt::format("topic '{}' has no uint64_t timestamp field", t.name));
    t.timestamp_offset = ts->offset;
    const int existing = topic_of_id_[t.msg_id];
    if (existing >= 0) {
      topics_[static_cast<std::size_t>(existing)] = std::move(t);  // re-subscribed: replaces (as pyulog)
    } else {
      topic_of_id_[t.msg_id] = static_cast<int>(topics_.size());
      topics_.push_back(std::move(t));
    }
  }

  void data(std::span<const std::uint8_t> p, std::size_t at) {
    in_data_ = true;
    if (p.size() < 2) c_.fail(at + 3, "expected a data message's msg id");
    const auto id = load<std::uint16_t>(p.data());
    const int ti = topic_of_id_[id];
    if (ti < 0) {
      ++log_.unknown_messages;  // data without subscription: skipped
      return;
    }
    ULogTopic& t = topics_[static_cast<std::size_t>(ti)];
    const std::size_t n = p.size() - 2;
    if (n < t.size || n > full_size_of_[id])
      c_.fail(at, fmt::format("data message of '{}' has {} bytes, expected {}..{} (its format)", t.name, n, t.size,
                              full_size_of_[id]));
    const std::uint8_t* d = p.data() + 2;
    t.data.insert(t.data.end(), d, d + t.size);
    const auto ts = load<std::uint64_t>(d + t.timestamp_offset);
    if (ts != 0 && ts > log_.last_timestamp) log_.last_timestamp = ts;
  }

  void finish() {
    for (auto& t : topics_)
      if (!t.data.empty()) log_.topics.push_back(std::move(t));
    std::sort(log_.topics.begin(), log_.topics.end(), [](const ULogTopic& a, const ULogTopic& b) {
      return a.name + std::to_string(a.multi_id) < b.name + std::to_string(b.multi_id);
    });
  }

  Cursor c_;
  ULogReadOptions opt_;
  ULog log_;
  bool in_data_ = false;
  std::map<std::string, Layout> layouts_;
  std::vector<ULogTopic> topics_;
  std::vector<int> topic_of_id_;
  std::vector<std::size_t> full_size_of_;
};

}  // namespace

int ulog_type_size(ULogType t) {
  for (const auto& ti : kTypes)
    if (ti.type == t) return ti.size;
  return 0;
}

std::optional<ULogType> ulog_type_from_name(std::string_view name) {
  for (const auto& ti : kTypes)
    if (name == ti.name) return ti.type;
  return std::nullopt;
}

std::optional<double> ULogValue::number() const {
  const auto t = ulog_type_from_name(type);
  if (!t || *t == ULogType::Char || bytes.size() != static_cast<std::size_t>(ulog_type_size(*t))) return std::nullopt;
  return decode(*t, reinterpret_cast<const std::uint8_t*>(bytes.data()));
}

std::string ULogValue::to_string() const {
  if (is_string()) return bytes;
  const auto t = ulog_type_from_name(type);
  if (t && *t != ULogType::Char && bytes.size() == static_cast<std::size_t>(ulog_type_size(*t))) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
    switch (*t) {
      case ULogType::Float: return py_float(load<float>(p));
      case ULogType::Double: return py_float(load<double>(p));
      case ULogType::Bool: return p[0] ? "True" : "False";
      case ULogType::Int64: return std::to_string(load<std::int64_t>(p));
      case ULogType::UInt64: return std::to_string(load<std::uint64_t>(p));
      default: return fmt::format("{}", static_cast<long long>(decode(*t, p)));
    }
  }
  std::string s = "b'";
  for (unsigned char c : bytes) {
    if (c == '\\' || c == '\'') { s += '\\'; s += static_cast<char>(c); }
    else if (c == '\n') s += "\\n";
    else if (c == '\r') s += "\\r";
    else if (c == '\t') s += "\\t";
    else if (c < 0x20 || c >= 0x7f) s += fmt::format("\\x{:02x}", c);
    else s += static_cast<char>(c);
  }
  return s + "'";
}

const ULogField* ULogTopic::find(std::string_view field) const {
  for (const auto& f : fields)
    if (f.name == field) return &f;
  return nullptr;
}

std::vector<std::uint64_t> ULogTopic::timestamps() const {
  std::vector<std::uint64_t> t(count());
  for (std::size_t i = 0; i < t.size(); ++i) t[i] = load<std::uint64_t>(data.data() + i * size + timestamp_offset);
  return t;
}

Eigen::VectorXd ULogTopic::column(std::string_view field) const {
  const ULogField* f = find(field);
  if (!f) throw InputError(fmt::format("topic '{}' has no field '{}'", name, field));
  Eigen::VectorXd v(static_cast<Eigen::Index>(count()));
  for (Eigen::Index i = 0; i < v.size(); ++i)
    v[i] = decode(f->type, data.data() + static_cast<std::size_t>(i) * size + f->offset);
  return v;
}

std::string ULogLoggedMessage::level_name() const {
  static const char* names[] = {"EMERGENCY", "ALERT", "CRITICAL", "ERROR", "WARNING", "NOTICE", "INFO", "DEBUG"};
  if (level >= '0' && level <= '7') return names[level - '0'];
  return "UNKNOWN";
}

const ULogTopic* ULog::find_topic(std::string_view name, int multi_id) const {
  for (const auto& t : topics)
    if (t.name == name && t.multi_id == multi_id) return &t;
  return nullptr;
}

std::optional<double> ULog::parameter(std::string_view name) const {
  for (auto it = changed_parameters.rbegin(); it != changed_parameters.rend(); ++it)
    if (it->name == name) return it->value.number();
  const auto it = parameters.find(std::string(name));
  if (it == parameters.end()) return std::nullopt;
  return it->second.number();
}

bool is_ulog(std::span<const std::uint8_t> head) {
  return head.size() >= 7 && std::equal(head.begin(), head.begin() + 7, kMagic);
}

ULog parse_ulog(std::span<const std::uint8_t> bytes, const std::string& source, const ULogReadOptions& opt) {
  return Parser(bytes, source, opt).run();
}

ULog read_ulog(const std::filesystem::path& path, const ULogReadOptions& opt) {
  const std::string bytes = read_file(path);
  return parse_ulog(detail::as_bytes(bytes), path.string(), opt);
}

namespace detail {
std::string py_repr_str(const std::string& s) { return py_repr(s); }
}  // namespace detail

}  // namespace quadid::logs
