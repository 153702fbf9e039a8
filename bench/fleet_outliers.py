#!/usr/bin/python3
"""False flags of two rules for "this flight departs from the others".

Each fleet: n flights whose 7 parameters scatter normally about one value
(one vehicle, no outlier). Two rules, per flight and parameter, against the
other n - 1 flights:
  MAD rule: |x - median(others)| / (1.4826 MAD(others)) > 4
  t rule (quadid batch): |x - mean(others)| / (sd(others) sqrt(1 + 1/(n-1)))
          > t*, the two-sided Student-t (n - 2 dof) critical value at
          level / (7 n) (Bonferroni), level = 0.01.
Prints, for each n, the fraction of fleets with any false flag. The t rule's
critical value comes from integrating the t density numerically (Simpson),
independently of the library's closed-form sum.

Usage: /usr/bin/python3 bench/fleet_outliers.py [FLEETS]
"""
import math
import sys

import numpy as np


def t_pdf(x, nu):
    c = math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2) - 0.5 * math.log(nu * math.pi)
    return np.exp(c - (nu + 1) / 2 * np.log1p(x * x / nu))


def two_sided_tail(t, nu):
    # P(|T| > t) = 1 - 2 int_0^t pdf, Simpson on a fine grid (tail in the substitution x = t / u).
    u = np.linspace(1e-9, 1.0, 200001)  # x = t / u covers (t, inf)
    f = t_pdf(t / u, nu) * t / (u * u)
    h = u[1] - u[0]
    return 2 * h / 3 * (f[0] + f[-1] + 4 * f[1:-1:2].sum() + 2 * f[2:-1:2].sum())


def critical(p, nu):
    lo, hi = 0.0, 1.0
    while two_sided_tail(hi, nu) > p:
        hi *= 2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if two_sided_tail(mid, nu) > p:
            lo = mid
        else:
            hi = mid
    return hi


def main():
    fleets = int(sys.argv[1]) if len(sys.argv) > 1 else 20000
    rng = np.random.default_rng(1)
    k = 1.482602218505602
    print(f"{'flights':>7} {'MAD>4: any false flag':>22} {'t rule: any false flag':>23} {'t*':>8}")
    for n in (3, 4, 5, 6, 8, 10, 20, 50):
        x = rng.standard_normal((fleets, 7, n))
        mad_any = np.zeros(fleets, bool)
        t_any = np.zeros(fleets, bool)
        tc = critical(0.01 / (7 * n), n - 2)
        for i in range(n):
            others = np.delete(x, i, axis=2)
            med = np.median(others, axis=2)
            mad = k * np.median(np.abs(others - med[..., None]), axis=2)
            mad_any |= (np.abs(x[..., i] - med) > 4 * mad).any(axis=1)
            sd = others.std(axis=2, ddof=1)
            t = np.abs(x[..., i] - others.mean(axis=2)) / (sd * math.sqrt(1 + 1 / (n - 1)))
            t_any |= (t > tc).any(axis=1)
        print(f"{n:>7} {mad_any.mean():>22.4f} {t_any.mean():>23.4f} {tc:>8.4g}")


if __name__ == "__main__":
    main()
