"""simulate, check_trajectory, design and validate against the command line."""

import numpy as np
import pytest

import quadid
from conftest import DURATION, assert_same, cli_json, run_cli


def test_simulate_equals_the_command_lines_log(tmp_path):
    p = tmp_path / "cli.csv"
    run_cli("simulate", "--trajectory", "circle1", "--duration", "5", "--seed", "7", "-o", str(p))
    sim = quadid.simulate("circle1", duration=5, seed=7, out=tmp_path / "py.csv", truth=True)
    assert (tmp_path / "py.csv").read_bytes() == p.read_bytes()  # same options -> same bytes
    ref = quadid.read_log(p)
    assert list(sim["columns"]) == list(ref)
    for k in ref:
        np.testing.assert_array_equal(sim["columns"][k], ref[k])
    assert sim["truth_columns"] is not None and "u_dot" in sim["truth_columns"]
    with pytest.warns(DeprecationWarning, match=r"simulate\(\)\['log'\] is now \['columns'\]"):
        assert sim["log"] is sim["columns"]
    assert sim["summary"]["samples"] == len(ref["t"])


def test_simulate_divergence_and_bad_options():
    with pytest.raises(ValueError, match="trajectory"):
        quadid.simulate("nowhere")
    with pytest.raises(ValueError, match="noise"):
        quadid.simulate("table2", noise="loud")


def test_check_trajectory_equals_the_command_line():
    # --no-precision: the Python API does not predict the precision (docs/fly-it.md) yet.
    cli = cli_json("check-trajectory", "table2", "--tilt-max-deg", "6", "--no-precision")
    assert_same(quadid.check_trajectory("table2", tilt_max_deg=6, no_precision=True), cli, 1e-12)
    with pytest.warns(DeprecationWarning, match="tilt_max= is now tilt_max_deg="):
        old = quadid.check_trajectory("table2", tilt_max=6, no_precision=True)
    assert_same(old, cli, 1e-12)


def design_cli_args(args: dict) -> list:
    return [x for k, v in args.items() for x in ("--" + k.replace("_", "-"), str(v))]


def drop_times(j):
    """Wall times differ from run to run; everything else must not."""
    if isinstance(j, dict):
        return {k: drop_times(v) for k, v in j.items() if k not in ("seconds", "wall_s")}
    if isinstance(j, list):
        return [drop_times(v) for v in j]
    return j


def test_design_equals_the_command_line():
    # feasible in ~1 s: one 60-evaluation start meets every limit for 39 of seeds 1-40 (seed 1 is the exception)
    args = dict(starts=1, max_evals=60, seed=2, harmonics=3)
    cli = cli_json("design", *design_cli_args(args), "--quiet", "--no-precision")
    assert_same(drop_times(quadid.design(**args, no_precision=True)), drop_times(cli), 1e-9)


def test_design_without_a_feasible_start_raises_as_the_command_line():
    args = dict(starts=1, max_evals=3, seed=3, harmonics=2)  # stops before meeting every limit
    r = run_cli("design", *design_cli_args(args), "--quiet", check=False)
    assert r.returncode == 1 and "no start met every limit" in r.stderr
    with pytest.raises(RuntimeError) as e:
        quadid.design(**args)
    assert str(e.value) == r.stderr.strip().removeprefix("quadid design: error: ")


def test_validate_equals_the_command_line(logs):
    cli = cli_json("validate", "--log", str(logs[0]), "--params", "qball2-virtual", "--no-simulation")
    res = quadid.validate(logs[0], "qball2-virtual", no_simulation=True)
    assert_same(res, cli, 1e-12)
    with pytest.raises(ValueError, match="at least one"):
        quadid.validate(logs[0], [])


def test_vehicle_by_name_in_simulate_and_identify(tmp_path):
    """A built-in vehicle by name: the same rotor-level log as the command line,
    and identify(vehicle=...) equal to `quadid identify --vehicle ... --json`."""
    p = tmp_path / "cli.csv"
    args = ["--trajectory", "table2", "--vehicle", "crazyflie21", "--speedup", "1.5", "--duration", "20", "--seed", "3"]
    run_cli("simulate", *args, "-o", str(p))
    sim = quadid.simulate("table2", vehicle="crazyflie21", speedup=1.5, duration=20, seed=3, out=tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == p.read_bytes()
    assert "rpm.m1" in sim["columns"]
    cli = cli_json("identify", str(p), "--vehicle", "crazyflie21", "--known-mass", "0.0347")
    res = quadid.identify(str(p), vehicle="crazyflie21", known_mass=0.0347)
    for s in ("LS", "FMLS"):
        for k in ("Ixx", "Iyy", "Izz"):
            assert res["estimates"][s][k] == pytest.approx(cli["estimates"][s][k], rel=1e-9)
        assert res["estimates"][s]["extra"]["thrust_scale"] == pytest.approx(
            cli["estimates"][s]["extra"]["thrust_scale"], rel=1e-9)


def test_validate_with_a_vehicle_judges_the_sets_with_their_terms(tmp_path):
    """validate(vehicle=...) equals `quadid validate --vehicle ... --json`, and
    judges identify's sets with their real-flight terms, saying so."""
    p, r = tmp_path / "log.csv", tmp_path / "r.json"
    run_cli("simulate", "--trajectory", "table2", "--vehicle", "crazyflie21", "--duration", "20", "--seed", "5",
            "-o", str(p))
    run_cli("identify", str(p), "--vehicle", "crazyflie21", "--known-mass", "0.0347", "-o", str(r))
    cli = cli_json("validate", "--log", str(p), "--vehicle", "crazyflie21", "--params", str(r))
    with pytest.warns(UserWarning, match="LS: judged with its terms"):
        res = quadid.validate(p, r, vehicle="crazyflie21")
    assert res["prediction_error"]["real_flight_terms"] is True
    assert "thrust_scale" in res["sets"]["LS"]["extra"]
    assert_same(res, cli, 1e-12)


def shared_autopilot_logs(tmp_path):
    """The real ArduPilot log (decompressed into tmp_path) and PX4's sample.ulg
    from ../shared; skipped without them, as the C++ tests do."""
    import gzip
    import os

    shared = os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "data")
    gz = os.path.join(shared, "ardupilot-real", "2023-07-06_10-12-18.bin.gz")
    ulg = os.path.join(shared, "px4-ulog", "sample.ulg")
    if not os.path.exists(gz):
        if os.environ.get("QUADID_REQUIRE_SHARED") == "1":
            pytest.fail(f"{gz} absent, and QUADID_REQUIRE_SHARED=1 says the shared data is here")
        pytest.skip(f"{gz} absent")
    binf = tmp_path / "flight.bin"
    binf.write_bytes(gzip.decompress(open(gz, "rb").read()))
    return binf, ulg


