#!/usr/bin/python3
"""Identified on one real Crazyflie flight, how well does the tensor predict the
body torques of the vehicle's other flights, against the published Crazyflie
2.0 tensor (Foerster 2015)? A measurement for the issue notes, not a test: the
flights are not in the repository (../shared/data/crazyflie-usd).

The prediction is written here apart from quadid's code (numpy/scipy):
torques from the logged rotor speeds by the data set's rotor model (kf, arm,
torque ratio of ../shared/data/crazyflie-usd/README.md), against
I w_dot + w x (I w) from the gyro. Both sides are low-passed alike (zero-phase
Butterworth, order 4, 8 Hz: the moment rows' default cutoff) and w_dot is a
central difference. Each flight's mean torque error is removed (a constant
offset is not part of a tensor, and the same for both). quadid's model adds
what it identified besides the tensor: the thrust scale s, the rotors' inertia
(J_r (Omega_r_dot e_z + w x e_z Omega_r), Omega_r the signed sum of the rotor
speeds) and the blade-flapping moment K (e_z x v_body), v_body from the motion
capture (the set's own terms: PC and FMPC carry theirs, moved with the body);
the published tensor has none of these. The score is
the RMS error of each axis over the other flights' samples; "1 Hz high-pass"
repeats it on the errors above 1 Hz, where the aerodynamic moments of
translational flight, which neither tensor models, are small. Two more tables
say why a model wins or loses: each part of it added in turn (tensor alone,
thrust scale, rotor inertia, flapping), and the yaw row fitted alone per
flight and high-pass cutoff (how much of the yaw torque the model explains).

usage: bench/crazyflie_cross_prediction.py [QUADID_EXE] [DATA_DIR]
"""
import json, os, subprocess, sys, tempfile
import numpy as np
from scipy.signal import butter, sosfiltfilt

exe = sys.argv[1] if len(sys.argv) > 1 else "build/quadid"
data = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "crazyflie-usd")
flights = sorted(f for f in os.listdir(data) if f.startswith("jana"))
MASS = 0.0347                      # kg, weighed (README)
KF, ARM, KQ = 2.2164e-10, 0.0325, 0.005964552  # N/rpm^2, m (x and y of each motor), m (README)
POS = np.array([[ARM, -ARM], [-ARM, -ARM], [-ARM, ARM], [ARM, ARM]])  # M1..M4 body (x, y)
YAW = np.array([-1.0, 1.0, -1.0, 1.0])  # tau_z = KQ (-T1 + T2 - T3 + T4)
CF20 = np.array([[16.57, 0.83, 0.72], [0.83, 16.66, 1.80], [0.72, 1.80, 29.26]]) * 1e-6  # kg m^2


def load(path):
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    names = lines[0].strip().split(",")
    d = np.array([[float(v) for v in l.split(",")] for l in lines[1:]])
    return {n: d[:, i] for i, n in enumerate(names)}


