#!/usr/bin/python3
"""Throughput of a fleet of logs: `quadid batch` (threads) and the Dask path
(quadid.fleet.identify_many on a LocalCluster), on N simulated logs of 50 s at
500 Hz (the default `quadid simulate`, Table 2, default noise, seeds 1..N).

Usage (after `make build python`):
    PYTHONPATH=build/python /usr/bin/python3 bench/fleet_throughput.py [--logs 100] [--workers 2]

Prints logs/s and s/log for each path and checks that both give the same
estimates. Not a test: it takes minutes. Results on the 2-core development
machine (shared with other jobs, load average 12-17, so indicative) are in
docs/fleet.md: quadid batch --threads 2 at 3.3-6.7 logs/s, the Dask
LocalCluster (2 workers x 1 thread) at 2.3-3.7 logs/s.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=100)
    ap.add_argument("--workers", type=int, default=2, help="threads of quadid batch and Dask worker processes")
    ap.add_argument("--quadid", default=str(ROOT / "build" / "quadid"))
    ap.add_argument("--keep", help="folder for the logs (kept; reused if present)")
    a = ap.parse_args()

    folder = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="quadid_fleet_"))
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"flight{i:04d}.csv" for i in range(1, a.logs + 1)]
    t0 = time.perf_counter()
    for i, p in enumerate(paths, 1):
        if not p.exists():
            subprocess.run([a.quadid, "simulate", "--trajectory", "table2", "--seed", str(i), "-o", str(p)],
                           check=True, capture_output=True)
    print(f"{a.logs} logs of 50 s at 500 Hz ({sum(p.stat().st_size for p in paths) / 1e6:.0f} MB) in {folder}"
          f" ({time.perf_counter() - t0:.1f} s to simulate)", flush=True)

    # 1. quadid batch, --threads workers
    t0 = time.perf_counter()
    r = subprocess.run([a.quadid, "batch", "-q", "--threads", str(a.workers), *map(str, paths)],
                       capture_output=True, text=True)
    batch_s = time.perf_counter() - t0
    if r.returncode != 0:
        print(r.stderr, file=sys.stderr)
        return 1
    batch = [json.loads(l) for l in r.stdout.splitlines()]
    print(f"quadid batch --threads {a.workers}: {batch_s:.1f} s, {a.logs / batch_s:.2f} logs/s "
          f"({batch_s / a.logs:.3f} s/log)", flush=True)

    # 2. Dask LocalCluster, --workers processes of one thread
    from dask.distributed import Client, LocalCluster

    import quadid.fleet

    with LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.run(lambda: __import__("quadid"))  # warm the workers: import time is not throughput
        t0 = time.perf_counter()
        dask = quadid.fleet.identify_many(paths, client=client)
        dask_s = time.perf_counter() - t0
    print(f"dask LocalCluster {a.workers} workers x 1 thread: {dask_s:.1f} s, {a.logs / dask_s:.2f} logs/s "
          f"({dask_s / a.logs:.3f} s/log)", flush=True)

    # 3. one log, one thread, for reference
    t0 = time.perf_counter()
    subprocess.run([a.quadid, "identify", str(paths[0]), "--json"], check=True, capture_output=True)
    print(f"quadid identify (one log, one process): {time.perf_counter() - t0:.2f} s")

    bad = [b["path"] for b, d in zip(batch, dask)
           if not (b["ok"] and d["ok"] and b["estimates"] == d["estimates"])]
    print("both paths agree on every estimate" if not bad else f"DISAGREE on {bad}")
    if not a.keep:
        for p in paths:
            p.unlink()
        folder.rmdir()
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
