#!/usr/bin/python3
"""An independent quadrotor simulator, written apart from quadid's own.

It shares no code and no formulation with src/simulation: a quaternion rigid
body with a full inertia tensor, rotors with first-order speed lag and their
own inertia (gyroscopic and reaction torques), a geometric tracking controller
(Lee et al. 2010 style, not the paper's PID), classical RK4 at 2 ms (the controller at 500 Hz, zero-order hold), and the
sensors of a lab flight: motion capture held at its own rate with noise, a
noisy gyro, noisy and quantised rotor speeds in rpm. Optional unmodelled
aerodynamics: rotor drag force against the air-relative velocity, blade
flapping moment against the air-relative velocity, and wind with gusts.

The log it writes holds ONLY what a real vehicle logs:
    t, x, y, z, phi, theta, psi (motion capture), p, q, r (gyro), rpm1..rpm4
and the vehicle file (quadid's TOML format) describes the rotors. The true
parameters go to a JSON file beside the log, for the acceptance script.

Usage: indep_sim.py --vehicle NAME --seed N --out DIR [--aero] [--duration S]
Requires numpy only (/usr/bin/python3 on Debian: python3-numpy).
"""
import argparse
import json
import math
import os

import numpy as np

# ---------------------------------------------------------------------------
# Vehicles. Rotor i at positions[i] (body FLU, m), spin +1 = counter-clockwise
# seen from above (angular momentum +z body). kf in N/(rad/s)^2.
VEHICLES = {
    # A 2 kg X-frame quad (650 mm class), a deliberately off-diagonal tensor
    # (battery and payload off-centre).
    "heavy-x": dict(
        m=2.05, I=[[0.0285, -0.0012, 0.0009], [-0.0012, 0.0310, -0.0007], [0.0009, -0.0007, 0.0540]],
        arm=0.325, layout="x", kf=1.9e-5, torque_ratio=0.016, tau_m=0.035, J_r=6.0e-5,
        omega_max=1100.0),
    # A 0.55 kg "+" frame quad (250 mm class).
    "mid-plus": dict(
        m=0.55, I=[[0.0021, 0.00008, -0.00012], [0.00008, 0.0026, 0.00010], [-0.00012, 0.00010, 0.0041]],
        arm=0.125, layout="+", kf=2.8e-6, torque_ratio=0.011, tau_m=0.025, J_r=6.0e-6,
        omega_max=2600.0),
    # A 32 g nano quad (Crazyflie class).
    "nano-x": dict(
        m=0.032, I=[[1.62e-5, 0.07e-5, 0.05e-5], [0.07e-5, 1.71e-5, 0.10e-5], [0.05e-5, 0.10e-5, 2.95e-5]],
        arm=0.046, layout="x", kf=1.9e-8, torque_ratio=0.0059, tau_m=0.03, J_r=2.5e-9,
        omega_max=2800.0),
}

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
G = 9.81


def rotor_geometry(v):
    a = v["arm"]
    if v["layout"] == "x":
        c = a / math.sqrt(2.0)
        pos = [(c, -c), (-c, -c), (-c, c), (c, c)]      # front-right, back-right, back-left, front-left
        spin = [1, -1, 1, -1]
    else:
        pos = [(a, 0.0), (0.0, a), (-a, 0.0), (0.0, -a)]  # front, left, back, right
        spin = [1, -1, 1, -1]
    return np.array(pos), np.array(spin, dtype=float)


# ---------------------------------------------------------------------------
# Quaternion helpers, q = (w, x, y, z), body -> world.
def quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def quat_to_R(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def R_to_zyx(R):
    # R = Rz(psi) Ry(theta) Rx(phi)
    theta = -math.asin(max(-1.0, min(1.0, R[2, 0])))
    phi = math.atan2(R[2, 1], R[2, 2])
    psi = math.atan2(R[1, 0], R[0, 0])
    return phi, theta, psi


def cross(a, b):
    # np.cross is ~20x slower on 3-vectors (axis handling); this is the whole cost.
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])



def vee(M):
    return np.array([M[2, 1], M[0, 2], M[1, 0]])


