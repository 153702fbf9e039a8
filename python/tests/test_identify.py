"""quadid.read_log and quadid.identify against the command line (`quadid identify --json`)."""

import json

import numpy as np
import pytest

import quadid
from conftest import WINDOW, assert_same, cli_json, load_csv, run_cli

STANDARD = "t x y z phi theta psi p q r Fz tau_phi tau_theta tau_psi".split()

# Same doubles in, same code path: the results agree to rounding. 1e-9 relative is
# the bar; in practice they are equal bit for bit (CSV numbers round-trip).
REL = 1e-9


def without(d, *keys):
    return {k: v for k, v in d.items() if k not in keys}


def test_read_log_returns_numpy_views_equal_to_the_file(logs):
    log = quadid.read_log(logs[0])
    assert list(log)[: len(STANDARD)] == STANDARD  # file order
    ref = load_csv(logs[0])  # an independent reader of the same file
    assert list(log) == list(ref)
    for name, col in log.items():
        assert isinstance(col, np.ndarray) and col.dtype == np.float64 and col.ndim == 1
        assert col.shape == ref[name].shape
        np.testing.assert_array_equal(col, ref[name])
        assert not col.flags.writeable  # views of the library's matrix, not copies
    owners = {id(col.base) for col in log.values()}
    assert len(owners) == 1 and log["t"].base is not None  # one owner keeps the one matrix alive


def test_identify_on_arrays_equals_the_command_line(logs):
    cli = cli_json("identify", str(logs[0]), "--window", WINDOW)
    arrays = {k: np.array(v) for k, v in quadid.read_log(logs[0]).items()}  # plain, writable arrays
    res = quadid.identify(arrays, window=WINDOW)
    assert res["log"] is None  # a mapping has no file name
    assert_same(without(res, "evolution", "log"), without(cli, "log"), REL)
    assert set(res["estimates"]) == {"LS", "GD", "FMLS", "FMGD", "PC", "FMPC"}
    assert all(isinstance(v, float) for v in res["estimates"]["LS"].values())


def test_short_log_without_window_fits_it_as_the_command_line(logs):
    # These simulated logs of the paper's setup are shorter than its 50 s:
    # without a window, path and command line both take 10 s to the end,
    # with the same warning.
    cli = cli_json("identify", str(logs[0]))
    with pytest.warns(UserWarning, match="^window: "):
        from_path = quadid.identify(logs[0])
    assert any(w.startswith("window: ") for w in from_path["warnings"]), from_path["warnings"]
    assert from_path["window"]["t0"] == 10
    assert_same(without(from_path, "evolution"), cli, REL)


def write_columns(path, columns):
    """A flight-log CSV of {name: array}, header first, no comments."""
    with open(path, "w") as f:
        f.write(",".join(columns) + "\n")
        for row in zip(*columns.values()):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    return path


def test_arrays_without_window_take_the_whole_log_as_a_csv_without_metadata(logs, tmp_path):
    # Arrays carry no '# quadid-simulate' header, so they are any log: the
    # whole log by default, as the command line gives a CSV without one.
    arrays = {k: np.array(v) for k, v in quadid.read_log(logs[0]).items()}
    res = quadid.identify(arrays)
    path = write_columns(tmp_path / "plain.csv", arrays)
    cli = cli_json("identify", str(path))
    assert res["window"]["t0"] < 1.0, res["window"]
    assert_same(without(res, "evolution", "log"), without(cli, "log"), REL)


def test_ground_at_the_start_is_left_out_of_arrays_as_of_the_file(logs, tmp_path):
    # 12 s on the ground (motors idle at 15 % of the hover thrust, z still)
    # before a 20 s flight: the default window (the whole log) is cut to 1 s
    # after take-off for arrays, path and command line alike.
    log = {k: np.array(v) for k, v in quadid.read_log(logs[0]).items()}
    T = log["t"][1] - log["t"][0]
    n = int(round(12.0 / T))
    ground = {k: np.full(n, v[0]) for k, v in log.items()}
    for k in ("phi", "theta", "p", "q", "r", "tau_phi", "tau_theta", "tau_psi"):
        ground[k][:] = 0.0
    ground["Fz"][:] = 0.15 * log["Fz"].mean()
    armed = {k: np.concatenate([ground[k], log[k]]) for k in log}
    armed["t"] = np.arange(len(armed["t"])) * T
    path = write_columns(tmp_path / "armed.csv", armed)
    cli = cli_json("identify", str(path))
    assert abs(cli["window"]["t0"] - 13.0) < 0.3, cli["window"]
    assert any("on the ground" in w for w in cli["warnings"]), cli["warnings"]
    with pytest.warns(UserWarning, match="on the ground"):
        res = quadid.identify(armed)
    assert_same(without(res, "evolution", "log"), without(cli, "log"), REL)


