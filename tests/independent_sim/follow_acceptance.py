#!/usr/bin/python3
"""Online estimation (quadid follow) on flights of the independent simulator
(indep_sim.py, beside this file: its own rigid body, rotors and controller).

Each vehicle (2 kg X, 0.55 kg +, 32 g X) flies 40 s; a point mass of 10 % of
its mass joins at 20 s. `quadid follow --vehicle vehicle.toml log.csv --json`
with default options must report (issue 40):
  one change, detected within 3 s after 20 s and none before;
  the segments' masses within 2 % of the old and new mass.
The rotor speeds are the only actuation record (the wrench comes from the
vehicle file's rotor model), as in acceptance.py.

Usage: follow_acceptance.py QUADID_EXE WORKDIR. Exit 0 when every check holds.
"""
import concurrent.futures
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
T_CHANGE, FRACTION, DURATION = 20.0, 0.10, 40.0
MASS = {"heavy-x": 2.0, "mid-plus": 0.55, "nano-x": 0.032}  # checked against truth.json below


def fly_and_follow(exe, work, vehicle):
    out = os.path.join(work, vehicle)
    dm = FRACTION * MASS[vehicle]
    subprocess.run([sys.executable, os.path.join(HERE, "indep_sim.py"), "--vehicle", vehicle, "--seed", "5",
                    "--duration", str(DURATION), "--payload", f"{T_CHANGE}:{dm}", "--out", out], check=True)
    truth = json.load(open(os.path.join(out, "truth.json")))
    r = subprocess.run([exe, "follow", os.path.join(out, "log.csv"), "--vehicle", os.path.join(out, "vehicle.toml"),
                        "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        return vehicle, truth, None, r.stderr
    return vehicle, truth, json.loads(r.stdout), ""


def main():
    exe, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    ok = True
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        runs = list(pool.map(lambda v: fly_and_follow(exe, work, v), MASS))
    for vehicle, truth, res, err in runs:
        m0, dm = truth["m"], truth["payload_dm"]
        if res is None:
            print(f"{vehicle}: quadid follow failed: {err}")
            ok = False
            continue
        ch = res["changes"]
        seg = res["segments"]
        checks = [
            ("one change", len(ch) == 1),
            ("detected within 3 s after the change", len(ch) >= 1 and T_CHANGE <= ch[0]["t_detected"] <= T_CHANGE + 3.0),
            ("mass before within 2 %", abs(seg[0]["estimate"]["m"] - m0) <= 0.02 * m0),
            ("mass after within 2 %", len(seg) > 1 and abs(seg[-1]["estimate"]["m"] - (m0 + dm)) <= 0.02 * (m0 + dm)),
        ]
        desc = ", ".join(f"{c['t']:.2f} s (detected {c['t_detected']:.2f} s)" for c in ch)
        masses = ", ".join(f"{s['estimate']['m']:.5g}" for s in seg)
        print(f"{vehicle}: m {m0} -> {m0 + dm:.5g} at {T_CHANGE} s; changes: {desc or 'none'}; segment masses {masses}")
        for name, good in checks:
            print(f"  {'PASS' if good else 'FAIL'} {name}")
            ok &= good
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
