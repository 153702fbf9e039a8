#!/usr/bin/python3
"""Study for issue 11: the long-run variance of an influence series whose sum
is mostly its two end values (the mass row of identify), and of the usual
kinds (white, AR(1)). It does not touch quadid; it prints the coverage of 95 %
intervals from three estimators over many replicates, to decide what
src/estimation/uncertainty.cpp should do next (docs/montecarlo.md, "m").

Estimators of Var(sum_t d_t) from one series d (at the estimate: sum d = 0):
  ewp      - quadid today: mean periodogram at the K lowest Fourier
             frequencies, K = n / (10 m), m the correlation time; 2K dof.
  mt       - the same with sine tapers (Riedel-Sidorenko): blind to the end
             values, so it misses the variance they carry.
  mt+vario - mt for the white part plus the plateau of the variogram of the
             partial sums S_t (its value past the correlation time, less the
             white part's slope): the end values' variance, from every pair
             (S_t, S_t+h) instead of from the two ends.

The mass-row model: y = m phi_true (an exact wrench), phi = phi_true +
second derivative of 0.3 mm white position noise at 500 Hz after a 4 Hz
order-4 zero-phase Butterworth (identify's default), m = 1.8 kg.

Run: /usr/bin/python3 bench/hac_end_values_study.py [replicates]   (Debian python3-numpy, python3-scipy)

Measured (400 replicates, 2026-12-02; K from the correlation time as quadid):
  mass row: ewp 100.0 % (se/sd 1.75, sd(se)/mean 0.23); mt 52.2 %;
            mt+vario 96.2 % (se/sd 1.10, sd(se)/mean 0.05), bias/sd -0.51
  white:    ewp 94.8 %, mt 95.5 %, mt+vario 95.5 % (the plateau is ~0)
  AR(1) .9: ewp 94.2 %, mt 94.2 %, mt+vario 94.2 %
"""
import sys

import numpy as np
from scipy import signal, stats

FS = 500.0
N = 20000          # 40 s window
G = 9.81
MASS = 1.8


def correlation_time(d, max_lag=2000):
    """Lags until the autocorrelation first falls below 0.05 (as uncertainty.cpp)."""
    x = d - d.mean()
    c0 = x @ x
    for k in range(1, max_lag):
        if (x[:-k] @ x[k:]) / c0 < 0.05:
            return k
    return max_lag


def ewp(d, K):
    n = len(d)
    t = np.arange(n)
    v = 0.0
    for k in range(1, K + 1):
        z = np.exp(-2j * np.pi * k * t / n)
        v += abs(d @ z) ** 2
    return v / K, 2 * K


def mt(d, K):
    n = len(d)
    t = np.arange(1, n + 1)
    v = 0.0
    for k in range(1, K + 1):
        h = np.sqrt(2.0 / (n + 1)) * np.sin(np.pi * k * t / (n + 1))
        v += (h @ d) ** 2
    return n * v / K, K   # n f(0); real series: K dof


def vario_plateau(d, m, white_rate):
    """Plateau of V(h) = mean (S_t+h - S_t)^2 over h in [5m, 20m], less white_rate h."""
    S = np.cumsum(d)
    n = len(d)
    hs = np.unique(np.linspace(5 * m, min(20 * m, n // 8), 8).astype(int))
    vals = [np.mean((S[h:] - S[:-h]) ** 2) - white_rate * h * (1 - h / n) for h in hs]
    return max(0.0, float(np.mean(vals))), max(2.0, n / (20.0 * m))


def mass_row(rng, sos, phi_true):
    noise = rng.normal(0.0, 3e-4, N + 2000)
    f = signal.sosfiltfilt(sos, noise)
    acc = np.gradient(np.gradient(f, 1 / FS), 1 / FS)[1000:1000 + N]
    phi = phi_true + acc
    y = MASS * phi_true
    m_hat = (phi @ y) / (phi @ phi)
    d = phi * (y - m_hat * phi) / (phi @ phi)   # influence on m_hat
    return m_hat - MASS, d


def white_row(rng, phi_true, rho):
    e = np.zeros(N)
    w = rng.normal(0.0, 0.05, N)
    for i in range(1, N):
        e[i] = rho * e[i - 1] + w[i]
    y = MASS * phi_true + e
    m_hat = (phi_true @ y) / (phi_true @ phi_true)
    d = phi_true * (y - m_hat * phi_true) / (phi_true @ phi_true)
    return m_hat - MASS, d


def main():
    reps = int(sys.argv[1]) if len(sys.argv) > 1 else 400
    rng = np.random.default_rng(1)
    sos = signal.butter(4, 4.0, fs=FS, output="sos")
    t = np.arange(N) / FS
    phi_true = G + 0.5 * np.sin(2 * np.pi * 0.2 * t) + 0.3 * np.sin(2 * np.pi * 0.37 * t + 1.0)
    cases = {
        "mass row (derivative of noise)": lambda: mass_row(rng, sos, phi_true),
        "white residual": lambda: white_row(rng, phi_true, 0.0),
        "AR(1) 0.9 residual": lambda: white_row(rng, phi_true, 0.9),
    }
    for name, draw in cases.items():
        err, res = [], {"ewp": [], "mt": [], "mt+vario": []}
        for _ in range(reps):
            e, d = draw()
            m = correlation_time(d)
            K = int(np.clip(len(d) // (10 * m), 1, 32))
            err.append(e)
            v, dof = ewp(d, K)
            res["ewp"].append((v, dof))
            v_mt, dof_mt = mt(d, K)
            res["mt"].append((v_mt, dof_mt))
            a, dof_a = vario_plateau(d, m, v_mt / len(d))
            tot = v_mt + a
            dof_tot = tot ** 2 / (v_mt ** 2 / dof_mt + a ** 2 / dof_a) if tot > 0 else dof_mt
            res["mt+vario"].append((tot, dof_tot))
        err = np.array(err)
        sd = err.std(ddof=1)
        print(f"{name}: {reps} replicates, bias/sd {err.mean() / sd:+.2f}")
        for k, r in res.items():
            v = np.array([x[0] for x in r])
            dof = np.array([x[1] for x in r])
            se = np.sqrt(v)
            q = stats.t.ppf(0.975, dof)
            cover = np.mean(np.abs(err) <= q * se)
            print(f"  {k:9s} coverage {100 * cover:5.1f} %  mean se/sd {se.mean() / sd:5.2f}  "
                  f"sd(se)/mean {se.std() / se.mean():4.2f}  corr(se,|err|) {np.corrcoef(se, np.abs(err))[0, 1]:+.2f}")


if __name__ == "__main__":
    main()