def test_identify_on_a_path_equals_the_command_line_with_options(logs):
    args = ["--window", WINDOW, "--cutoff", "3", "--lambda", "20", "--order", "2", "--sigma", "10"]
    cli = cli_json("identify", str(logs[1]), *args)
    res = quadid.identify(logs[1], window=WINDOW, cutoff=3.0, lambda_=20, order=2, sigma=10)
    assert_same(without(res, "evolution"), cli, REL)
    # lam is the other spelling of --lambda.
    res2 = quadid.identify(str(logs[1]), window=WINDOW, cutoff=3.0, lam=20, order=2, sigma=10)
    assert_same(without(res2, "evolution"), cli, 0.0)


def test_dicts_keep_the_order_written_parameters_in_theta_order(logs):
    # Not alphabetical (Ixx Ixy ... m): a parameter set reads m Ixx Ixy Ixz Iyy Iyz Izz,
    # as Theta and the printed tables do, and the JSON text has the same order.
    res = quadid.identify(logs[1], window=WINDOW)
    theta = ["m", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"]
    for s in ("LS", "FMLS"):
        assert list(res["estimates"][s]) == theta
    assert list(res)[0] == "estimates"
    cli = json.loads(run_cli("identify", str(logs[1]), "--window", WINDOW, "--json").stdout)
    assert list(cli["estimates"]["LS"]) == theta


def test_evolution_is_the_csv_of_the_command_line(logs, tmp_path):
    evo_csv = tmp_path / "evo.csv"
    run_cli("identify", str(logs[0]), "--window", WINDOW, "--evolution", str(evo_csv))
    ref = load_csv(evo_csv)
    evo = quadid.identify(logs[0], window=WINDOW)["evolution"]
    assert list(evo) == list(ref)
    for name, col in evo.items():
        assert isinstance(col, np.ndarray) and col.shape == ref[name].shape
        np.testing.assert_allclose(col, ref[name], rtol=1e-15, atol=0, equal_nan=True)


def test_bad_data_raises_input_error_with_the_command_lines_message(logs, tmp_path):
    bad = tmp_path / "bad.csv"
    lines = logs[0].read_text().splitlines()
    i = next(k for k, l in enumerate(lines) if l and not l.startswith("#")) + 5
    fields = lines[i].split(",")
    fields[3] = "oops"
    lines[i] = ",".join(fields)
    bad.write_text("\n".join(lines) + "\n")
    r = run_cli("identify", str(bad), check=False)
    assert r.returncode == 1
    msg = r.stderr.strip().removeprefix("quadid identify: error: ")
    with pytest.raises(quadid.InputError) as e:
        quadid.identify(bad)
    assert str(e.value) == msg
    assert isinstance(e.value, ValueError)
    with pytest.raises(quadid.InputError, match="bad.csv"):
        quadid.read_log(bad)


def test_period_tolerance_defaults_to_the_command_lines(logs, tmp_path):
    # A clock jittering by +-0.2 % of the period: inside the command line's
    # default 1 %, so read_log, identify on the path and the CLI all accept it;
    # a tolerance of 0.1 % given explicitly refuses it, naming the line.
    lines = open(logs[0]).read().splitlines(keepends=True)
    first = next(i for i, l in enumerate(lines) if not l.startswith("#")) + 1  # the first data row
    out = lines[:first]
    for k, l in enumerate(lines[first:]):
        t, rest = l.split(",", 1)
        jitter = 0.0 if k == 0 else (0.002 if k % 2 else -0.002) * 0.002
        out.append(repr(float(t) + jitter) + "," + rest)
    p = tmp_path / "jitter.csv"
    p.write_text("".join(out))
    assert len(quadid.read_log(p)["t"]) == len(lines) - first
    cli = cli_json("identify", str(p), "--window", WINDOW)
    assert_same(without(quadid.identify(str(p), window=WINDOW), "evolution"), cli, REL)
    with pytest.raises(quadid.InputError, match=r"jitter.csv:\d+: column 't'"):
        quadid.read_log(p, period_tolerance=1e-3)


def test_time_in_milliseconds_is_read_with_its_unit(logs, tmp_path):
    # t written in ms: refused as seconds (naming the unit), read with time_unit="ms",
    # and identify with time_unit="ms" gives the command line's result on the file in seconds.
    lines = open(logs[0]).read().splitlines(keepends=True)
    first = next(i for i, l in enumerate(lines) if not l.startswith("#")) + 1
    out = lines[:first]
    for l in lines[first:]:
        t, rest = l.split(",", 1)
        out.append(repr(float(t) * 1000.0) + "," + rest)
    p = tmp_path / "ms.csv"
    p.write_text("".join(out))
    with pytest.raises(quadid.InputError, match="looks like it is in ms"):
        quadid.read_log(p)
    t = quadid.read_log(p, time_unit="ms")["t"]
    np.testing.assert_allclose(t, quadid.read_log(logs[0])["t"], rtol=1e-15, atol=1e-18)
    cli = cli_json("identify", str(logs[0]), "--window", WINDOW)
    res = quadid.identify(str(p), window=WINDOW, time_unit="ms")
    assert_same(without(res, "evolution", "log"), without(cli, "log"), 1e-6)
    with pytest.raises(ValueError, match="time_unit=hours"):
        quadid.read_log(p, time_unit="hours")


def test_a_missing_column_or_short_log_in_a_mapping_raises_input_error(logs):
    log = dict(quadid.read_log(logs[0]))
    del log["tau_psi"]
    with pytest.raises(quadid.InputError, match="tau_psi"):
        quadid.identify(log, window=WINDOW)
    short = {k: v[:2] for k, v in quadid.read_log(logs[0]).items()}
    with pytest.raises(quadid.InputError, match="sample"):
        quadid.identify(short)


def test_bad_options_raise_value_error_naming_the_option(logs):
    with pytest.raises(ValueError, match="unknown option 'cutof'"):
        quadid.identify(logs[0], cutof=3)
    with pytest.raises(ValueError, match=r"option 'order': expected an integer"):
        quadid.identify(logs[0], order=2.5)
    with pytest.raises(ValueError, match="window"):
        quadid.identify(logs[0], window="50:10")
    with pytest.raises(ValueError, match="gd_discretization"):
        quadid.identify(logs[0], gd_discretization="fast")
    with pytest.raises(quadid.InputError, match="nope.json"):
        quadid.identify(logs[0], reference="nope.json")
    with pytest.raises(ValueError, match=r"option 'order': 9 is out of range"):
        quadid.identify(logs[0], order=9)


def test_option_names_are_the_command_lines(logs):
    help_text = run_cli("identify", "--help").stdout
    for name, kind, _ in quadid.option_names("identify"):
        flag = "--" + name.rstrip("_").replace("_", "-")
        assert flag in help_text, flag
    # One table: every command's keyword arguments are its options that are not the command line's only.
    for command in ("identify", "simulate", "design", "check_trajectory", "validate"):
        specs = quadid.option_specs(command)
        help_text = run_cli(command.replace("_", "-"), "--help").stdout
        for d in specs:
            assert "--" + d["name"] in help_text, (command, d["name"])
        assert {n for n, _, _ in quadid.option_names(command)} == {d["keyword"] for d in specs if not d["cli_only"]}


def test_old_spellings_work_with_a_deprecation_warning(logs):
    new = quadid.identify(logs[0], window=WINDOW, reference="qball2-virtual")
    with pytest.warns(DeprecationWarning, match="nominal= is now reference="):
        old = quadid.identify(logs[0], window=WINDOW, nominal="qball2-virtual")
    assert_same(without(old, "evolution"), without(new, "evolution"), 0.0)
    with pytest.warns(DeprecationWarning, match=r"read_log\(path=...\) is now read_log\(log=...\)"):
        log = quadid.read_log(path=logs[0])
    np.testing.assert_array_equal(log["t"], quadid.read_log(log=logs[0])["t"])


def test_window_as_a_tuple_or_list(logs):
    ref = quadid.identify(logs[0], window="2:18")
    for w in ((2, 18), [2, 18], (2.0, 18.0)):
        assert_same(without(quadid.identify(logs[0], window=w), "evolution"), without(ref, "evolution"), 0.0)
    assert quadid.identify(logs[0], window=(2, None))["window"]["t0"] == 2
    with pytest.raises(ValueError, match="window"):
        quadid.identify(logs[0], window=(18, 2))


def test_numpy_estimates_theta_order_tensor_and_covariance(logs):
    res = quadid.identify(logs[0], window=WINDOW)
    assert isinstance(res, quadid.IdentifyResult) and isinstance(res, dict)
    for s in ("LS", "FMLS"):
        order = res.theta_order(s)
        assert order == ["m", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"]  # Theta of eq. (12)
        theta, inertia, cov = res.theta(s), res.inertia_tensor(s), res.covariance(s)
        assert theta.shape == (7,) and inertia.shape == (3, 3) and cov.shape == (7, 7)
        assert all(isinstance(a, np.ndarray) and a.dtype == np.float64 for a in (theta, inertia, cov))
        np.testing.assert_array_equal(cov, cov.T)  # symmetric
        np.testing.assert_array_equal(inertia, inertia.T)
        est = res["estimates"][s]
        np.testing.assert_allclose(theta, [est[k] for k in order], rtol=1e-12)
        errors = [res["uncertainty"][s][k]["std_error"] for k in order]
        np.testing.assert_allclose(np.diag(cov), np.square(errors), rtol=1e-12)
        np.testing.assert_allclose(np.diag(inertia), [est["Ixx"], est["Iyy"], est["Izz"]], rtol=1e-12)
        assert inertia[0, 1] == pytest.approx(est["Ixy"], rel=1e-12) and inertia[1, 2] == pytest.approx(est["Iyz"], rel=1e-12)
    with pytest.raises(KeyError, match="XY"):
        res.covariance("XY")


def test_the_module_exports_its_api_only():
    for name in ("Any", "Mapping", "os", "Iterable"):
        assert not hasattr(quadid, name), name
        assert not hasattr(quadid.fleet, name), name
    assert set(quadid.__all__) <= set(dir(quadid))
    assert "check_trajectory" in quadid.__all__  # the command's name


def test_threads_identify_in_parallel_with_the_same_results(logs):
    """The C++ work releases the GIL; concurrent calls give the sequential results."""
    from concurrent.futures import ThreadPoolExecutor

    seq = [quadid.identify(p, window=WINDOW)["estimates"] for p in logs]
    with ThreadPoolExecutor(3) as ex:
        par = list(ex.map(lambda p: quadid.identify(p, window=WINDOW)["estimates"], logs))
    assert par == seq


def test_a_library_error_names_the_keyword_not_the_struct_field_or_the_flag(logs):
    # The pre-filter's check (LowpassOptions: cutoff_hz) reads as the keyword
    # that set it; the command line names its own flag for the same error.
    with pytest.raises(ValueError) as e:
        quadid.identify(str(logs[0]), cutoff=300)
    msg = str(e.value)
    assert "cutoff=300" in msg and "Nyquist" in msg, msg
    assert "LowpassOptions" not in msg and "--cutoff" not in msg, msg
    r = run_cli("identify", str(logs[0]), "--cutoff", "300", check=False)
    assert r.returncode != 0 and "--cutoff 300 must be below Nyquist" in r.stderr, r.stderr


def test_identify_on_arrays_with_a_vehicle_equals_the_command_line(tmp_path):
    # The rotor columns of a mapping get the wrench, the rotor checks and the
    # timing exactly as a file's do (it failed: "the rotor-inertia term needs
    # the rotor speeds"); the same doubles give the same result to rounding.
    f = tmp_path / "cf.csv"
    run_cli("simulate", "--vehicle", "crazyflie21", "--trajectory", "table2", "--duration", "20", "-o", str(f))
    cli = cli_json("identify", str(f), "--vehicle", "crazyflie21")
    arrays = {k: np.array(v) for k, v in quadid.read_log(f).items()}
    res = quadid.identify(arrays, vehicle="crazyflie21")
    assert res["log"] is None
    assert_same(without(res, "evolution", "log"), without(cli, "log"), REL)
