"""quadid: identify a quadrotor's mass and inertia tensor from flight logs.

The functions mirror the command line (docs/python.md):

    quadid.read_log(path)                      -> {column: numpy array}
    quadid.identify(log, **options)            -> the dict of `quadid identify --json`
    quadid.simulate(trajectory, **options)     -> {"log": {column: array}, "summary": ...}
    quadid.design(**options)                   -> the dict of `quadid design --json`
    quadid.check_trajectory(trajectory, **options)
    quadid.validate(log, params, **options)    -> the dict of `quadid validate --json`
    quadid.fleet.identify_many(paths, client=None, **options)

Options are the command line's long names with '-' written '_' (cutoff=4.0,
window="10:50", gd_init="nominal", keep_edges=True, map=["tau_phi=tau_x"]);
--lambda is lambda_=30 (or lam=30). Defaults and checks are the command line's:
one implementation in the C++ library reads both. A bad option raises
ValueError naming it; bad data raises quadid.InputError (a ValueError) with
the library's message (file, line, column).

Vehicle files (docs/vehicles.md, `--vehicle FILE|NAME`): pass vehicle="crazyflie21" or
vehicle="my.toml" to identify (with known_mass=..., terms=..., cutoffs=... as the
command line's --known-mass, --terms, --cutoffs; docs/real-flights.md).
"""

from __future__ import annotations

import os
import warnings as _warnings
from typing import Any, Mapping

from . import _quadid
from ._quadid import InputError, SimulationDiverged, __version__

__all__ = [
    "InputError",
    "SimulationDiverged",
    "__version__",
    "read_log",
    "identify",
    "simulate",
    "design",
    "check_trajectory",
    "validate",
    "option_names",
]

# Python keywords and spellings that cannot be keyword arguments as they are.
_ALIASES = {"lam": "lambda"}


def _options(command: str, options: Mapping[str, Any]) -> dict:
    """Keyword arguments -> the library's option dict (None = the default)."""
    out = {}
    for key, value in options.items():
        if value is None:
            continue
        out[_ALIASES.get(key, key)] = value
    return out


def option_names(command: str) -> list[tuple[str, str, str]]:
    """(name, kind, help) of every option of a command ("identify", "simulate",
    "design", "check-trajectory", "validate"), names as keyword arguments."""
    return [(n.replace("-", "_") + ("_" if n == "lambda" else ""), k, h) for n, k, h in _quadid.option_specs(command)]


def _path(p) -> str:
    return os.fspath(p)


def read_log(path, *, map: list[str] | None = None, period_tolerance: float | None = None,
             time_unit: str = "s") -> dict:
    """A flight log as {column name: 1-D float64 numpy array}, in file order.

    The arrays are read-only views of one column-major matrix (no copy).
    `map` renames columns like --map (["tau_phi=tau_x"]); the standard columns
    (t x y z phi theta psi p q r Fz tau_phi tau_theta tau_psi) are required.
    `period_tolerance`: relative tolerance of each time step against the
    median step, as --period-tolerance (None: the command line's default, 1 %).
    `time_unit`: the unit of column t, as --time-unit ("s", "ms", "us", "ns").
    """
    tol = None if period_tolerance is None else float(period_tolerance)
    return _quadid.read_log(_path(path), list(map or []), tol, str(time_unit))


def identify(log, **options) -> dict:
    """`quadid identify LOG --json` on a path or a mapping {column: array}.

    Returns the same structure (estimates.LS/GD/FMLS/FMGD, prediction_error,
    processing, ...; numbers as floats) plus "evolution": {column: array}, the
    estimates over time (the CSV of --evolution). Warnings (e.g. rank-deficient
    data with allow_rank_deficient=True) are also issued as Python warnings.
    """
    if isinstance(log, (str, os.PathLike)):
        log = _path(log)
    res = _quadid.identify(log, _options("identify", options))
    for w in res.get("warnings") or []:
        _warnings.warn(w, stacklevel=2)
    return res


def simulate(trajectory: str = "table2", *, out=None, truth: bool = False, truth_out=None, **options) -> dict:
    """`quadid simulate --trajectory T [options]`.

    Returns {"log": {column: array}, "truth": {column: array} or None,
    "summary": ..., "options": ..., "trajectory": spec, "comments": [...]}.
    `out` / `truth_out` also write the CSV files (atomically), as -o / --truth.
    """
    opts = _options("simulate", options)
    opts["trajectory"] = _path(trajectory) if isinstance(trajectory, os.PathLike) else trajectory
    return _quadid.simulate(opts, bool(truth), _path(out) if out else "", _path(truth_out) if truth_out else "")


def design(*, out=None, **options) -> dict:
    """`quadid design --json [options]` (wf in deg/s and angle limits in degrees, as on the command line)."""
    return _quadid.design(_options("design", options), _path(out) if out else "")


def check_trajectory(trajectory="table2", **options) -> dict:
    """`quadid check-trajectory TRAJECTORY --json [options]`."""
    return _quadid.check_trajectory(_path(trajectory), _options("check-trajectory", options))


def validate(log, params, **options) -> dict:
    """`quadid validate --log LOG --params P ... --json`; `params` is one spec or a list
    (presets, params JSON, identify result JSON files). Notes go to Python warnings."""
    opts = _options("validate", options)
    if isinstance(params, (str, os.PathLike)):
        params = [params]
    opts["params"] = [_path(p) for p in params]
    def note(msg: str) -> None:
        if not msg.startswith("re-flying"):  # progress, not a warning
            _warnings.warn(msg, stacklevel=4)

    return _quadid.validate(_path(log), opts, note)


from . import fleet  # noqa: E402  (imports identify)
