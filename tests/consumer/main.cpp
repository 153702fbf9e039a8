// Uses the installed library through its front door, quadid/quadid.hpp (every
// public header compiles on its own terms outside the build tree), and functions
// compiled into the installed archives (Params presets and validation, JSON output).
// Checks the QBall 2 nominal mass (Table 1).
#include "quadid/quadid.hpp"

#include <cstdio>

int main() {
  const quadid::Params P = quadid::Params::qball2_nominal();
  P.validate("qball2-nominal");
  const nlohmann::ordered_json j = quadid::to_json(P);
  std::printf("m = %.2f kg, Izz = %.5f kg m^2\n", j["m"].get<double>(), j["Izz"].get<double>());
  return j["m"].get<double>() == 1.79 ? 0 : 1;
}
