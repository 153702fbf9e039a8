// Bounds-checked little-endian reading of a byte buffer, shared by the ULog
// and uSD readers: every read names the byte offset and what was expected.
#pragma once

#include "quadid/io.hpp"

#include <fmt/format.h>

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace quadid::logs::detail {

static_assert(std::endian::native == std::endian::little, "the log readers assume a little-endian host");

class Cursor {
 public:
  Cursor(std::span<const std::uint8_t> bytes, const std::string& source) : b_(bytes), src_(source) {}
  std::size_t pos() const { return pos_; }
  std::size_t size() const { return b_.size(); }
  std::size_t left() const { return b_.size() - pos_; }
  void seek(std::size_t p) { pos_ = p; }
  const std::string& source() const { return src_; }

  [[noreturn]] void fail(std::size_t at, std::string_view what) const {
    throw InputError(fmt::format("{}: byte {}: {}", src_, at, what));
  }
  void need(std::size_t n, std::string_view what) const {
    if (n > left())
      fail(pos_, fmt::format("expected {} ({} bytes), the file ends after {} more", what, n, left()));
  }
  template <class T>
  T get(std::string_view what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::span<const std::uint8_t> take(std::size_t n, std::string_view what) {
    need(n, what);
    auto s = b_.subspan(pos_, n);
    pos_ += n;
    return s;
  }
  /// A NUL-terminated string (the NUL consumed, not returned).
  std::string cstring(std::string_view what, std::size_t max_len = 4096) {
    const std::size_t start = pos_;
    const std::size_t end = std::min(b_.size(), pos_ + max_len);
    for (std::size_t i = pos_; i < end; ++i)
      if (b_[i] == 0) {
        std::string s(reinterpret_cast<const char*>(b_.data() + start), i - start);
        pos_ = i + 1;
        return s;
      }
    fail(start, fmt::format("expected {} ending in a NUL byte within {} bytes", what, max_len));
  }

 private:
  std::span<const std::uint8_t> b_;
  std::string src_;
  std::size_t pos_ = 0;
};

/// Appends v's bytes (little endian, the host's order) to s: the writers' one packer.
template <class T>
void put(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  s.append(b, sizeof(T));
}

inline std::string as_string(std::span<const std::uint8_t> s) {
  return std::string(reinterpret_cast<const char*>(s.data()), s.size());
}

inline std::span<const std::uint8_t> as_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

/// Python's repr of a str (pyulog's verbose listing of multi-info values).
std::string py_repr_str(const std::string& s);

}  // namespace quadid::logs::detail
