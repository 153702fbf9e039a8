"""quadid: identify a quadrotor's mass and inertia tensor from flight logs.

The functions mirror the command line (docs/python.md):

    quadid.read_log(log)                       -> {column: numpy array}
    quadid.identify(log, **options)            -> IdentifyResult: the dict of `quadid identify --json`
    quadid.simulate(trajectory, **options)     -> {"columns": {column: array}, "summary": ...}
    quadid.design(**options)                   -> the dict of `quadid design --json`
    quadid.check_trajectory(trajectory, **options)
    quadid.validate(log, params, **options)    -> the dict of `quadid validate --json`
    quadid.fleet.identify_many(paths, client=None, **options)

A flight log is the argument `log` everywhere: a path, or (identify) a mapping
{column: array}. Options are the command line's long names with '-' written
'_' (cutoff=4.0, window="10:50" or window=(10, 50); default the whole log, gd_init="nominal",
keep_edges=True, map=["tau_phi=tau_x"]); --lambda is lambda_=30 (or lam=30).
They, their defaults and checks come from the library's one option table
(option_names lists them); an old spelling (nominal=, tilt_max=, ...) still
works with a DeprecationWarning. A bad option raises ValueError naming it; bad
data raises quadid.InputError (a ValueError) with the library's message (file,
line, column). Numbers in arrays come back as numpy arrays (float64, NaN where
the JSON has null).

Vehicle files (docs/vehicles.md, `--vehicle FILE|NAME`): pass vehicle="crazyflie21" or
vehicle="my.toml" to identify (with known_mass=..., terms=..., cutoffs=... as the
command line's --known-mass, --terms, --cutoffs; docs/real-flights.md).
"""

from __future__ import annotations

import os as _os
import warnings as _warnings
from typing import Any as _Any, Mapping as _Mapping

import numpy as _np

from . import _quadid
from ._quadid import InputError, SimulationDiverged, __version__

__all__ = [
    "InputError",
    "SimulationDiverged",
    "__version__",
    "IdentifyResult",
    "OnlineEstimator",
    "follow",
    "read_log",
    "import_log",
    "identify",
    "simulate",
    "design",
    "check_trajectory",
    "validate",
    "log_info",
    "model",
    "option_names",
    "option_specs",
]

# Python keywords and spellings that cannot be keyword arguments as they are.
_ALIASES = {"lam": "lambda"}


def _command(command: str) -> str:
    return command.replace("_", "-")


def option_specs(command: str) -> list[dict]:
    """The option table of a command ("identify", "simulate", "design", "check_trajectory",
    "validate", ...): one dict per option with name (the command line's), keyword (the
    keyword argument), kind, help, default, default_text, unit, choices, aliases, range
    and cli_only (True: the command line's only, e.g. -o, --json)."""
    out = []
    for d in _quadid.option_specs(_command(command)):
        d = dict(d)
        d["keyword"] = d["name"].replace("-", "_") + ("_" if d["name"] == "lambda" else "")
        out.append(d)
    return out


def option_names(command: str) -> list[tuple[str, str, str]]:
    """(keyword, kind, help) of every option the keyword arguments of a command accept."""
    return [(d["keyword"], d["kind"], d["help"]) for d in option_specs(command) if not d["cli_only"]]


def _options(command: str, options: _Mapping[str, _Any]) -> dict:
    """Keyword arguments -> the library's option dict (None = the default); an old
    spelling is renamed with a DeprecationWarning."""
    aliases = {}
    for d in _quadid.option_specs(_command(command)):
        for a in d["aliases"]:
            aliases[a] = d["name"]
    out = {}
    for key, value in options.items():
        if value is None:
            continue
        key = _ALIASES.get(key, key)
        norm = _quadid.normalize_option_key(key)
        if norm in aliases:
            new = aliases[norm].replace("-", "_")
            _warnings.warn(f"{key}= is now {new}=; the old spelling still works", DeprecationWarning, stacklevel=3)
            key = aliases[norm]
        out[key] = value
    return out


def _path(p) -> str:
    return _os.fspath(p)


def _log_argument(log, kwargs: dict, function: str):
    """The flight log argument `log`; `path=` is its old name (DeprecationWarning)."""
    if "path" in kwargs:
        old = kwargs.pop("path")
        _warnings.warn(f"{function}(path=...) is now {function}(log=...); the old name still works",
                       DeprecationWarning, stacklevel=3)
        if log is not None:
            raise TypeError(f"{function}: give log= or path=, not both")
        log = old
    if log is None:
        raise TypeError(f"{function}: missing the flight log (log=)")
    return log


