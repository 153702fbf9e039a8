#!/usr/bin/python3
"""Reference power spectral densities for signal::welch_psd (tests/test_signal.cpp).

Run with /usr/bin/python3 (numpy, scipy): writes welch_golden.json beside this file.
Input: a deterministic signal (two sines, a ramp and a pseudo-random part from a
fixed linear congruential sequence, so that the C++ test can rebuild it exactly).
"""
import json
import os

import numpy as np
from scipy import signal

n, fs, nseg = 1000, 250.0, 128
k = np.arange(n)
state, r = 12345, []
for _ in range(n):
    state = (1103515245 * state + 12345) % 2**31
    r.append(state / 2**31 - 0.5)
x = np.sin(2 * np.pi * 12.5 * k / fs) + 0.3 * np.cos(2 * np.pi * 61.0 * k / fs) + 0.001 * k + 0.2 * np.array(r)
f, p = signal.welch(x, fs=fs, window="hann", nperseg=nseg, noverlap=nseg // 2, detrend="constant",
                    scaling="density", return_onesided=True)
out = {"n": n, "fs": fs, "nseg": nseg, "x": x.tolist(), "psd": p.tolist()}
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "welch_golden.json"), "w") as fh:
    json.dump(out, fh)
