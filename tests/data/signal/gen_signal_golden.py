#!/usr/bin/python3
"""Golden data for tests/test_signal.cpp, computed with SciPy.

Run with a Python that has numpy and scipy (here /usr/bin/python3: numpy 1.24,
scipy 1.10):  /usr/bin/python3 tests/data/signal/gen_signal_golden.py
Writes, next to this script:
  signal_coeffs.json  filter coefficients (Butterworth as second-order sections,
                      FIR taps, first-order filters), initial states, the case lists
  signal_golden.csv   the input signal x and every filtered output, one column each
Deterministic: fixed seed, no time-dependent input. Floats written with repr
(shortest round-trip), so the C++ side reads the exact doubles.
"""
import json
import os
from fractions import Fraction

import numpy as np
import scipy
import scipy.signal as ss

HERE = os.path.dirname(os.path.abspath(__file__))
FS = 500.0
N = 2000

# Test signal: slow and fast sines, seeded noise, a step at t = 1.5 s, and a
# nonzero start value (so the filtfilt edge handling matters).
t = np.arange(N) / FS
rng = np.random.default_rng(20240611)
x = (0.7
     + 1.0 * np.sin(2 * np.pi * 0.3 * t + 0.4)
     + 0.5 * np.sin(2 * np.pi * 2.0 * t)
     + 0.2 * np.sin(2 * np.pi * 7.0 * t + 1.0)
     + 0.1 * np.sin(2 * np.pi * 45.0 * t)
     + 0.05 * np.sin(2 * np.pi * 120.0 * t + 0.3)
     + 0.05 * rng.standard_normal(N)
     + 0.5 * (t >= 1.5))


def exact_zi(b, a):
    """lfilter_zi of the given double coefficients in exact rational arithmetic,
    rounded once to double: the reference for how accurate a zi can be."""
    b = [Fraction(v) / Fraction(a[0]) for v in b]
    a = [Fraction(v) / Fraction(a[0]) for v in a]
    n = max(len(a), len(b))
    b += [Fraction(0)] * (n - len(b))
    a += [Fraction(0)] * (n - len(a))
    G = sum(b) / sum(a)           # DC gain: steady output for a unit step
    zi, acc = [0.0] * (n - 1), Fraction(0)
    for k in range(n - 2, -1, -1):  # z_k = b_{k+1} - a_{k+1} G + z_{k+1}, z_{n-1} = 0
        acc += b[k + 1] - a[k + 1] * G
        zi[k] = float(acc)
    return zi


def matlab_filtfilt(b, a, sig):
    """MATLAB filtfilt == scipy filtfilt with odd padding of 3*(nfilt-1)."""
    padlen = 3 * (max(len(a), len(b)) - 1)
    return ss.filtfilt(b, a, sig, padtype='odd', padlen=padlen)


def cplx(v):
    return [[float(np.real(c)), float(np.imag(c))] for c in v]


cases = []   # zero-phase cases: sosfiltfilt (Butterworth) and filtfilt (FIR)
columns = {"x": x}
coeffs = {}

# Butterworth as second-order sections (order, cutoff Hz, fs Hz), zero-phase
# with scipy.signal.sosfiltfilt's defaults (odd padding, padlen 3 * ntaps).
for order, fc, fs in [(1, 10.0, 500.0), (2, 5.0, 500.0), (3, 1.0, 500.0), (4, 4.0, 500.0),
                      (6, 20.0, 500.0), (8, 30.0, 500.0), (4, 10.0, 100.0), (8, 2.0, 500.0),
                      (6, 0.5, 500.0), (8, 0.5, 500.0), (7, 0.1, 500.0), (5, 200.0, 500.0)]:
    name = f"butter_o{order}_fc{fc:g}_fs{fs:g}"
    sos = ss.butter(order, fc, fs=fs, output='sos')
    coeffs[name] = {"kind": "butter", "order": order, "cutoff_hz": fc, "fs_hz": fs,
                    "sos": sos.tolist(), "zi": ss.sosfilt_zi(sos).tolist()}
    columns["sosfiltfilt_" + name] = ss.sosfiltfilt(sos, x)
    cases.append(name)

