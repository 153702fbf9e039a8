#include "quadid/io.hpp"

#include <fmt/format.h>

#include <atomic>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace quadid {

void write_file_atomic(const std::filesystem::path& path, std::string_view content) {
  static std::atomic<unsigned> counter{0};
  namespace fs = std::filesystem;
  if (path.has_parent_path() && !fs::exists(path.parent_path()))
    throw InputError(fmt::format("{}: directory {} does not exist", path.string(), path.parent_path().string()));
  const fs::path tmp = path.string() + fmt::format(".tmp.{}.{}", ::getpid(), counter++);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(fmt::format("{}: cannot open for writing", tmp.string()));
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw InputError(fmt::format("{}: write failed (disk full?)", path.string()));
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError(fmt::format("{}: cannot replace file: {}", path.string(), ec.message()));
  }
}

namespace {

void require_writable_directory(const std::filesystem::path& dir, const std::filesystem::path& path,
                                std::string_view option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(dir, ec))
    throw InputError(fmt::format("{} {}: directory '{}' does not exist", option, path.string(), dir.string()));
  if (!fs::is_directory(dir, ec))
    throw InputError(fmt::format("{} {}: '{}' is not a directory", option, path.string(), dir.string()));
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw InputError(fmt::format("{} {}: directory '{}' is not writable", option, path.string(), dir.string()));
}

}  // namespace

void check_output_file(const std::filesystem::path& path, std::string_view option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty()) throw InputError(fmt::format("{}: an empty file name", option));
  if (fs::is_directory(path, ec))
    throw InputError(fmt::format("{} {}: is a directory; give a file name", option, path.string()));
  require_writable_directory(path.has_parent_path() ? path.parent_path() : fs::path("."), path, option);
}

void check_output_directory(const std::filesystem::path& path, std::string_view option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty()) throw InputError(fmt::format("{}: an empty folder name", option));
  if (fs::exists(path, ec)) {
    require_writable_directory(path, path, option);
    return;
  }
  fs::path p = path.lexically_normal();
  if (!p.has_filename()) p = p.parent_path();  // "out/" names the folder "out"
  const fs::path parent = p.has_parent_path() ? p.parent_path() : fs::path(".");
  require_writable_directory(parent, path, option);
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open file for reading", path.string()));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

nlohmann::ordered_json read_json_file(const std::filesystem::path& path) {
  const std::string text = read_file(path);
  try {
    return nlohmann::ordered_json::parse(text);
  } catch (const nlohmann::ordered_json::parse_error& e) {
    // Convert the byte offset into line and column for the message.
    const size_t off = std::min<size_t>(e.byte, text.size());
    size_t line = 1, col = 1;
    for (size_t i = 0; i + 1 < off; ++i) {
      if (text[i] == '\n') { ++line; col = 1; } else { ++col; }
    }
    throw InputError(fmt::format("{}:{}:{}: invalid JSON ({})", path.string(), line, col, e.what()));
  }
}

}  // namespace quadid
