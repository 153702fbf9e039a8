"""quadid.fleet.identify_many on a 2-worker dask LocalCluster and on local processes."""

import pytest

import quadid
import quadid.fleet
from conftest import WINDOW, assert_same, cli_json


@pytest.fixture
def fleet(logs, tmp_path):
    """The three logs with a corrupt one (a truncated copy) in the middle, and the CLI's results."""
    corrupt = tmp_path / "corrupt.csv"
    lines = logs[0].read_text().splitlines(keepends=True)
    corrupt.write_text("".join(lines[: len(lines) // 3]) + "1.0,2.0\n")  # a short last row
    paths = [logs[0], corrupt, logs[1], logs[2]]
    expected = {str(p): cli_json("identify", str(p), "--window", WINDOW) for p in logs}
    return paths, expected


def check(records, paths, expected):
    assert [r["path"] for r in records] == [str(p) for p in paths]  # input order
    bad = records[1]
    assert bad["ok"] is False and "corrupt.csv" in bad["error"] and "field" in bad["error"]
    assert set(bad) == {"path", "ok", "error"}
    for r in records[:1] + records[2:]:
        assert r["ok"] is True
        ref = dict(expected[r["path"]], path=r["path"], ok=True)
        assert_same(r, ref, 1e-9)


def test_identify_many_on_a_local_dask_cluster(fleet):
    distributed = pytest.importorskip("dask.distributed")
    paths, expected = fleet
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            records = quadid.fleet.identify_many(paths, client=client, window=WINDOW)
    check(records, paths, expected)


def test_identify_many_on_local_processes(fleet):
    paths, expected = fleet
    check(quadid.fleet.identify_many(paths, max_workers=2, window=WINDOW), paths, expected)


def test_a_bad_option_fails_at_once_not_per_log(logs):
    with pytest.raises(ValueError, match="cutof"):
        quadid.fleet.identify_many(logs, cutof=3)


def test_summarize_equals_the_batch_summary(fleet, tmp_path):
    """quadid.fleet.summarize on identify_many's records == `quadid batch --summary` on the same logs."""
    import json

    from conftest import run_cli

    paths, _ = fleet
    records = quadid.fleet.identify_many(paths, max_workers=2, window=WINDOW)
    out = tmp_path / "summary.json"
    run_cli("batch", "-q", "--window", WINDOW, "--summary-set", "LS", "--summary", str(out),
            *[str(p) for p in paths], check=False)  # exit 2: the corrupt log
    cli = json.loads(out.read_text())
    py = quadid.fleet.summarize(records, set="LS")
    assert py["flights"] == 3 and len(py["skipped"]) == 1 and "corrupt.csv" in py["skipped"][0]
    assert_same(py, cli, 1e-12)
    with pytest.raises(ValueError, match="set=XY"):
        quadid.fleet.summarize(records, set="XY")
    with pytest.raises(ValueError, match="level=1.5"):
        quadid.fleet.summarize(records, level=1.5)


def test_report_writes_the_batch_fleet_page(fleet, tmp_path):
    """quadid.fleet.report on identify_many's records: the page `quadid batch --report` writes as
    index.html, but for the links to per-log pages (the Python records have none)."""
    from conftest import run_cli

    paths, _ = fleet
    records = quadid.fleet.identify_many(paths, max_workers=2, window=WINDOW)
    page = quadid.fleet.report(records, tmp_path / "fleet.html", set="LS")
    assert page == str(tmp_path / "fleet.html")
    html = (tmp_path / "fleet.html").read_text()
    run_cli("batch", "-q", "--window", WINDOW, "--summary-set", "LS", "--report", str(tmp_path / "cli"),
            *[str(p) for p in paths], check=False)  # exit 2: the corrupt log
    cli = (tmp_path / "cli" / "index.html").read_text()
    strip = lambda s: __import__("re").sub(r'<a href="[^"]*">([^<]*)</a>', r"\1", s)
    assert strip(html) == strip(cli)
    assert "3 of 4 logs identified" in html and "FAILED: " in html
    assert [p.name for p in tmp_path.iterdir() if ".tmp" in p.name] == []  # written atomically
    with pytest.raises(ValueError, match="set=XY"):
        quadid.fleet.report(records, tmp_path / "x.html", set="XY")
    assert not (tmp_path / "x.html").exists()
