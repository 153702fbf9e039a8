"""quadid.OnlineEstimator and quadid.follow (docs/follow.md) against the
command line on the same simulated flight with a payload picked up."""

import quadid
import pytest

from conftest import cli_json, run_cli

COLUMNS = ["t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r", "Fz", "tau_phi", "tau_theta", "tau_psi"]


@pytest.fixture(scope="module")
def payload_log(tmp_path_factory):
    p = tmp_path_factory.mktemp("online") / "payload.csv"
    sim = quadid.simulate("table2", duration=30, payload_change=["15:0.2"], out=p)
    return p, sim


def test_follow_equals_the_command_line(payload_log):
    path, _ = payload_log
    py = quadid.follow(path)
    cli = cli_json("follow", str(path))
    assert len(py["changes"]) == len(cli["changes"]) == 1
    assert py["changes"][0]["t"] == cli["changes"][0]["t"]
    for a, b in zip(py["segments"], cli["segments"]):
        assert a["estimate"]["m"] == b["estimate"]["m"]


def test_the_estimator_fed_row_by_row_finds_the_change_as_follow_does(payload_log):
    path, sim = payload_log
    cols = sim["columns"]
    est = quadid.OnlineEstimator()
    changed_at = []
    for k in range(len(cols["t"])):
        if est.update({c: float(cols[c][k]) for c in COLUMNS}):
            changed_at.append(float(cols["t"][k]))
    assert len(changed_at) == 1 and 15.0 <= changed_at[0] <= 18.0
    res = est.result()
    follow = quadid.follow(path)
    # The same samples (the CSV holds the simulator's numbers in shortest round-trip form): the same segments.
    assert [s["estimate"]["m"] for s in res["segments"]] == [s["estimate"]["m"] for s in follow["segments"]]
    m0 = sim["options"]["plant"]["m"]
    assert abs(res["segments"][0]["estimate"]["m"] - m0) < 0.02 * m0
    assert abs(res["segments"][1]["estimate"]["m"] - (m0 + 0.2)) < 0.02 * (m0 + 0.2)
    assert est.estimate()["m"] == res["segments"][1]["estimate"]["m"]


def test_bad_rows_and_options_name_what_is_wrong():
    est = quadid.OnlineEstimator()
    with pytest.raises(ValueError, match="no 'tau_psi'"):
        est.update({c: 0.0 for c in COLUMNS[:-1]})
    with pytest.raises(ValueError, match="14"):
        est.update([0.0] * 3)
    with pytest.raises(ValueError, match="memory"):
        quadid.OnlineEstimator(memory=-1)
    with pytest.raises(ValueError, match="window"):
        quadid.OnlineEstimator(window="1:2")
