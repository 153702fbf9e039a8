// The regressor from its "a" and "b" signals (include/quadid/model/regressor.hpp).
#include "quadid/model/regressor.hpp"

namespace quadid {

Regressor4x7 assemble_regressor(const Vec4& a, const Eigen::Matrix<double, 7, 1>& b) {
  // Phi_a(a) + Phi_b(b), rows from eqs. (7)-(10) (see regressor.hpp);
  // a = [w p q r] (or their derivatives / g_D images), b = [c pq pr qr p2 q2 r2].
  const double w = a(0), p = a(1), q = a(2), r = a(3);
  const double c = b(0), pq = b(1), pr = b(2), qr = b(3), pp = b(4), qq = b(5), rr = b(6);
  Regressor4x7 G;
  G << w + c, 0.0, 0.0,     0.0,      0.0, 0.0,     0.0,
       0.0,   p,   q - pr,  r + pq,   -qr, qq - rr, qr,
       0.0,   pr,  p + qr,  rr - pp,  q,   r - pq,  -pr,
       0.0,   -pq, pp - qq, p - qr,   pq,  q + pr,  r;
  return G;
}

}  // namespace quadid
