#!/usr/bin/python3
"""Independent reference for tests/test_design.cpp (quadid design module).

Evaluates, with numpy only and without the C++ code's formulas for the
derivatives of the angles:
  * eq. (18) and its derivatives in closed form,
  * the desired roll/pitch of eqs. (26)-(27),
  * the limits of section III-B on a 1 ms grid (worst value and where),
  * the start/end conditions,
  * cond(W) of eq. (20): W stacks the 4x7 regressor of eqs. (7)-(10) over one
    period at T = 2 ms; omega = W(eta)^-1 eta_dot with the paper's W(eta)
    inverted numerically, v = R^T p_dot; eta_dot, eta_ddot, v_dot and
    omega_dot come from 8th-order central finite differences in time
    (h = 1e-3 s), not from the chain rule. cond is numpy's SVD 2-norm cond.

Writes design_golden.json beside this script. Run: /usr/bin/python3 gen_design_golden.py
"""
import json
import math
import os

import numpy as np

G = 9.81
DEG = math.pi / 180.0

TABLE2 = {
    "x": ([-0.1000, -0.0386, -0.0828, -0.0698, 0.2911], [-0.0712, 0.0290, 0.0218, 0.0249, -0.0304], -0.0784),
    "y": ([-0.0163, 0.0418, -0.0079, 0.0147, -0.0322], [0.2112, 0.0830, 0.0954, 0.1418, -0.2462], 0.4310),
    "z": ([-0.0338, -0.1039, 0.2224, -0.0738, -0.0108], [0.0833, 0.0414, 0.2020, -0.1457, -0.0379], 0.9026),
    "psi": ([0.1959, 0.1709, -0.0586, -0.2600, -0.0483], [0.1136, -0.2140, 0.1724, -0.0428, -0.0063], 0.0830),
}

# A second, livelier trajectory (3 harmonics, 8 s period) with larger tilt and yaw.
OTHER = {
    "x": ([0.30, -0.20, 0.15], [0.10, 0.25, -0.12], 0.05),
    "y": ([-0.25, 0.10, 0.20], [0.30, -0.15, 0.05], -0.10),
    "z": ([0.10, 0.12, -0.08], [-0.05, 0.10, 0.07], 1.00),
    "psi": ([0.40, -0.30, 0.25], [0.20, 0.35, -0.15], 0.30),
}
OTHER_WF = 2 * math.pi / 8.0

LIMITS = dict(x_max=1.0, y_max=1.0, z_min=0.7, z_max=1.5, psi_max=180 * DEG, tilt_max=5.73 * DEG,
              xdot_max=0.5, ydot_max=0.5, zdot_max=0.5, psidot_max=28.65 * DEG, zddot_min=-9.81)
Q0 = {"x": 0.0, "y": 0.0, "z": 0.7, "psi": 0.0}


def q(coeffs, wf, t, n):
    """n-th derivative of eq. (18) for one axis, differentiated by hand:
    d^n/dt^n sin(wt) = w^n sin(wt + n pi/2), d^n/dt^n cos(wt) = w^n cos(wt + n pi/2)."""
    a, b, c = coeffs
    t = np.asarray(t, dtype=float)
    out = np.full_like(t, c if n == 0 else 0.0)
    for l in range(1, len(a) + 1):
        w = wf * l
        out = out + (a[l - 1] / w) * w**n * np.sin(w * t + n * math.pi / 2) \
            - (b[l - 1] / w) * w**n * np.cos(w * t + n * math.pi / 2)
    return out


def angles(tr, wf, t):
    xdd, ydd, zdd = (q(tr[k], wf, t, 2) for k in ("x", "y", "z"))
    psi = q(tr["psi"], wf, t, 0)
    theta = np.arctan((np.cos(psi) * xdd + np.sin(psi) * ydd) / (zdd + G))                   # eq. (26)
    phi = np.arctan(np.cos(theta) * (np.sin(psi) * xdd - np.cos(psi) * ydd) / (zdd + G))    # eq. (27)
    return phi, theta, psi


# 8th-order central difference for the first derivative.
FD_W = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
FD_H = 1e-3


def ddt(f, t):
    """d/dt of a vector-valued function of time (returns shape of f(t))."""
    return sum(w * f(t + (j - 4) * FD_H) for j, w in enumerate(FD_W) if w != 0.0) / FD_H


def R_of(phi, theta, psi):
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    R = np.empty(phi.shape + (3, 3))
    R[..., 0, 0] = ct * cp; R[..., 0, 1] = st * cp * sf - sp * cf; R[..., 0, 2] = st * cp * cf + sp * sf
    R[..., 1, 0] = ct * sp; R[..., 1, 1] = st * sp * sf + cp * cf; R[..., 1, 2] = st * sp * cf - cp * sf
    R[..., 2, 0] = -st;     R[..., 2, 1] = ct * sf;                R[..., 2, 2] = ct * cf
    return R


