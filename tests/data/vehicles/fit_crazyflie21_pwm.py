#!/usr/bin/python3
"""Fit of the built-in `crazyflie21-pwm` rotor input (src/vehicle/builtin_vehicles.cpp)
on the real Crazyflie 2.1 flights of ../shared/data/crazyflie-usd, which log both the
motor PWM (pwm.mK_pwm, 0..65535), the battery voltage (pm.vbatMV) and the rotor speed
(rpm.mK, RPM deck). Independent of quadid: the uSD parser of the reader's test
(tests/data/logs/usd_reference.py, from the format in that folder's README.md),
numpy and scipy.

Model (docs/vehicles.md, input = "duty"):
  V_i   = pwm_i / 65535 * vbat                (applied voltage, V; vbat sags under load)
  w*_i  = c0 + c1 V_i + c2 V_i^2              (steady rotor speed, rpm; quadid holds it
                                               at the vertex below V = -c1 / (2 c2))
  tau w_i' = w*_i - w_i                       (first-order motor lag, exact with w* held)
one set of (c0, c1, c2, tau) for all four motors and flights. A straight line
fits 0.1-0.7 points worse and makes the torques' gain vary more between flights
(docs/crazyflie.md); it is printed for comparison, with a fit that ignores the
battery sag. Also fitted, for
`simulate` only: the battery, vbat = v0_f - sag * sum_i kf rpm_i^2 - drain * t
(v0 per flight; sag in V per N of total thrust, drain in V/s).

usage: /usr/bin/python3 tests/data/vehicles/fit_crazyflie21_pwm.py [DATA_DIR]
Output (committed beside it): fit_crazyflie21_pwm.txt
"""
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'logs'))
import usd_reference  # noqa: E402  the independent uSD parser of the reader's test

KF = 2.2164e-10  # N/rpm^2, the data set's README (Bitcraze thrust stand)


def parse(data):
    """{event name: (variable names, records as an array: timestamp first)}."""
    _, _, events = usd_reference.parse(data, values=True)
    return {name: (names, np.array(rows, dtype=float)) for name, _, _, names, rows in events.values()}


def load(folder):
    flights = {}
    for f in sorted(Path(folder).glob('jana*')):
        names, a = parse(f.read_bytes())['fixedFrequency']
        col = lambda n: a[:, 1 + names.index(n)]
        t = a[:, 0] * 1e-6
        pwm = np.stack([col(f'pwm.m{i}_pwm') for i in range(1, 5)], 1)
        rpm = np.stack([col(f'rpm.m{i}') for i in range(1, 5)], 1)
        flights[f.name] = (t - t[0], pwm, rpm, col('pm.vbatMV') * 1e-3)
    return flights


def lagged(tau, t, target):
    w = np.empty_like(target)
    w[0] = target[0]
    a = np.exp(-np.diff(t) / max(tau, 1e-6))
    for k in range(len(t) - 1):
        w[k + 1] = target[k] + (w[k] - target[k]) * a[k]
    return w


def predict(p, t, volts):
    tau, c0, c1 = p[:3]
    c2 = p[3] if len(p) > 3 else 0.0
    if c2 > 0:  # the increasing branch only, as quadid's RotorModel::speed_of_applied_voltage
        volts = np.maximum(volts, -c1 / (2 * c2))
    return lagged(tau, t, c0 + c1 * volts + c2 * volts ** 2)


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else str(Path(__file__).resolve().parents[4] / 'shared' / 'data' / 'crazyflie-usd')
    flights = load(folder)

    def residuals(p, with_battery=True):
        r = []
        for t, pwm, rpm, vb in flights.values():
            v = vb if with_battery else np.full_like(vb, np.median(vb))
            for i in range(4):
                r.append(predict(p, t, pwm[:, i] / 65535 * v) - rpm[:, i])
        return np.concatenate(r)

    fits = {}
    cases = (('measured vbat, quadratic (the model)', True, [0.05, 4000, 9000, 0]),
             ('measured vbat, straight line', True, [0.05, 4000, 9000]),
             ('vbat held at its median (no sag), quadratic', False, [0.05, 4000, 9000, 0]))
    for label, wb, p0 in cases:
        fits[label] = least_squares(lambda p: residuals(p, wb), p0, x_scale='jac').x
    p = fits[cases[0][0]]
    print('rotor input fit (all four flights, four motors, one parameter set)')
    print(f'  time_constant = {p[0]:.5f} s')
    print(f'  speed_of_voltage = [{p[1]:.6g}, {p[2]:.6g}, {p[3]:.6g}]  (rpm = c0 + c1 V + c2 V^2)')
    print(f'  straight line, for comparison: {fits[cases[1][0]]}')
    for label, q in fits.items():
        print(f'rms rpm error, % of mean rpm, per flight and motor; {label}:')
        for name, (t, pwm, rpm, vb) in flights.items():
            v = vb if label.startswith('measured') else np.full_like(vb, np.median(vb))
            e = [np.sqrt(np.mean((predict(q, t, pwm[:, i] / 65535 * v) - rpm[:, i]) ** 2)) / np.mean(rpm[:, i]) * 100
                 for i in range(4)]
            print(f'  {name}: ' + ' '.join(f'{x:5.2f}' for x in e))
    # Battery, for simulate: vbat = v0_f - sag * total thrust - drain * t.
    rows, rhs = [], []
    names = list(flights)
    for j, (t, pwm, rpm, vb) in enumerate(flights.values()):
        T = KF * (rpm ** 2).sum(1)
        A = np.zeros((len(t), len(names) + 2))
        A[:, j] = 1.0
        A[:, -2] = -T
        A[:, -1] = -t
        rows.append(A)
        rhs.append(vb)
    x, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
    res = np.concatenate(rhs) - np.vstack(rows) @ x
    print('battery (simulate only): vbat = v0 - sag * sum(T) - drain * t')
    print('  v0 per flight: ' + ', '.join(f'{n} {v:.3f} V' for n, v in zip(names, x[:-2])))
    print(f'  sag = {x[-2]:.4f} V/N, drain = {x[-1]:.5f} V/s, rms residual {np.sqrt(np.mean(res ** 2)) * 1e3:.1f} mV')


if __name__ == '__main__':
    main()
