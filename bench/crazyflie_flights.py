#!/usr/bin/python3
"""Identify the real Crazyflie 2.1 flights of ../shared/data/crazyflie-usd with
the built-in vehicle and the weighed mass, for several term sets, and print the
per-flight table and the spread across flights (CV). A measurement for the
issue notes, not a test: the flights are not in the repository.

usage: bench/crazyflie_flights.py [QUADID_EXE] [DATA_DIR] [-- extra identify options]
"""
import json, os, subprocess, sys

args = sys.argv[1:]
extra = []
if "--" in args:
    i = args.index("--")
    extra, args = args[i + 1:], args[:i]
exe = args[0] if len(args) > 0 else "build/quadid"
data = args[1] if len(args) > 1 else os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "crazyflie-usd")
flights = sorted(f for f in os.listdir(data) if f.startswith("jana"))
MASS = 0.0347  # kg, weighed (the data set's README)

F48 = ["--cutoffs", "fixed", "--cutoff-force", "4", "--cutoff-moment", "8"]
configs = [
    ("paper model, 4 Hz everywhere", ["--terms", "paper", "--cutoffs", "fixed"] + ["--moment-highpass", "off"]),
    ("paper model, moment rows at 8 Hz", ["--terms", "paper"] + F48 + ["--moment-highpass", "off"]),
    ("+ weighting", ["--terms", "weighting"] + F48 + ["--moment-highpass", "off"]),
    ("+ offsets", ["--terms", "weighting,offsets"] + F48 + ["--moment-highpass", "off"]),
    ("+ flapping", ["--terms", "weighting,offsets,flapping", "--moment-highpass", "off"] + F48),
    ("+ rotor inertia, no high-pass (real terms; 4/8 Hz)", ["--moment-highpass", "off"]),
    ("default (+ roll/pitch high-pass chosen from the data)", []),
    ("default terms, held-out cutoffs", ["--cutoffs", "held-out"]),
]


def cv(xs):
    m = sum(xs) / len(xs)
    if len(xs) < 2 or m == 0:
        return float("nan")
    return (sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) ** 0.5 / abs(m) * 100


for name, opts in configs:
    rows = []
    for f in flights:
        cmd = [exe, "identify", os.path.join(data, f), "--vehicle", "crazyflie21", "--known-mass", str(MASS),
               "--ignore-input-errors", "--json"] + opts + extra
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            print(f"{name}: {f}: failed: {p.stderr.strip()[:300]}")
            continue
        j = json.loads(p.stdout)
        rec = j.get("recommended", {}).get("set") or "LS"
        e = j["estimates"][rec]
        # PC / FMPC keep the mass and move only the inertia: the thrust scale is their base set's.
        base_set = {"PC": "LS", "FMPC": "FMLS"}.get(rec, rec)
        s = j["estimates"][base_set].get("extra", {}).get("thrust_scale", float("nan"))
        I = [e["Ixx"], e["Iyy"], e["Izz"]]
        rf = j.get("real_flight", {})
        cut = rf.get("cutoff_selection", {})
        cons = j.get("consistency", {}).get(rec, {}).get("physical")
        base = {"PC": "LS", "FMPC": "FMLS"}.get(rec, rec)
        unc = j.get("uncertainty", {}).get(base, {})
        ci = [unc.get(k, {}).get("ci95", [float("nan")] * 2) for k in ("Ixx", "Iyy", "Izz")]
        poor = set(j.get("least_squares", {}).get(base, {}).get("poorly_determined", []))
        rows.append((f, s, I, cut.get("force_cutoff_hz"), cut.get("moment_cutoff_hz"), cons, rec, ci, poor))
    print(f"\n== {name}")
    print(f"{'flight':8} {'set':5} {'s':>7} {'Ixx':>8} {'Iyy':>8} {'Izz':>8}  (1e-6 kg m^2)  cutoffs F/M Hz  physical  poorly determined")
    for f, s, I, cf, cm, cons, rec, ci, poor in rows:
        print(f"{f:8} {rec:5} {s:7.4f} {I[0]*1e6:8.2f} {I[1]*1e6:8.2f} {I[2]*1e6:8.2f}  {str(cf):>6}/{str(cm):<6} "
              f"{str(cons):8}  {','.join(sorted(poor)) or '-'}")
    if len(rows) > 1:
        print(f"{'CV %':14} {cv([r[1] for r in rows]):7.2f} {cv([r[2][0] for r in rows]):8.1f} "
              f"{cv([r[2][1] for r in rows]):8.1f} {cv([r[2][2] for r in rows]):8.1f}")
        wd = []
        for k, n in enumerate(("Ixx", "Iyy", "Izz")):
            xs = [r[2][k] for r in rows if n not in r[8]]
            wd.append(f"{n} {cv(xs):.1f} % (n = {len(xs)})" if len(xs) > 1 else f"{n} - (n = {len(xs)})")
        print("CV over the flights where the moment is well determined: " + ", ".join(wd))
        # Issue 11: the median of the other flights inside this flight's 95 %
        # interval (or within 10 %), per moment.
        hits, total = 0, 0
        for i, r in enumerate(rows):
            for k in range(3):
                others = sorted(o[2][k] for j, o in enumerate(rows) if j != i)
                med = others[len(others) // 2] if len(others) % 2 else 0.5 * (others[len(others) // 2 - 1] + others[len(others) // 2])
                lo, hi = r[7][k]
                ok = (lo <= med <= hi) or abs(med - r[2][k]) <= 0.1 * abs(r[2][k])
                hits += ok
                total += 1
        print(f"median of the other flights inside the 95 % interval or within 10 %: {hits}/{total} "
              f"({100.0 * hits / total:.0f} %)")