# plain sosfilt from rest (zi = None) for one Butterworth
columns["sosfilt_butter_o4_fc4_fs500"] = ss.sosfilt(np.array(coeffs["butter_o4_fc4_fs500"]["sos"]), x)

# Every order the pre-filter allows (1-8) over cutoffs from 10 mHz to just below
# Nyquist at 500 Hz: the sections (design + zpk2sos) and sosfilt_zi.
sweep = []
for order in range(1, 9):
    for fc in [0.01, 0.05, 0.1, 0.5, 1.0, 2.0, 4.0, 10.0, 30.0, 100.0, 200.0, 245.0, 249.9, 249.99]:
        sos = ss.butter(order, fc, fs=FS, output='sos')
        sweep.append({"order": order, "cutoff_hz": fc, "fs_hz": FS, "sos": sos.tolist(),
                      "zi": ss.sosfilt_zi(sos).tolist()})

# zpk2sos beyond Butterworth: complex zeros, odd orders, a real pole and zero
# (scipy's docstring example), an elliptic low-pass and a Chebyshev II band-pass.
zpk_cases = []
for label, (z, p, k) in [
        ("docstring", (np.array([-1, -0.5 - 0.5j, -0.5 + 0.5j]), np.array([0.75, 0.8 + 0.1j, 0.8 - 0.1j]), 1.0)),
        ("ellip5", ss.ellip(5, 0.5, 60, 0.2, output='zpk')),
        ("cheby2_bp4", ss.cheby2(4, 40, [0.1, 0.3], btype='bandpass', output='zpk'))]:
    zpk_cases.append({"name": label, "z": cplx(z), "p": cplx(p), "k": float(k),
                      "sos": ss.zpk2sos(z, p, k).tolist()})

# FIR Blackman-Harris (taps, cutoff Hz, fs Hz); 30 taps: firwin accepts even
# lengths for a low-pass, and so does fir_lowpass_blackmanharris.
for taps, fc, fs in [(31, 4.0, 500.0), (31, 11.0, 500.0), (31, 50.0, 500.0),
                     (51, 20.0, 500.0), (30, 20.0, 500.0), (31, 0.001, 500.0)]:
    name = f"fir_n{taps}_fc{fc:g}_fs{fs:g}"
    h = ss.firwin(taps, fc, window='blackmanharris', fs=fs)
    coeffs[name] = {"kind": "fir", "taps": taps, "cutoff_hz": fc, "fs_hz": fs,
                    "b": list(h), "a": [1.0], "padlen": 3 * (taps - 1)}
    columns["filtfilt_" + name] = matlab_filtfilt(h, [1.0], x)
    cases.append(name)

# First-order filters of the filtered regression model, eqs. (35)-(36), with
# steady-state initial state lfilter_zi * x[0].
LAM, T = 30.0, 0.002
ad = np.exp(-LAM * T)
one_minus_a = -np.expm1(-LAM * T)
first_order = {
    "fD": ([0.0, one_minus_a], [1.0, -ad]),
    "gD_printed": ([LAM, -LAM], [1.0, -ad]),
    "gD_consistent": ([one_minus_a / T, -one_minus_a / T], [1.0, -ad]),
}
for name, (b, a) in first_order.items():
    zi = ss.lfilter_zi(b, a)
    y, _ = ss.lfilter(b, a, x, zi=zi * x[0])
    coeffs[name] = {"kind": "first_order", "lambda": LAM, "T": T, "b": b, "a": a,
                    "zi": list(zi), "zi_exact": exact_zi(b, a)}
    columns["lfilter_" + name] = y

meta = {"generator": "gen_signal_golden.py", "numpy": np.__version__,
        "scipy": scipy.__version__, "fs_hz": FS, "samples": N,
        "zero_phase_cases": cases, "filters": coeffs, "butter_sweep": sweep,
        "zpk2sos": zpk_cases}
with open(os.path.join(HERE, "signal_coeffs.json"), "w") as f:
    json.dump(meta, f, indent=1)

names = list(columns)
with open(os.path.join(HERE, "signal_golden.csv"), "w") as f:
    f.write(",".join(names) + "\n")
    for i in range(N):
        f.write(",".join(repr(float(columns[c][i])) for c in names) + "\n")
print(f"wrote {len(names)} columns x {N} rows, {len(coeffs)} filters, {len(sweep)} sweep designs")
