// --map canonical=name on a header (include/quadid/io.hpp): the CSV reader's
// and the log importer's one renaming rule.
#include "quadid/io.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

namespace quadid {

ColumnMapping map_columns(const std::vector<std::string>& header, const std::map<std::string, std::string>& map,
                          bool missing_is_error, std::string_view holder) {
  const auto find = [&header](std::string_view name) {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : static_cast<int>(it - header.begin());
  };
  // canonical=-name negates `name`, unless the header has a column called "-name".
  const auto source = [&find](const std::string& mapped) {
    const bool negate = mapped.size() > 1 && mapped[0] == '-' && find(mapped) < 0;
    return std::pair{negate ? mapped.substr(1) : mapped, negate};
  };
  std::vector<std::string> sources;  // header columns renamed away by the map
  for (const auto& kv : map) sources.push_back(source(kv.second).first);
  ColumnMapping out{header, {}};
  for (const auto& [canon, mapped] : map) {
    const auto [name, negate] = source(mapped);
    const int i = find(name);
    if (i < 0 && missing_is_error)
      throw InputError(fmt::format("--map {}={}: {} has no column '{}' (it has: {})", canon, name, holder, name,
                                   fmt::join(header, ",")));
    const int j = find(canon);
    if (j >= 0 && canon != name && std::find(sources.begin(), sources.end(), canon) == sources.end())
      throw InputError(fmt::format("--map {}={}: {} already has a column '{}'", canon, name, holder, canon));
    if (i < 0) continue;  // left to the required-column check
    out.header[static_cast<size_t>(i)] = canon;
    if (negate) out.negated.push_back(i);
  }
  return out;
}

}  // namespace quadid