# ---------------------------------------------------------------------------
class Reference:
    """Sums of sines in x, y, z, yaw under a smooth window (zero velocity at the
    ends); random amplitudes and phases from the seed."""

    def __init__(self, rng, duration, scale):
        self.T = duration
        self.f0 = 1.0 / duration
        self.terms = []
        # (axis, amplitude per harmonic, harmonics) tuned to excite attitude.
        # Harmonics of 1/duration up to about 1 Hz, amplitudes falling as 1/h^0.8
        # so that the accelerations (tilt) stay moderate while the snap (angular
        # acceleration) grows: what an identification flight needs.
        for axis, amp, hs in (("x", 0.8 * scale, (3, 5, 8, 12, 17, 24, 33, 41)),
                              ("y", 0.8 * scale, (4, 6, 9, 13, 19, 27, 37, 43)),
                              ("z", 0.25 * scale, (2, 7, 11, 16)), ("yaw", 0.9, (3, 7, 10, 15, 22))):
            for h in hs:
                a = amp * rng.uniform(0.5, 1.0) * (min(1.0, (3.0 / h) ** 0.8) if axis != "yaw" else 1.0 / (1.0 + 0.12 * h))
                self.terms.append((axis, a, 2.0 * math.pi * h * self.f0, rng.uniform(0, 2 * math.pi)))
        self.z0 = 1.0 * max(scale, 0.5)

    def window(self, t):
        # w(t) = sin^2(pi t / T): zero value and slope at both ends.
        s = np.sin(math.pi * t / self.T)
        c = np.cos(math.pi * t / self.T)
        k = math.pi / self.T
        return s * s, 2 * s * c * k, 2 * k * k * (c * c - s * s), -8 * k ** 3 * s * c, -8 * k ** 4 * (c * c - s * s)

    def __call__(self, t):
        """Position and yaw with their derivatives 0..4 at the times t (array)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = {a: np.zeros((5, t.size)) for a in ("x", "y", "z", "yaw")}
        for axis, a, w, ph in self.terms:
            s, c = np.sin(w * t + ph), np.cos(w * t + ph)
            out[axis] += a * np.array([s, w * c, -w * w * s, -w ** 3 * c, w ** 4 * s])
        W = self.window(t)
        res = {}
        for axis, f in out.items():
            # Leibniz rule: (W f)^(n) = sum_k C(n, k) W^(k) f^(n-k)
            res[axis] = np.array([sum(math.comb(n, k) * W[k] * f[n - k] for k in range(n + 1)) for n in range(5)])
        res["z"][0] += self.z0
        return res


# ---------------------------------------------------------------------------
class Simulator:
    def __init__(self, v, rng, aero, wind=0.0, payload=None):
        self.v = v
        # (t, dm): a point mass added at the centre of mass at t (the controller keeps m).
        self.payload = payload
        self.rng = rng
        self.m = v["m"]
        self.I = np.array(v["I"])
        self.Iinv = np.linalg.inv(self.I)
        self.pos, self.spin = rotor_geometry(v)
        self.kf = v["kf"]
        self.kq = v["torque_ratio"] * v["kf"]
        self.tau_m = v["tau_m"]
        self.J_r = v["J_r"]
        self.omega_max = v["omega_max"]
        # Allocation: [Fz, tau_x, tau_y, tau_z] = A @ T (thrusts)
        A = np.zeros((4, 4))
        for i in range(4):
            x, y = self.pos[i]
            A[:, i] = [1.0, y, -x, -self.spin[i] * v["torque_ratio"]]
        self.A = A
        self.Ainv = np.linalg.inv(A)
        self.aero = aero
        # Unmodelled aerodynamics (per unit air-relative velocity).
        hover_T = self.m * G
        self.drag = 0.12 * hover_T / 4.0 if aero else 0.0          # N/(m/s) horizontal body
        self.drag_z = 0.05 * hover_T / 4.0 if aero else 0.0
        self.flap = 0.02 * hover_T * v["arm"] / 4.0 if aero else 0.0   # N m/(m/s)
        # Wind: a steady part of `wind` m/s from a random direction, and gusts
        # (sines of 0.1-1.5 Hz) of up to half of it per axis.
        heading = rng.uniform(0, 2 * math.pi)
        self.wind_mean = wind * np.array([math.cos(heading), math.sin(heading), 0.0])
        self.gust = [(wind * rng.uniform(0.2, 0.5), rng.uniform(0.1, 1.5), rng.uniform(0, 6.3), k) for k in range(3)]

    def wind(self, t):
        w = self.wind_mean.copy()
        for a, f, ph, k in self.gust:   # gusts: x and y at amplitude a, z at 0.3 a
            w[k] += (a if k < 2 else 0.3 * a) * math.sin(2 * math.pi * f * t + ph)
        return w

    def derivatives(self, t, s, omega_cmd):
        # state: p(3) v(3) q(4) w(3) Omega(4)
        v, q, w, Om = s[3:6], s[6:10], s[10:13], s[13:17]
        R = quat_to_R(q)
        T = self.kf * Om * Om
        Q = self.kq * Om * Om
        F_b = np.array([0.0, 0.0, T.sum()])
        tau = np.array([np.dot(self.pos[:, 1], T), -np.dot(self.pos[:, 0], T), -np.dot(self.spin, Q)])
        if self.aero:
            v_air_b = R.T @ (v - self.wind(t))
            F_b += np.array([-self.drag * v_air_b[0], -self.drag * v_air_b[1], -self.drag_z * v_air_b[2]])
            tau += -self.flap * cross([0.0, 0.0, 1.0], v_air_b)
        Om_dot = (omega_cmd - Om) / self.tau_m
        Omega_r = np.dot(self.spin, Om)
        Omega_r_dot = np.dot(self.spin, Om_dot)
        h = self.I @ w + np.array([0.0, 0.0, self.J_r * Omega_r])
        # d/dt (I w + h_r) + w x (I w + h_r) = tau  (body and rotors together)
        w_dot = self.Iinv @ (tau - cross(w, h) - np.array([0.0, 0.0, self.J_r * Omega_r_dot]))
        m = self.m + (self.payload[1] if self.payload and t >= self.payload[0] else 0.0)
        a = R @ F_b / m - np.array([0.0, 0.0, G])
        q_dot = 0.5 * quat_mul(q, np.array([0.0, *w]))
        return np.concatenate([v, a, q_dot, w_dot, Om_dot])

    def control(self, s, r):
        """Geometric tracking controller: thrust vector from position error,
        attitude error on SO(3), rate feedback; feed-forward of the reference's
        acceleration and (through the jerk and snap) angular rate/acceleration
        is left out on purpose: the tracking error is part of a real flight."""
        p, v, q, w = s[0:3], s[3:6], s[6:10], s[10:13]
        R = quat_to_R(q)
        pd, vd, ad = r[0:3], r[3:6], r[6:9]
        kp, kv = 6.0, 4.0
        F_w = self.m * (kp * (pd - p) + kv * (vd - v) + ad + np.array([0.0, 0.0, G]))
        b3 = F_w / np.linalg.norm(F_w)
        psi = r[9]
        c1 = np.array([math.cos(psi), math.sin(psi), 0.0])
        b2 = cross(b3, c1)
        b2 /= np.linalg.norm(b2)
        b1 = cross(b2, b3)
        Rd = np.column_stack([b1, b2, b3])
        eR = 0.5 * vee(Rd.T @ R - R.T @ Rd)
        wd = np.array([0.0, 0.0, r[10]])
        ew = w - R.T @ Rd @ wd
        # Gains scaled with the inertia so every vehicle gets similar bandwidth.
        kR = np.diag(self.I) * 120.0
        kw = np.diag(self.I) * 16.0
        tau = -kR * eR - kw * ew + cross(w, self.I @ w)
        Fz = float(F_w @ R[:, 2])
        T = self.Ainv @ np.array([Fz, *tau])
        T = np.clip(T, 0.02 * self.m * G / 4.0, self.kf * self.omega_max ** 2)
        return np.sqrt(T / self.kf)

    def run(self, ref, duration, dt=0.002):
        n = int(round(duration / dt))
        rr = ref(np.arange(n + 1) * dt)
        # per step: position, velocity, acceleration (3 each), yaw, yaw rate
        table = np.vstack([np.array([rr[a][d] for a in ("x", "y", "z")]) for d in range(3)] +
                          [rr["yaw"][0:2]]).T
        s = np.zeros(17)
        s[0:3] = table[0, 0:3]
        yaw0 = table[0, 9]
        s[6:10] = [math.cos(yaw0 / 2), 0.0, 0.0, math.sin(yaw0 / 2)]
        hover = math.sqrt(self.m * G / 4.0 / self.kf)
        s[13:17] = hover
        states = np.zeros((n + 1, 17))
        states[0] = s
        for k in range(n):
            t = k * dt
            cmd = self.control(s, table[k])   # zero-order hold over the step
            k1 = self.derivatives(t, s, cmd)
            k2 = self.derivatives(t + dt / 2, s + dt / 2 * k1, cmd)
            k3 = self.derivatives(t + dt / 2, s + dt / 2 * k2, cmd)
            k4 = self.derivatives(t + dt, s + dt * k3, cmd)
            s = s + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            s[6:10] /= np.linalg.norm(s[6:10])
            states[k + 1] = s
        return states


def write_log(path, states, dt_sim, rng, log_rate=500.0, mocap_rate=100.0,
              pos_noise=0.0005, ang_noise=math.radians(0.15), gyro_noise=0.01, rpm_noise=0.004):
    stride = int(round(1.0 / log_rate / dt_sim))
    mocap_stride = int(round(1.0 / mocap_rate / dt_sim))
    rows = []
    last_mocap = None
    psi_prev, psi_unwrap = None, 0.0
    n = states.shape[0]
    for k in range(0, n, stride):
        s = states[k]
        if k % mocap_stride == 0 or last_mocap is None:
            R = quat_to_R(s[6:10])
            phi, theta, psi = R_to_zyx(R)
            if psi_prev is None:
                psi_unwrap = psi
            else:
                d = psi - psi_prev
                d -= 2 * math.pi * round(d / (2 * math.pi))
                psi_unwrap += d
            psi_prev = psi
            last_mocap = [s[0] + rng.normal(0, pos_noise), s[1] + rng.normal(0, pos_noise),
                          s[2] + rng.normal(0, pos_noise), phi + rng.normal(0, ang_noise),
                          theta + rng.normal(0, ang_noise), psi_unwrap + rng.normal(0, ang_noise)]
        gyro = s[10:13] + rng.normal(0, gyro_noise, 3)
        # rpm: relative noise and 1 rpm quantisation, as an ESC's speed report.
        rpm = np.round(s[13:17] * RPM_PER_RAD_S * (1.0 + rng.normal(0, rpm_noise, 4)))
        rows.append([k * dt_sim, *last_mocap, *gyro, *rpm])
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("t,x,y,z,phi,theta,psi,p,q,r,rpm1,rpm2,rpm3,rpm4\n")
        for row in rows:
            f.write(",".join(f"{x:.9g}" for x in row) + "\n")
    os.replace(tmp, path)


def write_vehicle(path, name, v, kf_factor=1.0):
    pos, spin = rotor_geometry(v)
    kf_rpm = v["kf"] / RPM_PER_RAD_S ** 2 * kf_factor
    I = v["I"]
    text = f"""# Vehicle "{name}" of tests/independent_sim/indep_sim.py (generated).
