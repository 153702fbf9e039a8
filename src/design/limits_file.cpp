// The limits a designed trajectory file records (include/quadid/design.hpp).
#include "quadid/design.hpp"

#include "quadid/io.hpp"

#include <algorithm>
#include <filesystem>

namespace quadid {

std::optional<Constraints> saved_trajectory_limits(const std::string& spec) {
  const auto names = builtin_trajectory_names();
  if (std::find(names.begin(), names.end(), spec) != names.end() || !std::filesystem::is_regular_file(spec))
    return std::nullopt;
  const nlohmann::ordered_json j = read_json_file(spec);
  if (!j.is_object() || !j.contains("constraints")) return std::nullopt;
  return constraints_from_json(j["constraints"], spec);
}

}  // namespace quadid
