// Private to the library: NLopt's result codes in words, for the summaries of
// the design optimizer and of the physically consistent projection.
#pragma once

#include <fmt/format.h>
#include <nlopt.hpp>

#include <string>

namespace quadid::detail {

inline std::string nlopt_status(nlopt::result r) {
  switch (r) {
    case nlopt::SUCCESS: return "success";
    case nlopt::STOPVAL_REACHED: return "stopval reached";
    case nlopt::FTOL_REACHED: return "ftol reached";
    case nlopt::XTOL_REACHED: return "xtol reached";
    case nlopt::MAXEVAL_REACHED: return "max evaluations";
    case nlopt::MAXTIME_REACHED: return "max time";
    default: return fmt::format("nlopt code {}", static_cast<int>(r));
  }
}

}  // namespace quadid::detail
