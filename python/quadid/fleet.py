"""Many flight logs, one identification each (docs/fleet.md).

    import quadid.fleet
    from dask.distributed import Client, LocalCluster
    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))
    records = quadid.fleet.identify_many(paths, client=client, cutoff=3.0)

Each record is one line of `quadid batch`: {"path", "ok": True, ...the dict of
`quadid identify --json`...} or {"path", "ok": False, "error": "..."} for a
log that failed (bad file, bad data, a worker that died); the others go on.
Records come back in the order of `paths`.

    summary = quadid.fleet.summarize(records)   # the flights compared, as `quadid batch --summary`
    quadid.fleet.report(records, "fleet.html")  # the page to look at, as `quadid batch --report` (docs/report.md)
"""

from __future__ import annotations

import concurrent.futures as _cf
import functools as _functools
import os as _os
from typing import Any as _Any, Iterable as _Iterable

__all__ = ["identify_one", "identify_many", "summarize", "report"]


def identify_one(path, options: dict | None = None, keep_evolution: bool = False) -> dict:
    """One log -> one record; never raises for a bad log (the record says why)."""
    import quadid  # imported here so that a worker process needs only `quadid` on its path

    path = _os.fspath(path)
    try:
        res = quadid.identify(path, **(options or {}))
    except Exception as e:  # noqa: BLE001 - every failure of one log is that log's record
        return {"path": path, "ok": False, "error": str(e)}
    if not keep_evolution:
        res.pop("evolution", None)
    res["path"] = path
    res["ok"] = True
    return res


def _failure(path, e: BaseException) -> dict:
    return {"path": _os.fspath(path), "ok": False, "error": f"{type(e).__name__}: {e}"}


def identify_many(
    paths: _Iterable,
    client: _Any = None,
    *,
    max_workers: int | None = None,
    keep_evolution: bool = False,
    **options,
) -> list[dict]:
    """Identify every log of `paths`; the records in the order of `paths`.

    client: a dask.distributed Client (a LocalCluster or a real scheduler):
        one task per log on its workers. None: local processes
        (concurrent.futures.ProcessPoolExecutor, `max_workers`, default one per core).
    options: those of quadid.identify (cutoff=3.0, window="10:50", ...); they
        are checked here first, so a bad option raises ValueError at once
        instead of failing every log.
    keep_evolution: keep each result's "evolution" arrays (costly to ship back).
    """
    import quadid

    paths = [_os.fspath(p) for p in paths]
    quadid._quadid.check_identify_options(quadid._options("identify", options))
    task = _functools.partial(identify_one, options=options, keep_evolution=keep_evolution)
    if not paths:
        return []
    if client is not None:
        # pure=False: the same path may hold a new flight the next time.
        futures = client.map(task, paths, pure=False)
        out = []
        for p, f in zip(paths, futures):
            try:
                out.append(f.result())
            except Exception as e:  # noqa: BLE001 - a lost worker, a cancelled task
                out.append(_failure(p, e))
        return out
    workers = max_workers or _os.cpu_count() or 1
    with _cf.ProcessPoolExecutor(max_workers=min(workers, len(paths))) as ex:
        futures = [ex.submit(task, p) for p in paths]
        out = []
        for p, f in zip(paths, futures):
            try:
                out.append(f.result())
            except Exception as e:  # noqa: BLE001 - a crashed worker process (BrokenProcessPool)
                out.append(_failure(p, e))
        return out


def summarize(records: _Iterable[dict], set: str = "recommended", level: float = 0.01) -> dict:
    """Compare the flights of `records` (identify_many's, or `quadid batch`'s lines read back).

    The dict `quadid batch --summary FILE` writes: per parameter the mean and
    standard deviation over the flights beside their own standard errors, and
    the flights that depart from the others (leave-one-out t test; `level` is
    the chance of any false flag when all are of one vehicle). set:
    "recommended" (each flight's) or LS, GD, FMLS, FMGD, PC, FMPC. A failed
    record is listed under "skipped". A bad set or level raises ValueError.
    """
    import quadid

    try:
        return quadid._quadid.summarize_fleet(_records_json(records), set, float(level))
    except ValueError as e:  # the library names batch's keys; this function's arguments are set= and level=
        raise ValueError(str(e).replace("summary_set=", "set=").replace("outlier_level=", "level=")) from None


def _plain(o):
    """numpy arrays (the results' arrays of numbers) -> JSON lists, NaN -> null."""
    import numpy as np

    if isinstance(o, np.ndarray):
        return [_plain(x) for x in o.tolist()] if o.ndim else _plain(o.item())
    if isinstance(o, float) and o != o:
        return None
    if isinstance(o, dict):
        return {k: _plain(v) for k, v in o.items()}
    if isinstance(o, list):
        return [_plain(x) for x in o]
    return o


def _records_json(records) -> str:
    """What the comparison and the fleet page read of each record, as JSON."""
    import json

    keys = ("path", "ok", "error", "warnings", "estimates", "uncertainty", "recommended")
    return json.dumps(_plain([{k: r[k] for k in keys if k in r} for r in records]))


def report(records: _Iterable[dict], path, set: str = "recommended", level: float = 0.01) -> str:
    """Write the fleet page of `records` to `path` (HTML, one self-contained file; atomically).

    The page `quadid batch --report DIR` writes as DIR/index.html (docs/report.md,
    "A fleet"): the conclusions, the flights compared (the numbers of
    summarize(records, set, level)), each parameter over the flights with its
    95 % intervals, and every log with its warnings (here without links to
    per-log pages: `quadid identify LOG --report DIR` writes one). Returns the path.
    """
    import quadid

    try:
        html = quadid._quadid.fleet_report(_records_json(list(records)), set, float(level))
    except ValueError as e:
        raise ValueError(str(e).replace("summary_set=", "set=").replace("outlier_level=", "level=")) from None
    path = _os.fspath(path)
    tmp = f"{path}.tmp{_os.getpid()}"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(html)
        _os.replace(tmp, path)
    except BaseException:
        if _os.path.exists(tmp):
            _os.remove(tmp)
        raise
    return path
