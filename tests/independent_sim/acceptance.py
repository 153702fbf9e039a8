#!/usr/bin/python3
"""Acceptance on flights of an independent simulator (indep_sim.py, beside this file).

Flies three vehicles (2 kg X, 0.55 kg +, 32 g X) with rotor speeds as the only
actuation record, noisy motion capture at 100 Hz and a noisy gyro, then runs
`quadid identify --vehicle vehicle.toml log.csv --json` with default options and
checks the figures of issues 9 and 11:

  clean flights     recommended set: m within 0.5 %, Ixx/Iyy/Izz within 2 %,
                    products within 2 % of Ixx; LS and FMLS: m 1 %, moments 5 %,
                    products 5 % of Ixx; 95 % intervals reported for every parameter
  drag and wind     recommended set: moments within 5 %, products within 5 % of Ixx
  kf 25 % wrong,    thrust scale recovers kf within 2 %; recommended set's inertia
  mass known        within 5 %
  band dependence   the warning that Ixx and Iyy depend on the roll and pitch
                    rows' band fires on both flights in wind and gusts (the
                    0.55 kg one is wrong by ~50 % there: no model term holds
                    gusts) and on none of the clean ones

Usage: acceptance.py QUADID_EXE WORKDIR
Exit 0 when every check holds; 1 otherwise, with a table of every figure.
"""
import concurrent.futures
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SIM = os.path.join(HERE, "indep_sim.py")

# (name, simulator arguments, kind)
FLIGHTS = [
    ("heavy-x-1", ["--vehicle", "heavy-x", "--seed", "1"], "clean"),
    ("mid-plus-2", ["--vehicle", "mid-plus", "--seed", "2"], "clean"),
    ("nano-x-3", ["--vehicle", "nano-x", "--seed", "3"], "clean"),
    ("heavy-x-4-wind", ["--vehicle", "heavy-x", "--seed", "4", "--aero", "--wind", "2"], "aero"),
    ("mid-plus-22-wind", ["--vehicle", "mid-plus", "--seed", "22", "--aero", "--wind", "2"], "gusts"),
]
BAND_WARNING = "depend on the band"
KF_FACTOR = 1.25  # the vehicle file's kf is 25 % too high in the known-mass case


def simulate(name, args, workdir):
    out = os.path.join(workdir, name)
    subprocess.run([sys.executable, SIM, *args, "--out", out], check=True)
    return out


def identify(exe, folder, vehicle="vehicle.toml", extra=()):
    cmd = [exe, "identify", "--vehicle", os.path.join(folder, vehicle), os.path.join(folder, "log.csv"), "--json",
           *extra]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
    return json.loads(p.stdout)