name = "{name}"

[nominal]
m = {v['m']}
Ixx = {I[0][0]}
Iyy = {I[1][1]}
Izz = {I[2][2]}

[rotors]
input = "rpm"
columns = ["rpm1", "rpm2", "rpm3", "rpm4"]
kf = {kf_rpm:.9e}
torque_ratio = {v['torque_ratio']}
rotor_inertia = {v['J_r']}
positions = [{", ".join(f"[{x:.9g}, {y:.9g}, 0.0]" for x, y in pos)}]
spin = [{", ".join('"ccw"' if s > 0 else '"cw"' for s in spin)}]
"""
    with open(path, "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vehicle", choices=sorted(VEHICLES), required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--aero", action="store_true", help="rotor drag and blade flapping against the air-relative velocity")
    ap.add_argument("--wind", type=float, default=0.0, help="mean wind speed, m/s (with --aero), plus gusts")
    ap.add_argument("--kf-factor", type=float, default=1.0, help="scale the vehicle file's kf (a wrong thrust model)")
    ap.add_argument("--payload", default="", help="T:DM: a point mass of DM kg joins the centre of mass at T s")
    ap.add_argument("--out", required=True, help="folder: log.csv, vehicle.toml, truth.json")
    a = ap.parse_args()
    v = VEHICLES[a.vehicle]
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.out, exist_ok=True)
    scale = {"heavy-x": 1.0, "mid-plus": 0.8, "nano-x": 0.7}[a.vehicle]
    ref = Reference(rng, a.duration, scale)
    payload = tuple(float(x) for x in a.payload.split(":")) if a.payload else None
    sim = Simulator(v, rng, a.aero, a.wind, payload)
    dt = 0.002
    states = sim.run(ref, a.duration, dt)
    write_log(os.path.join(a.out, "log.csv"), states, dt, rng)
    write_vehicle(os.path.join(a.out, "vehicle.toml"), a.vehicle, v, a.kf_factor)
    I = v["I"]
    truth = dict(m=v["m"], Ixx=I[0][0], Iyy=I[1][1], Izz=I[2][2], Ixy=I[0][1], Ixz=I[0][2], Iyz=I[1][2],
                 payload_t=payload[0] if payload else None, payload_dm=payload[1] if payload else None,
                 kf_factor=a.kf_factor, aero=a.aero, wind=a.wind, seed=a.seed,
                 max_tilt_deg=max(math.degrees(math.acos(max(-1, min(1, quat_to_R(s[6:10])[2, 2])))) for s in states[::50]),
                 max_rpm=float(states[:, 13:17].max() * RPM_PER_RAD_S),
                 min_rpm=float(states[:, 13:17].min() * RPM_PER_RAD_S))
    with open(os.path.join(a.out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)


if __name__ == "__main__":
    main()
