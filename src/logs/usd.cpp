// Crazyflie uSD-card deck event-based log (format in
// ../shared/data/crazyflie-usd/README.md): 0xBC, uint16 version (1 or 2),
// uint16 event count, event definitions (uint16 id, NUL-terminated name,
// uint16 variable count, variables "name(T)"), records (uint16 id, timestamp
// uint32 ms in v1 / uint64 us in v2, packed variables) and a zlib CRC-32 of
// everything before the last 4 bytes.
#include "quadid/logs.hpp"

#include "bytes.hpp"

#include <fmt/format.h>

#include <array>
#include <cstring>

namespace quadid::logs {
namespace {

using detail::Cursor;

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[n] = c;
  }
  return t;
}
constexpr auto kCrcTable = make_crc_table();

int type_size(char t) {
  switch (t) {
    case 'f': case 'i': case 'I': return 4;
    case 'h': case 'H': return 2;
    case 'b': case 'B': return 1;
    default: return 0;
  }
}

template <class T>
double as(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<double>(v);
}

double decode(char t, const std::uint8_t* p) {
  switch (t) {
    case 'f': return as<float>(p);
    case 'i': return as<std::int32_t>(p);
    case 'I': return as<std::uint32_t>(p);
    case 'h': return as<std::int16_t>(p);
    case 'H': return as<std::uint16_t>(p);
    case 'b': return as<std::int8_t>(p);
    default: return as<std::uint8_t>(p);
  }
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  crc = ~crc;
  for (std::uint8_t b : bytes) crc = kCrcTable[(crc ^ b) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

bool is_usd(std::span<const std::uint8_t> head) { return !head.empty() && head[0] == 0xBC; }

int UsdEvent::find(std::string_view variable) const {
  for (std::size_t i = 0; i < variables.size(); ++i)
    if (variables[i].name == variable) return static_cast<int>(i);
  return -1;
}

Eigen::VectorXd UsdEvent::column(std::string_view variable) const {
  const int j = find(variable);
  if (j < 0) throw InputError(fmt::format("uSD event '{}' has no variable '{}'", name, variable));
  const std::size_t nv = variables.size();
  Eigen::VectorXd v(static_cast<Eigen::Index>(count()));
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = values[static_cast<std::size_t>(i) * nv + static_cast<std::size_t>(j)];
  return v;
}

Eigen::VectorXd UsdEvent::times() const {
  Eigen::VectorXd t(static_cast<Eigen::Index>(count()));
  for (Eigen::Index i = 0; i < t.size(); ++i) t[i] = static_cast<double>(timestamps_us[static_cast<std::size_t>(i)]) * 1e-6;
  return t;
}

const UsdEvent* UsdLog::find_event(std::string_view name) const {
  for (const auto& e : events)
    if (e.name == name) return &e;
  return nullptr;
}

UsdLog parse_usd(std::span<const std::uint8_t> bytes, const std::string& source, const UsdReadOptions& opt) {
  if (bytes.size() < 4 + 5)
    throw InputError(fmt::format("{}: byte 0: expected a uSD log (header and CRC-32, at least 9 bytes), the file has {}",
                                 source, bytes.size()));
  // The CRC first: a corrupt file is reported as such, not as a parse error.
  std::size_t body = bytes.size() - 4;
  std::uint32_t stored;
  std::memcpy(&stored, bytes.data() + body, 4);
  const std::uint32_t computed = crc32(bytes.first(body));
  const bool cut = stored != computed && opt.allow_truncated;
  if (cut) body = bytes.size();  // no CRC at the end of a cut file: every byte may be a record's
  if (stored != computed && !cut)
    throw InputError(fmt::format("{}: byte {}: CRC-32 mismatch: stored {:08x}, computed {:08x} over bytes 0..{} "
                                 "(file truncated or corrupt)",
                                 source, body, stored, computed, body));
  Cursor c(bytes.first(body), source);
  if (c.get<std::uint8_t>("the magic byte 0xBC") != 0xBC) c.fail(0, "not a Crazyflie uSD log (expected 0xBC)");
  UsdLog log;
  log.crc = cut ? 0 : stored;
  log.version = c.get<std::uint16_t>("the format version");
  if (log.version != 1 && log.version != 2) c.fail(1, fmt::format("expected format version 1 or 2, found {}", log.version));
  const int n_events = c.get<std::uint16_t>("the number of event types");
  std::vector<int> index_of(65536, -1);
  std::vector<std::size_t> record_size;
  for (int e = 0; e < n_events; ++e) {
    UsdEvent ev;
    const std::size_t at = c.pos();
    ev.id = c.get<std::uint16_t>("an event id");
    ev.name = c.cstring("an event name");
    const int nv = c.get<std::uint16_t>("the number of variables");
    std::size_t rs = 0;
    for (int v = 0; v < nv; ++v) {
      const std::size_t vat = c.pos();
      const std::string s = c.cstring("a variable \"name(T)\"");
      if (s.size() < 4 || s.back() != ')' || s[s.size() - 3] != '(' || type_size(s[s.size() - 2]) == 0)
        c.fail(vat, fmt::format("expected a variable \"name(T)\" with T one of f i I h H b B, found \"{}\"", s));
      ev.variables.push_back({s.substr(0, s.size() - 3), s[s.size() - 2]});
      rs += static_cast<std::size_t>(type_size(s[s.size() - 2]));
    }
    if (index_of[ev.id] >= 0) c.fail(at, fmt::format("event id {} defined twice", ev.id));
    index_of[ev.id] = static_cast<int>(log.events.size());
    record_size.push_back(rs);
    log.events.push_back(std::move(ev));
  }
  const std::size_t ts_size = log.version == 1 ? 4 : 8;
  while (c.left() > 0) {
    const std::size_t at = c.pos();
    if (cut) {  // stop at the first record that is cut short or not a record
      const std::size_t need = 2 + ts_size;
      int k = -1;
      if (c.left() >= need) {
        std::uint16_t id;
        std::memcpy(&id, bytes.data() + at, 2);
        k = index_of[id];
      }
      if (k < 0 || c.left() < need + record_size[static_cast<std::size_t>(k)]) {
        log.truncated_at = at;
        log.truncated_bytes = c.left();
        break;
      }
    }
    const auto id = c.get<std::uint16_t>("a record's event id");
    const int k = index_of[id];
    if (k < 0) c.fail(at, fmt::format("record of unknown event id {}", id));
    UsdEvent& ev = log.events[static_cast<std::size_t>(k)];
    std::uint64_t t;
    if (ts_size == 4) t = static_cast<std::uint64_t>(c.get<std::uint32_t>("a record's timestamp")) * 1000u;
    else t = c.get<std::uint64_t>("a record's timestamp");
    const auto rec = c.take(record_size[static_cast<std::size_t>(k)], fmt::format("the variables of event '{}'", ev.name));
    ev.timestamps_us.push_back(t);
    std::size_t off = 0;
    for (const auto& v : ev.variables) {
      ev.values.push_back(decode(v.type, rec.data() + off));
      off += static_cast<std::size_t>(type_size(v.type));
    }
  }
  return log;
}

UsdLog read_usd(const std::filesystem::path& path, const UsdReadOptions& opt) {
  const std::string bytes = read_file(path);
  return parse_usd(detail::as_bytes(bytes), path.string(), opt);
}

}  // namespace quadid::logs