def errors(est, truth):
    """Relative errors: m against m, moments against themselves, products against Ixx."""
    e = {"m": (est["m"] - truth["m"]) / truth["m"]}
    for k in ("Ixx", "Iyy", "Izz"):
        e[k] = (est[k] - truth[k]) / truth[k]
    for k in ("Ixy", "Ixz", "Iyz"):
        e[k] = (est[k] - truth[k]) / truth["Ixx"]
    return e


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    exe, workdir = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    os.makedirs(workdir, exist_ok=True)
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as pool:
        folders = list(pool.map(simulate, [f[0] for f in FLIGHTS], [f[1] for f in FLIGHTS],
                                [workdir] * len(FLIGHTS)))
    failures = []
    rows = []

    def check(flight, what, value, limit):
        ok = abs(value) <= limit
        rows.append((flight, what, value, limit, ok))
        if not ok:
            failures.append(f"{flight}: {what} = {100 * value:+.2f} % (limit {100 * limit:.1f} %)")

    for (name, _, kind), folder in zip(FLIGHTS, folders):
        truth = json.load(open(os.path.join(folder, "truth.json")))
        res = identify(exe, folder)
        rec = res["recommended"]["set"]
        warned = any(BAND_WARNING in w for w in res["warnings"])
        if warned != (BAND_WARNING in res["recommended"]["reason"]):
            failures.append(f"{name}: the recommendation's reason and the warnings disagree on the band dependence")
        if warned != (kind != "clean"):
            failures.append(f"{name}: the band-dependence warning {'fired' if warned else 'did not fire'}")
        rows.append((name, "band-dependence warning", float(warned), float(kind != "clean"), warned == (kind != "clean")))
        if kind == "gusts":
            continue  # only the warning is asked of it
        if not rec:
            failures.append(f"{name}: no recommended set ({res['recommended']['reason']})")
            continue
        e = errors(res["estimates"][rec], truth)
        if kind == "clean":
            check(name, f"{rec} m", e["m"], 0.005)
            for k in ("Ixx", "Iyy", "Izz"):
                check(name, f"{rec} {k}", e[k], 0.02)
            for k in ("Ixy", "Ixz", "Iyz"):
                check(name, f"{rec} {k} (of Ixx)", e[k], 0.02)
            for s in ("LS", "FMLS"):
                es = errors(res["estimates"][s], truth)
                check(name, f"{s} m", es["m"], 0.01)
                for k in ("Ixx", "Iyy", "Izz"):
                    check(name, f"{s} {k}", es[k], 0.05)
                for k in ("Ixy", "Ixz", "Iyz"):
                    check(name, f"{s} {k} (of Ixx)", es[k], 0.05)
            for s in ("LS", "FMLS"):
                u = res["uncertainty"][s]
                for k in ("m", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"):
                    lo, hi = u[k]["ci95"]
                    if not (lo < res["estimates"][s][k] < hi):
                        failures.append(f"{name}: {s} {k}: no 95 % interval around the estimate ({lo}, {hi})")
        else:
            for k in ("Ixx", "Iyy", "Izz"):
                check(name, f"{rec} {k}", e[k], 0.05)
            for k in ("Ixy", "Ixz", "Iyz"):
                check(name, f"{rec} {k} (of Ixx)", e[k], 0.05)

    # Known mass, kf 25 % wrong: the mid-plus flight again with a wrong vehicle file.
    folder = folders[1]
    truth = json.load(open(os.path.join(folder, "truth.json")))
    text = open(os.path.join(folder, "vehicle.toml")).read()
    kf = float(re.search(r"^kf = (\S+)$", text, re.M).group(1))
    with open(os.path.join(folder, "vehicle_kf_wrong.toml"), "w") as f:
        f.write(re.sub(r"^kf = \S+$", f"kf = {kf * KF_FACTOR:.9e}", text, flags=re.M))
    res = identify(exe, folder, "vehicle_kf_wrong.toml", ["--known-mass", str(truth["m"])])
    rec = res["recommended"]["set"]
    # PC / FMPC keep the mass and move the inertia only: the thrust scale is their base set's.
    s = res["estimates"][{"PC": "LS", "FMPC": "FMLS"}.get(rec, rec)]["extra"]["thrust_scale"]
    check("mid-plus-2 kf+25%", f"{rec} kf recovered (s x 1.25 - 1)", s * KF_FACTOR - 1.0, 0.02)
    e = errors(res["estimates"][rec], truth)
    for k in ("Ixx", "Iyy", "Izz"):
        check("mid-plus-2 kf+25%", f"{rec} {k}", e[k], 0.05)

    print(f"{'flight':<20} {'figure':<34} {'value':>9} {'limit':>7}")
    for flight, what, value, limit, ok in rows:
        if what == "band-dependence warning":  # value: fired, limit: expected
            print(f"{flight:<20} {what:<34} {'yes' if value else 'no':>9} {'yes' if limit else 'no':>7} "
                  f"{'' if ok else 'FAIL'}")
        else:
            print(f"{flight:<20} {what:<34} {100 * value:+8.3f}% {100 * limit:6.1f}% {'' if ok else 'FAIL'}")
    if failures:
        print("\nFAILED:\n  " + "\n  ".join(failures))
        return 1
    print(f"\nall {len(rows)} checks hold")
    return 0


if __name__ == "__main__":
    sys.exit(main())