def W_of(phi, theta):
    """The paper's W(eta) (section II-A): eta_dot = W omega."""
    cf, sf, ct, tt = np.cos(phi), np.sin(phi), np.cos(theta), np.tan(theta)
    W = np.zeros(phi.shape + (3, 3))
    W[..., 0, 0] = 1; W[..., 0, 1] = sf * tt; W[..., 0, 2] = cf * tt
    W[..., 1, 1] = cf; W[..., 1, 2] = -sf
    W[..., 2, 1] = sf / ct; W[..., 2, 2] = cf / ct
    return W


def eta(tr, wf, t):
    phi, theta, psi = angles(tr, wf, t)
    return np.stack([phi, theta, psi], axis=-1)


def omega(tr, wf, t):
    e = eta(tr, wf, t)
    edot = ddt(lambda s: eta(tr, wf, s), t)
    return np.linalg.solve(W_of(e[..., 0], e[..., 1]), edot[..., None])[..., 0]


def vbody(tr, wf, t):
    e = eta(tr, wf, t)
    pdot = np.stack([q(tr[k], wf, t, 1) for k in ("x", "y", "z")], axis=-1)
    return np.einsum("...ji,...j->...i", R_of(e[..., 0], e[..., 1], e[..., 2]), pdot)  # R^T p_dot


def regressor_stack(tr, wf, T):
    period = 2 * math.pi / wf
    K = int(round(period / T))
    t = np.arange(K) * (period / K)
    e = eta(tr, wf, t)
    v = vbody(tr, wf, t)
    vd = ddt(lambda s: vbody(tr, wf, s), t)
    w = omega(tr, wf, t)
    wd = ddt(lambda s: omega(tr, wf, s), t)
    u, vv = v[:, 0], v[:, 1]
    p, qq, r = w[:, 0], w[:, 1], w[:, 2]
    pd, qd, rd = wd[:, 0], wd[:, 1], wd[:, 2]
    gbz = G * np.cos(e[:, 1]) * np.cos(e[:, 0])
    Z = np.zeros_like(p)
    # eqs. (7)-(10): rows Fz, tau_phi, tau_theta, tau_psi; columns m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz.
    rows = [
        [vd[:, 2] + p * vv - qq * u + gbz, Z, Z, Z, Z, Z, Z],
        [Z, pd, qd - p * r, rd + p * qq, -qq * r, qq * qq - r * r, qq * r],
        [Z, p * r, pd + qq * r, r * r - p * p, qd, rd - p * qq, -p * r],
        [Z, -p * qq, p * p - qq * qq, pd - qq * r, p * qq, qd + p * r, rd],
    ]
    Phi = np.array(rows).transpose(2, 0, 1)  # K x 4 x 7
    return Phi.reshape(-1, 7), K


def check(tr, wf):
    period = 2 * math.pi / wf
    t = np.arange(int(math.floor(period / 1e-3 + 1e-9)) + 1) * 1e-3
    if period - t[-1] > 1e-12:
        t = np.append(t, period)
    phi, theta, psi = angles(tr, wf, t)
    fam = {
        "x": ("abs", q(tr["x"], wf, t, 0)), "y": ("abs", q(tr["y"], wf, t, 0)),
        "z_min": ("min", q(tr["z"], wf, t, 0)), "z_max": ("max", q(tr["z"], wf, t, 0)),
        "psi": ("abs", psi), "phi": ("abs", phi), "theta": ("abs", theta),
        "xdot": ("abs", q(tr["x"], wf, t, 1)), "ydot": ("abs", q(tr["y"], wf, t, 1)),
        "zdot": ("abs", q(tr["z"], wf, t, 1)), "psidot": ("abs", q(tr["psi"], wf, t, 1)),
        "zddot_min": ("min", q(tr["z"], wf, t, 2)),
    }
    out = {}
    for name, (kind, f) in fam.items():
        if kind == "abs":
            k = int(np.argmax(np.abs(f))); worst = float(abs(f[k]))
        elif kind == "min":
            k = int(np.argmin(f)); worst = float(f[k])
        else:
            k = int(np.argmax(f)); worst = float(f[k])
        out[name] = {"worst": worst, "time": float(t[k])}
    ends = {}
    for ax in ("x", "y", "z", "psi"):
        ends[ax] = [float(q(tr[ax], wf, np.array([0.0]), n)[0]) for n in range(3)]
    Wst, K = regressor_stack(tr, wf, 0.002)
    return {"constraints": out, "start": ends, "cond": float(np.linalg.cond(Wst)), "samples": K,
            "period": period}


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    res = {
        "note": "generated by gen_design_golden.py (numpy); limits in SI units and radians",
        "limits": LIMITS,
        "table2": dict(wf=36 * DEG, **check(TABLE2, 36 * DEG)),
        "other": dict(wf=OTHER_WF, coefficients={k: {"a": v[0], "b": v[1], "c": v[2]} for k, v in OTHER.items()},
                      **check(OTHER, OTHER_WF)),
    }
    with open(os.path.join(here, "design_golden.json"), "w") as f:
        json.dump(res, f, indent=1, sort_keys=True)
        f.write("\n")
    print("table2 cond", res["table2"]["cond"], " other cond", res["other"]["cond"])


if __name__ == "__main__":
    main()
