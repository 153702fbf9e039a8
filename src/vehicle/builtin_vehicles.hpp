// The vehicle files shipped inside the program (private to src/vehicle).
#pragma once

#include <string_view>
#include <vector>

namespace quadid::detail {

struct BuiltinVehicle {
  std::string_view name;
  std::string_view text;  // the TOML file, sources in its comments
};

const std::vector<BuiltinVehicle>& builtin_vehicles();

}  // namespace quadid::detail
