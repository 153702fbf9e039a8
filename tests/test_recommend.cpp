// recommend_set: which set the report recommends, and its reason's numbers.
#include "quadid/identification.hpp"

#include <gtest/gtest.h>

namespace {

// LS and FMLS of a consistent body whose standard errors are `rel_ls` and
// `rel_fmls` of each parameter's scale (m for m, the mean principal moment,
// 2e-3 kg m^2 here, for the inertia entries): relative precision = those.
quadid::IdentificationResult two_sets(double rel_ls, double rel_fmls) {
  quadid::IdentificationResult r;
  quadid::Theta th;
  th << 1.0, 2e-3, 0.0, 0.0, 2e-3, 0.0, 2e-3;  // m Ixx Ixy Ixz Iyy Iyz Izz: a sphere
  r.estimates[0] = {"LS", quadid::RegressionModel::Standard, true, th, true, "", {}};
  r.estimates[2] = {"FMLS", quadid::RegressionModel::Filtered, true, th, true, "", {}};
  quadid::Theta scale;
  scale << 1.0, 2e-3, 2e-3, 2e-3, 2e-3, 2e-3, 2e-3;
  r.ls_standard.std_error = rel_ls * scale;
  r.ls_filtered.std_error = rel_fmls * scale;
  return r;
}

TEST(Recommend, TheSmallerStandardErrorsWinAndTheirNumbersDiffer) {
  // 2.96 % and 3.04 % print alike at two digits ("3 % against 3 %"): the
  // reason takes the digits that tell them apart.
  const quadid::Recommendation a = quadid::recommend_set(two_sets(0.0296, 0.0304));
  EXPECT_EQ(a.set, "LS");
  EXPECT_NE(a.reason.find("2.96 % against 3.04 % for FMLS"), std::string::npos) << a.reason;
  // Numbers that differ at two digits keep two.
  const quadid::Recommendation b = quadid::recommend_set(two_sets(0.05, 0.0073));
  EXPECT_EQ(b.set, "FMLS");
  EXPECT_NE(b.reason.find("0.73 % against 5 % for LS"), std::string::npos) << b.reason;
}

}  // namespace