class IdentifyResult(dict):
    """The dict of `quadid identify --json`, plus numpy accessors of each set's estimate.

    theta_order: the order of theta (m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz).
    theta(set) -> (7,) array, inertia_tensor(set) -> (3, 3), covariance(set) -> (7, 7)
    (symmetric; its diagonal is the squared standard errors), for the sets of
    least_squares ("LS", "FMLS", ...).
    """

    def _ls(self, set: str) -> dict:
        ls = self.get("least_squares") or {}
        if set not in ls:
            raise KeyError(f"no least-squares set {set!r} (have: {', '.join(ls)})")
        return ls[set]

    def theta_order(self, set: str = "LS") -> list[str]:
        return list(self._ls(set)["theta_order"])

    def theta(self, set: str = "LS") -> _np.ndarray:
        return _np.asarray(self._ls(set)["theta"], dtype=float)

    def inertia_tensor(self, set: str = "LS") -> _np.ndarray:
        return _np.asarray(self._ls(set)["inertia_tensor"], dtype=float).reshape(3, 3)

    def covariance(self, set: str = "LS") -> _np.ndarray:
        return _np.asarray(self._ls(set)["covariance"], dtype=float).reshape(7, 7)


class _SimulateResult(dict):
    """simulate()'s dict; "log" and "truth" are the old names of "columns" and "truth_columns"."""

    _OLD = {"log": "columns", "truth": "truth_columns"}

    def __getitem__(self, key):
        if key in self._OLD:
            _warnings.warn(f"simulate()[{key!r}] is now [{self._OLD[key]!r}]; the old key still works",
                           DeprecationWarning, stacklevel=2)
            key = self._OLD[key]
        return dict.__getitem__(self, key)


def read_log(log=None, *, map: list[str] | None = None, period_tolerance: float | None = None,
             time_unit: str = "s", **kwargs) -> dict:
    """A flight log file as {column name: 1-D float64 numpy array}, in file order.

    The arrays are read-only views of one column-major matrix (no copy).
    `map` renames columns like --map (["tau_phi=tau_x"]); the standard columns
    (t x y z phi theta psi p q r Fz tau_phi tau_theta tau_psi) are required.
    `period_tolerance`: relative tolerance of each time step against the
    median step, as --period-tolerance (None: the command line's default, 1 %).
    `time_unit`: the unit of column t, as --time-unit ("s", "ms", "us", "ns").
    """
    log = _log_argument(log, kwargs, "read_log")
    if kwargs:
        raise TypeError(f"read_log: unexpected keyword arguments {', '.join(kwargs)}")
    tol = None if period_tolerance is None else float(period_tolerance)
    return _quadid.read_log(_path(log), list(map or []), tol, str(time_unit))


def identify(log=None, **options) -> IdentifyResult:
    """`quadid identify LOG --json` on a path or a mapping {column: array}.

    Returns the same structure (estimates.LS/GD/FMLS/FMGD, prediction_error,
    processing, ...; numbers as floats, arrays of numbers as numpy arrays) plus
    "evolution": {column: array}, the estimates over time (the CSV of
    --evolution), as an IdentifyResult (result.covariance("LS") etc.).
    Warnings (e.g. rank-deficient data with allow_rank_deficient=True) are also
    issued as Python warnings.
    """
    log = _log_argument(log, options, "identify")
    if isinstance(log, (str, _os.PathLike)):
        log = _path(log)
    res = IdentifyResult(_quadid.identify(log, _options("identify", options)))
    for w in res.get("warnings") or []:
        _warnings.warn(w, stacklevel=2)
    return res


def simulate(trajectory: str = "table2", *, out=None, truth: bool = False, truth_out=None, **options) -> dict:
    """`quadid simulate --trajectory T [options]`.

    Returns {"columns": {column: array}, "truth_columns": {column: array} or None,
    "summary": ..., "options": ..., "trajectory": spec, "comments": [...]}.
    `out` / `truth_out` also write the CSV files (atomically), as -o / --truth.
    """
    opts = _options("simulate", options)
    opts["trajectory"] = _path(trajectory) if isinstance(trajectory, _os.PathLike) else trajectory
    d = _quadid.simulate(opts, bool(truth), _path(out) if out else "", _path(truth_out) if truth_out else "")
    d["columns"] = d.pop("log")
    d["truth_columns"] = d.pop("truth")
    return _SimulateResult(d)


def design(*, out=None, **options) -> dict:
    """`quadid design --json [options]` (wf_deg in deg/s and the angle limits in degrees, as the names say).

    With the predicted precision of the result unless no_precision=True, as the command line.
    """
    return _quadid.design(_options("design", options), _path(out) if out else "")


def check_trajectory(trajectory="table2", **options) -> dict:
    """`quadid check-trajectory TRAJECTORY --json [options]` (no_precision=True: without the
    predicted precision)."""
    return _quadid.check_trajectory(_path(trajectory), _options("check-trajectory", options))


def import_log(log=None, *, rate: float = 250.0, vehicle=None, **kwargs) -> dict:
    """`quadid import LOG` as arrays: {"columns": {name: 1-D float64 numpy array},
    "report": the import report of `quadid import --json` (kind, sources,
    warnings, truncated, gaps, ...)}.

    LOG is a PX4 ULog, a Crazyflie uSD log or an ArduPilot DataFlash .bin; the
    columns are t x y z phi theta psi p q r (SI, z up, body FLU), ax_b ay_b az_b
    when the log has an accelerometer, and the rotor signals under the log's
    names, on one grid of `rate` Hz. With `vehicle` (a built-in name or a vehicle
    file), also the wrench its rotor model gives: Fz tau_phi tau_theta tau_psi
    and Omega_r, as identify computes them. A file cut mid-record is read to
    its last complete record (report["truncated"]).
    """
    log = _log_argument(log, kwargs, "import_log")
    if kwargs:
        raise TypeError(f"import_log: unexpected keyword arguments {', '.join(kwargs)}")
    return _quadid.import_log(_path(log), float(rate), _path(vehicle) if vehicle else "")