def test_log_info_equals_the_command_line(tmp_path):
    """quadid.log_info on an ArduPilot DataFlash log and a PX4 ULog: the JSON of
    `quadid log-info --json` (the real logs in ../shared; skipped without them,
    as the C++ tests do)."""
    binf, ulg = shared_autopilot_logs(tmp_path)
    for path in (binf, ulg):
        got = quadid.log_info(path)
        want = cli_json("log-info", str(path))
        assert_same(got, want, where=str(path))
    got = quadid.log_info(binf)
    assert got["kind"] == "dataflash"
    assert got["messages"]["IMU"]["instances"] == 3
    assert abs(got["parameters"]["MOT_THST_HOVER"] - 0.19679) < 1e-5  # the independent listing's value
    with pytest.raises(ValueError, match="not an autopilot log"):
        bad = tmp_path / "x.txt"
        bad.write_text("hello")
        quadid.log_info(bad)


def test_import_log_equals_the_command_line(tmp_path):
    """quadid.import_log on a real ArduPilot log and a PX4 ULog: the columns of
    `quadid import -o CSV` (to the CSV's printed precision) and its --json report."""
    import numpy as np

    binf, ulg = shared_autopilot_logs(tmp_path)
    for path in (binf, ulg):
        got = quadid.import_log(path)
        csv = tmp_path / "out.csv"
        want = cli_json("import", str(path), "-o", str(csv))
        assert list(got["columns"]) == want["columns"]
        for key in ("kind", "sources", "truncated", "rate_hz"):
            assert got["report"][key] == want[key], key
        # The command adds its "too slow for identify's default cutoffs" findings after the import's.
        assert want["warnings"][: len(got["report"]["warnings"])] == got["report"]["warnings"]
        lines = [ln for ln in csv.read_text().splitlines() if not ln.startswith("#")]
        header = lines[0].split(",")
        table = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
        for name in ("t", "x", "p", "phi"):
            # The CSV prints enough digits to round-trip float64 (docs/file-formats.md).
            np.testing.assert_allclose(got["columns"][name], table[:, header.index(name)], rtol=1e-12, atol=1e-12,
                                       err_msg=name)
    assert "ends mid-record" in quadid.import_log(binf)["report"]["truncated"]
    with pytest.raises(ValueError, match="not an autopilot log"):
        bad = tmp_path / "x.csv"
        bad.write_text("t,x\n0,1\n")
        quadid.import_log(bad)


def test_import_log_with_a_vehicle_adds_its_rotor_wrench(tmp_path):
    """import_log(path, vehicle=...) on a simulated PX4 ULog: the columns of the
    plain import plus Fz and the torques of the vehicle's rotor model, which are
    the simulator's own wrench to the ULog's float32 precision and the 250 Hz grid."""
    import numpy as np

    ulg = tmp_path / "sim.ulg"
    run_cli("simulate", "--vehicle", "jmavsim-quad", "--trajectory", "table2", "--duration", "10", "--ulog", str(ulg))
    plain = quadid.import_log(ulg)
    got = quadid.import_log(ulg, vehicle="jmavsim-quad")
    for name in plain["columns"]:
        np.testing.assert_array_equal(got["columns"][name], plain["columns"][name], err_msg=name)
    assert {"Fz", "tau_phi", "tau_theta", "tau_psi", "Omega_r"} <= set(got["columns"])
    # Hover thrust of the 0.8 kg jmavsim-quad: m g within 1 % on average (the flight is level on average).
    assert abs(np.mean(got["columns"]["Fz"]) / (0.8 * 9.81) - 1.0) < 0.01
    with pytest.raises(ValueError, match="neither a built-in vehicle"):
        quadid.import_log(ulg, vehicle="no-such-vehicle")
