"""Shared fixtures: the built program (QUADID_EXE, default build/quadid) and
simulated flight logs written by it in a temporary folder."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXE = os.environ.get("QUADID_EXE", str(ROOT / "build" / "quadid"))

# A short flight keeps the suite fast: 20 s of Table 2 at 500 Hz, estimated over
# 2-18 s (the default 10:50 window needs a 50 s log).
DURATION = "20"
WINDOW = "2:18"


def run_cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run([EXE, *args], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"quadid {' '.join(args)} failed ({r.returncode}): {r.stderr}")
    return r


def cli_json(*args: str) -> dict:
    return json.loads(run_cli(*args, "--json").stdout)


@pytest.fixture(scope="session")
def logs(tmp_path_factory) -> list[Path]:
    """Three simulated logs (different noise seeds) written by `quadid simulate`."""
    d = tmp_path_factory.mktemp("logs")
    out = []
    for seed in (1, 2, 3):
        p = d / f"flight{seed}.csv"
        run_cli("simulate", "--trajectory", "table2", "--duration", DURATION, "--seed", str(seed), "-o", str(p))
        out.append(p)
    return out


def assert_same(a, b, rel=1e-9, where="result"):
    """Recursive equality with a relative tolerance on floats (a numpy array of the
    Python module against the JSON's list, null = NaN)."""
    import numpy as np

    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        x = np.asarray(a if isinstance(a, np.ndarray) else [np.nan if v is None else v for v in np.ravel(a).tolist()]
                       if not isinstance(a, list) or not a or not isinstance(a[0], list) else
                       [[np.nan if v is None else v for v in row] for row in a], dtype=float)
        y = np.asarray(b if isinstance(b, np.ndarray) else
                       [[np.nan if v is None else v for v in row] for row in b] if b and isinstance(b[0], list) else
                       [np.nan if v is None else v for v in b], dtype=float)
        assert x.shape == y.shape, f"{where}: shapes {x.shape} != {y.shape}"
        np.testing.assert_allclose(x, y, rtol=rel, atol=0.0, equal_nan=True, err_msg=where)
        return
    if isinstance(a, dict) and isinstance(b, dict):
        assert sorted(a) == sorted(b), f"{where}: keys {sorted(a)} != {sorted(b)}"
        for k in a:
            assert_same(a[k], b[k], rel, f"{where}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b), f"{where}: lengths {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, rel, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, (int, float)) and isinstance(b, (int, float)), f"{where}: {a!r} vs {b!r}"
        assert a == pytest.approx(b, rel=rel, abs=0.0), f"{where}: {a!r} != {b!r}"
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def load_csv(path) -> dict:
    """An independent CSV reader (plain Python float()): {column: array}, '#' lines skipped."""
    import numpy as np

    lines = [l for l in Path(path).read_text().splitlines() if l and not l.startswith("#")]
    names = lines[0].split(",")
    data = np.array([[float(x) for x in l.split(",")] for l in lines[1:]])
    return {n: data[:, i] for i, n in enumerate(names)}