def log_info(log=None, *, allow_truncated: bool = False, **kwargs) -> dict:
    """`quadid log-info LOG --json` as Python objects: what an autopilot log holds.

    LOG is a PX4 ULog, a Crazyflie uSD log or an ArduPilot DataFlash .bin (the
    kind from the file's first bytes). The result is the command's JSON
    ("kind": "ulog", "usd" or "dataflash"; for DataFlash "messages" with each
    type's count, instances, rate and columns with units, and "parameters"
    with each one's last value); arrays of numbers as numpy arrays.
    `allow_truncated`: a ULog cut mid-message keeps the messages before it.
    """
    log = _log_argument(log, kwargs, "log_info")
    if kwargs:
        raise TypeError(f"log_info: unexpected keyword arguments {', '.join(kwargs)}")
    return _quadid.log_info(_path(log), bool(allow_truncated))


def validate(log=None, params=None, **options) -> dict:
    """`quadid validate LOG --params P ... --json`; `params` is one spec or a list
    (presets, params JSON, identify result JSON files). Notes go to Python warnings."""
    log = _log_argument(log, options, "validate")
    opts = _options("validate", options)
    if params is None:
        params = []
    if isinstance(params, (str, _os.PathLike)):
        params = [params]
    opts["params"] = [_path(p) for p in params]

    def note(msg: str) -> None:
        if not msg.startswith("re-flying"):  # progress, not a warning
            _warnings.warn(msg, stacklevel=4)

    return _quadid.validate(_path(log), opts, note)


from . import fleet  # noqa: E402  (imports identify)


def model(result, format: str, *, set: str | None = None, sih_scale: float = 1.0, mjcf_motor_lag: bool = False,
          flavour: str | None = None, gazebo: str = "gz") -> str:
    """`quadid model RESULT --format FORMAT` as text: the identified vehicle for a simulator.

    RESULT is identify's result, a path to its JSON (`quadid identify LOG -o RESULT.json`)
    or the dict `quadid.identify(...)` returns. FORMAT: "vehicle" (a quadid vehicle
    file), "mjcf" (MuJoCo), "rotorpy" (a RotorPy quad_params dict), "urdf".
    `set`: the parameter set to write (default: the result's recommended one).
    `sih_scale`: px4-sih only, every mass, inertia, thrust, torque, drag and damping
    parameter times this factor (a UserWarning names the one a small vehicle needs).
    `mjcf_motor_lag`: mjcf, filter actuators with the motors' time constant.
    `flavour`: urdf, None or "gym-pybullet-drones". `gazebo`: sdf, "gz" or "classic".
    The same options as the command line's (--sih-scale, --mjcf-motor-lag, --flavour,
    --gazebo). See docs/models.md for each target's frames, units and signs.
    """
    if not isinstance(result, dict):
        result = _path(result)
    if flavour not in (None, "none", "gym-pybullet-drones"):
        raise ValueError(f"flavour={flavour!r}: expected None or 'gym-pybullet-drones'")
    if gazebo not in ("gz", "classic"):
        raise ValueError(f"gazebo={gazebo!r}: expected 'gz' or 'classic'")
    if format == "sdf" and gazebo == "classic":
        format = "sdf-classic"
    return _quadid.model(result, str(format), "" if set is None else str(set), float(sih_scale), bool(mjcf_motor_lag),
                         "" if flavour in (None, "none") else str(flavour))


class OnlineEstimator:
    """Online estimation (`quadid follow`, docs/follow.md): feed one sample at a
    time, read the estimate whenever you like.

    Options are follow's keyword arguments (memory=10, warmup=3, block=0.5,
    cusum_drift=3, cusum_threshold=12, no_changes=False, cutoff=4, terms=...,
    known_mass=...). update(row) takes a dict {t, x, y, z, phi, theta, psi, p,
    q, r, Fz, tau_phi, tau_theta, tau_psi} (SI, the flight-log columns) or 14
    numbers in that order, and returns True when it detected a change.
    estimate() is the current segment's (nothing forgotten), tracking() the
    forgetting one; result() is `quadid follow --json`'s structure.
    """

    def __init__(self, **options):
        self._e = _quadid.OnlineEstimator(_options("follow", options))

    def update(self, row) -> bool:
        return self._e.update(row)

    def estimate(self) -> dict:
        return self._e.estimate()

    def tracking(self) -> dict:
        return self._e.tracking()

    def result(self) -> dict:
        return self._e.result()

    @property
    def changed(self) -> bool:
        return self._e.changed


def follow(log, **options) -> dict:
    """`quadid follow LOG --json` on a path: {"changes", "segments", "track", ...}."""
    return _quadid.follow(_path(log), _options("follow", options))