def signals(c):
    t = c["t"]
    T = t[1] - t[0]
    sos = butter(4, 8.0, fs=1.0 / T, output="sos")
    F = lambda x: sosfiltfilt(sos, x)
    rpm = np.vstack([c[f"rpm.m{i}"] for i in range(1, 5)])
    thrust = KF * rpm ** 2
    tau = np.vstack([F(POS[:, 1] @ thrust), F(-(POS[:, 0] @ thrust)), F(KQ * (YAW @ thrust))])
    w = np.vstack([F(c["p"]), F(c["q"]), F(c["r"])])
    wd = np.gradient(w, T, axis=1)
    # Omega_r: + for the counter-clockwise rotors M1, M3 (README), rad/s.
    om = F((rpm[0] - rpm[1] + rpm[2] - rpm[3]) * 2.0 * np.pi / 60.0)
    omd = np.gradient(om, T)
    # Body velocity: the motion capture's world velocity rotated by R^T (ZYX Euler angles).
    vw = np.vstack([np.gradient(F(c[k]), T) for k in ("x", "y", "z")])
    ph, th, ps = F(c["phi"]), F(c["theta"]), F(c["psi"])
    cf, sf, ct, st, cp, sp = np.cos(ph), np.sin(ph), np.cos(th), np.sin(th), np.cos(ps), np.sin(ps)
    R = np.array([[cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
                  [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
                  [-st, ct * sf, ct * cf]])  # body -> world, 3 x 3 x n
    vb = np.einsum("jin,jn->in", R, vw)
    edge = int(round(1.0 / T))  # the filters' settling, 1 s at each end
    cut = lambda x: x[..., edge:-edge]
    return T, cut(tau), cut(w), cut(wd), cut(om), cut(omd), cut(vb)


def errors(model, sig):
    I, s, jr, kx, ky = model
    T, tau, w, wd, om, omd, vb = sig
    ez = np.array([0.0, 0.0, 1.0])
    need = I @ wd + np.cross(w.T, (I @ w).T).T                       # rigid body
    need += jr * (omd * ez[:, None] + np.cross(w.T, ez).T * om)       # rotors' inertia
    need += np.vstack([kx * -vb[1], ky * vb[0], 0.0 * vb[0]])         # + K (e_z x v_body)
    e = tau - need / s                                                # the rotor model's torque is 1/s of the true one
    return T, e - e.mean(axis=1, keepdims=True)


def tensor(est):
    return np.array([[est["Ixx"], est["Ixy"], est["Ixz"]], [est["Ixy"], est["Iyy"], est["Iyz"]],
                     [est["Ixz"], est["Iyz"], est["Izz"]]])


with tempfile.TemporaryDirectory() as tmp:
    sig, ident = {}, {}
    for f in flights:
        csv = os.path.join(tmp, f + ".csv")
        subprocess.run([exe, "import", os.path.join(data, f), "-o", csv], check=True, capture_output=True)
        sig[f] = signals(load(csv))
        out = subprocess.run([exe, "identify", os.path.join(data, f), "--vehicle", "crazyflie21", "--known-mass",
                              str(MASS), "--ignore-input-errors", "--json"], check=True, capture_output=True, text=True)
        j = json.loads(out.stdout)
        rec = j["recommended"]["set"]
        x = j["estimates"][rec].get("extra") or j["estimates"][{"PC": "LS", "FMPC": "FMLS"}.get(rec, rec)].get("extra", {})
        ident[f] = (rec, (tensor(j["estimates"][rec]), x.get("thrust_scale", 1.0), x.get("rotor_inertia", 0.0),
                          x.get("flapping_x", 0.0), x.get("flapping_y", 0.0)))

    def score(I, others, highpass):
        sq, n = np.zeros(3), 0
        for g in others:
            T, e = errors(I, sig[g])
            if highpass:
                e = e - sosfiltfilt(butter(2, 1.0, fs=1.0 / T, output="sos"), e, axis=1)
            sq += (e ** 2).sum(axis=1)
            n += e.shape[1]
        return np.sqrt(sq / n)

    for highpass in (False, True):
        print(f"\n== torque prediction RMS on the other flights, 1e-6 N m ({'1 Hz high-pass' if highpass else 'to 8 Hz'})")
        print(f"{'identified on':14} {'set':5} {'roll':>8} {'pitch':>8} {'yaw':>8} {'vector':>8}   {'CF2.0 roll':>10} {'pitch':>8} "
              f"{'yaw':>8} {'vector':>8}   better")
        wins = vector_wins = 0
        for f in flights:
            others = [g for g in flights if g != f]
            a, b = score(ident[f][1], others, highpass), score((CF20, 1.0, 0.0, 0.0, 0.0), others, highpass)
            # The torque vector's RMS error: sqrt(mean |e|^2) = the three axes' RMS combined.
            va, vb = np.sqrt((a ** 2).sum()), np.sqrt((b ** 2).sum())
            better = (a <= b).all()
            wins += better
            vector_wins += va <= vb
            print(f"{f:14} {ident[f][0]:5} {a[0]*1e6:8.2f} {a[1]*1e6:8.2f} {a[2]*1e6:8.2f} {va*1e6:8.2f}   {b[0]*1e6:10.2f} "
                  f"{b[1]*1e6:8.2f} {b[2]*1e6:8.2f} {vb*1e6:8.2f}   {'yes' if better else 'no'} "
                  f"({', '.join(f'{100*(x/y-1):+.0f} %' for x, y in zip(a, b))}; vector {100*(va/vb-1):+.1f} %)")
        print(f"better on every axis: {wins}/{len(flights)}; better on the torque vector: {vector_wins}/{len(flights)}")

    # Which part of each identified model wins or loses: the tensor alone
    # (thrust scale 1, no rotor inertia, no flapping), then each extra term added.
    print("\n== what each part contributes: RMS error against the Crazyflie 2.0 tensor's, % (roll, pitch, yaw; to 8 Hz)")
    for f in flights:
        I, s, jr, kx, ky = ident[f][1]
        others = [g for g in flights if g != f]
        b = score((CF20, 1.0, 0.0, 0.0, 0.0), others, False)
        parts = [("tensor", (I, 1.0, 0.0, 0.0, 0.0)), ("+ s", (I, s, 0.0, 0.0, 0.0)),
                 ("+ J_r", (I, s, jr, 0.0, 0.0)), ("+ flapping", (I, s, jr, kx, ky))]
        print(f"{f:8} " + "  ".join(f"{n}: {', '.join(f'{100*(x/y-1):+.1f}' for x, y in zip(score(m, others, False), b))}"
                                   for n, m in parts))

    # The yaw row on its own, per flight and band: tau_psi (rotor model) against
    # Izz r_dot + (Iyy - Ixx) p q + J_r Omega_r_dot, each signal high-passed alike
    # (0 Hz: mean removed). "unexplained" is the residual's share of tau_psi's power.
    print("\n== the yaw row alone: Izz (1e-6 kg m^2), J_r (1e-8 kg m^2), unexplained % by high-pass cutoff")
    for f in flights:
        T, tau, w, wd, om, omd, vb = sig[f]
        cells = []
        for hp in (0.0, 0.5, 1.0, 2.0, 3.0):
            H = (lambda x: x - x.mean()) if hp == 0 else (lambda x: x - sosfiltfilt(butter(2, hp, fs=1.0 / T, output="sos"), x))
            A = np.vstack([H(wd[2]), H(w[0] * w[1]), H(omd)]).T
            y = H(tau[2])
            x, *_ = np.linalg.lstsq(A, y, rcond=None)
            cells.append(f"{hp:g} Hz: {x[0]*1e6:5.1f} {x[2]*1e8:5.2f} {100*np.sum((y - A @ x)**2)/np.sum(y**2):3.0f} %")
        print(f"{f:8} " + " | ".join(cells))
