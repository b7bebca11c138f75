"""The designer's History page: a ``pdmkit monitor`` history, read and never written.

The history is made by ``run_monitor_fit`` and ``run_monitor_score`` (the functions
behind ``pdmkit monitor fit`` / ``score``) on a small fleet with timestamps, or by
:class:`HealthHistory` directly where a case needs many rows or RUL rows. The page's
answers are checked against the history's own readers: ``alarm_table`` (the report's
table), ``first_alarms`` and ``rul_history``.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from starlette.testclient import TestClient

from pdmkit.ensembles import Ensemble
from pdmkit.errors import DataError
from pdmkit.experiments._monitor import run_monitor_fit, run_monitor_score
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.experiments._monitor_report import alarm_table
from pdmkit.experiments.designer._app import create_app
from pdmkit.experiments.designer._history import MAX_POINTS, HistorySource
from pdmkit.experiments.designer._session import Session
from pdmkit.experiments.designer._source import Source

TOKEN = "history-token"
H = {"x-designer-token": TOKEN}
START = pd.Timestamp("2026-11-01")


def _fleet(n: int = 160, seed: int = 0) -> pd.DataFrame:
    """Three pumps, hourly timestamps; pump1 drifts from hour 100, pump3 from 120."""
    rng = np.random.default_rng(seed)
    parts = []
    for unit, drift in (("pump1", 100), ("pump2", None), ("pump3", 120)):
        k = np.arange(n)
        rms = rng.normal(size=n) + (0 if drift is None else np.maximum(0, k - drift) * 0.3)
        stamps = (START + pd.to_timedelta(k, unit="h")).strftime("%Y-%m-%d %H:%M")
        parts.append(
            pd.DataFrame(
                {"pump": unit, "stamp": stamps, "v/stats/RMS": rms,
                 "v/stats/Kurtosis": rng.normal(size=n)}
            )
        )  # fmt: skip
    return pd.concat(parts, ignore_index=True)


@pytest.fixture(scope="module")
def scored(tmp_path_factory) -> Path:
    """A history written by monitor fit + two monitor scores (two files)."""
    folder = tmp_path_factory.mktemp("monitor")
    table = _fleet()
    table.to_csv(folder / "all.csv", index=False)
    run_monitor_fit(folder / "all.csv", out_dir=folder / "m", unit="pump", time="stamp",
                    healthy_first=0.5, false_alarm_rate=0.05)  # fmt: skip
    hour = pd.to_datetime(table["stamp"])
    for i, part in enumerate((table[hour < START + pd.Timedelta("100h")],
                              table[hour >= START + pd.Timedelta("100h")])):  # fmt: skip
        part.to_csv(folder / f"day{i}.csv", index=False)
        run_monitor_score(folder / "m/model.pdmkit", folder / f"day{i}.csv",
                          db=folder / "h.sqlite", out_dir=folder / f"s{i}",
                          unit="pump", time="stamp")  # fmt: skip
    return folder / "h.sqlite"


def _client(path, session: Session | None = None) -> TestClient:
    return TestClient(create_app(session, TOKEN, HistorySource(path)))


def _rows(n: int, alarm_at: int | None, unit: str = "u") -> pd.DataFrame:
    """``n`` rows of one unit: healthy noise, over the threshold from ``alarm_at``."""
    rng = np.random.default_rng(3)
    hi = np.clip(0.9 + 0.05 * rng.normal(size=n), 0.6, 1.0)
    if alarm_at is not None:
        hi[alarm_at:] = np.linspace(0.45, 0.05, n - alarm_at)
    hi[n // 3] = 0.55  # a lone dip the decimation must keep
    return pd.DataFrame({"unit": unit, "time": np.arange(n, dtype=float),
                         "member": "m", "score": -np.log2(hi), "health_index": hi,
                         "exceeds": hi < 0.5})  # fmt: skip


def _fleet_with_rul(path: Path, files: int = 4, hours: int = 72) -> None:
    """A fleet's history with timestamps and an RUL estimate after each file.

    pump1 wears from hour 120 and pump3 from hour 170 (their RUL shrinks; the first
    estimates have no lower bound); pump2 stays healthy (its RUL has no upper bound).
    """
    rng = np.random.default_rng(7)
    life = {"pump1": 330.0, "pump2": None, "pump3": 380.0}
    with HealthHistory(path) as history:
        for f in range(files):
            k = np.arange(f * hours, (f + 1) * hours)
            stamps = START + pd.to_timedelta(k, unit="h")
            parts, rul = [], []
            for unit, end in life.items():
                wear = 0.0 if end is None else np.clip((k - end + 210.0) / 210.0, 0, 1)
                hi = np.clip(0.93 - 0.9 * wear + 0.04 * rng.normal(size=k.size), 0, 1)
                parts.append(pd.DataFrame({
                    "unit": unit, "time": (stamps - pd.Timestamp(0)).total_seconds(),
                    "time_text": stamps.strftime("%Y-%m-%d %H:%M"),
                    "member": [f"day{f}.csv:{i}" for i in range(k.size)],
                    "score": -np.log2(np.maximum(hi, 1e-3)), "health_index": hi,
                    "exceeds": hi < 0.5}))  # fmt: skip
                left = 900.0 if end is None else max(end - k[-1], 0.0)
                rul.append({"unit": unit, "time": parts[-1]["time"].iloc[-1],
                            "time_text": parts[-1]["time_text"].iloc[-1], "rul": left,
                            "lower": np.nan if f == 0 else 0.7 * left,
                            "upper": np.nan if end is None else 1.4 * left,
                            "level": 0.9, "note": ""})  # fmt: skip
            rows = pd.concat(parts, ignore_index=True)
            tops = [["v/stats/RMS", "v/stats/Kurtosis"]] * len(rows)
            history.record(rows, persistence=3, source=(f"sha{f}", f"day{f}.csv"),
                           top_indicators=tops, rul=pd.DataFrame(rul))  # fmt: skip


def _fingerprint(path: Path) -> tuple:
    stat = path.stat()
    return (
        hashlib.sha256(path.read_bytes()).hexdigest(),
        stat.st_mtime_ns,
        sorted(p.name for p in path.parent.iterdir()),
    )


def test_alarm_table_is_the_reports(scored: Path) -> None:
    client = _client(scored)
    res = client.get("/api/history?limit=500", headers=H).json()
    with HealthHistory(scored, read_only=True) as history:
        expected = alarm_table(history.history())
    page = pd.DataFrame(res["rows"], columns=res["columns"]).fillna(np.nan)
    pd.testing.assert_frame_equal(page, expected, check_dtype=False)
    assert list(page["unit"]) == ["pump1", "pump3", "pump2"]  # alarmed first
    assert (res["n_units"], res["n_alarmed"], res["history"]) == (3, 2, str(scored))


def test_unit_series_first_alarm_as_dates(scored: Path) -> None:
    client = _client(scored)
    with HealthHistory(scored, read_only=True) as history:
        first = history.first_alarms(text=True)
        rows = history.history("pump1")
    s = client.get("/api/history/unit?unit=pump1", headers=H).json()
    assert s["first_alarm"]["time_text"] == first["pump1"] is not None
    assert s["x_kind"] == "date"  # the table's timestamps, drawn as dates
    assert pd.Timestamp(s["first_alarm"]["x"]) == pd.Timestamp(first["pump1"])
    assert s["n_rows"] == len(rows) == s["n_points"] and not s["decimated"]
    assert s["time_text"] == rows["time_text"].tolist()
    assert s["health_index"] == pytest.approx(rows["health_index"].tolist())
    assert s["alarm"] == rows["alarm"].tolist() and s["threshold"] == 0.5
    assert s["first_alarm"]["drivers"] and s["rul"] is None  # no RUL model attached
    healthy = client.get("/api/history/unit?unit=pump2", headers=H).json()
    assert first["pump2"] is None and healthy["first_alarm"] is None


def test_a_long_history_is_decimated_within_the_bound(tmp_path: Path) -> None:
    path = tmp_path / "long.sqlite"
    n, alarm_at, persistence = 30_000, 21_000, 3
    with HealthHistory(path) as history:
        history.record(_rows(n, alarm_at), persistence=persistence)
    client = _client(path)
    s = client.get("/api/history/unit?unit=u", headers=H).json()
    assert s["n_rows"] == n and s["decimated"] and len(s["x"]) <= MAX_POINTS
    assert len(s["health_index"]) == len(s["x"]) == s["n_points"]
    first = float(alarm_at + persistence - 1)  # the row completing the persistence
    assert s["first_alarm"]["x"] == first
    # every alarm change is drawn: the last quiet row and the first alarmed one
    k = s["x"].index(first)
    assert s["x"][k - 1] == first - 1 and not s["alarm"][k - 1] and s["alarm"][k]
    assert s["x"][0] == 0.0 and s["x_end"] == s["x"][-1] == n - 1
    assert 0.55 in s["health_index"]  # the lone dip survives the decimation
    small = client.get("/api/history/unit?unit=u&points=100", headers=H).json()
    assert small["n_points"] <= 100 and small["first_alarm"]["x"] == first


def test_rul_rows_come_back_with_their_bounds(tmp_path: Path) -> None:
    path = tmp_path / "rul.sqlite"
    rul = pd.DataFrame({"unit": "u", "time": [99.0], "time_text": ["99.0"],
                        "rul": [40.0], "lower": [np.nan], "upper": [55.0],
                        "level": [0.9], "note": [""]})  # fmt: skip
    with HealthHistory(path) as history:
        history.record(_rows(100, 60), persistence=2, source=("f1", "a"), rul=rul)
        rows = _rows(200, 60).iloc[100:]
        rul2 = rul.assign(time=199.0, time_text="199.0", rul=20.0, lower=12.0, upper=30.0)
        history.record(rows, persistence=2, source=("f2", "b"), rul=rul2)
        expected = history.rul_history("u")
    client = _client(path)
    r = client.get("/api/history/unit?unit=u", headers=H).json()["rul"]
    assert r["x"] == expected["time"].tolist() == [99.0, 199.0]
    assert r["rul"] == [40.0, 20.0]
    assert r["lower"] == [None, 12.0] and r["upper"] == [55.0, 30.0]  # None: open
    assert r["level"] == [0.9, 0.9] and r["x_kind"] == "number"
    page = client.get("/api/history", headers=H).json()
    assert page["last_rul"] == {"u": {"rul": 20.0, "lower": 12.0, "upper": 30.0}}


def test_the_page_never_writes_the_history_and_sees_new_rows(tmp_path: Path) -> None:
    path = tmp_path / "h.sqlite"
    with HealthHistory(path) as history:
        history.record(_rows(50, None, "a"), persistence=2, source=("f1", "a"))
    before = _fingerprint(path)
    client = _client(path)
    for _ in range(2):
        assert client.get("/api/history", headers=H).json()["rows"][0]["rows"] == 50
        assert client.get("/api/history/unit?unit=a", headers=H).status_code == 200
    assert _fingerprint(path) == before  # bytes, mtime and no journal left behind
    # a running `monitor watch` adds a file: the next read (refresh) shows it
    with HealthHistory(path) as history:
        rows = _rows(80, 60, "a").iloc[50:]
        history.record(rows, persistence=2, source=("f2", "b"))
    res = client.get("/api/history", headers=H).json()
    assert res["rows"][0]["rows"] == 80 and res["n_alarmed"] == 1


def test_missing_and_foreign_files_are_one_line_errors(tmp_path: Path) -> None:
    missing = tmp_path / "nothing.sqlite"
    with pytest.raises(DataError, match=r"nothing\.sqlite: no such health history file"):
        HistorySource(missing)
    assert not missing.exists()  # never created
    text = tmp_path / "fleet.csv"
    text.write_text("unit,time\na,1\n" * 200)
    with pytest.raises(DataError, match=r"fleet\.csv is not a pdmkit health history"):
        HistorySource(text)
    empty = tmp_path / "other.sqlite"
    import sqlite3

    with sqlite3.connect(empty) as db:
        db.execute("CREATE TABLE t (x)")
    with pytest.raises(DataError, match=r"other\.sqlite is not a pdmkit health history"):
        HistorySource(empty)
    # the command line: one line naming the file, exit status 2, no server
    run = subprocess.run(
        [sys.executable, "-m", "pdmkit", "designer", "--no-browser", "--history",
         str(missing)],
        capture_output=True, text=True, timeout=120, env={**os.environ},
    )  # fmt: skip
    assert run.returncode == 2 and not missing.exists()
    assert run.stderr.strip().count("\n") == 0 and "nothing.sqlite" in run.stderr


def test_a_database_url_reads_the_same_without_writing(scored: Path, tmp_path) -> None:
    pytest.importorskip("sqlalchemy", reason="pdmkit[db] is not installed")
    before = _fingerprint(scored)
    by_path = _client(scored).get("/api/history", headers=H).json()
    by_url = _client(f"sqlite:///{scored}").get("/api/history", headers=H).json()
    assert by_url["rows"] == by_path["rows"] and by_url["history"].startswith("sqlite:")
    assert _fingerprint(scored) == before
    missing = tmp_path / "nothing.sqlite"  # SQLite would create it: refused first
    with pytest.raises(DataError, match="no such health history file"):
        HistorySource(f"sqlite:///{missing}")
    assert not missing.exists()


def test_a_history_deleted_while_open_is_an_error_on_the_page(tmp_path: Path) -> None:
    path = tmp_path / "h.sqlite"
    with HealthHistory(path) as history:
        history.record(_rows(20, None), persistence=2)
    client = _client(path)
    path.unlink()
    res = client.get("/api/history", headers=H)
    assert res.status_code == 400 and "no such health history file" in res.json()["error"]
    assert not path.exists()


def test_token_guard_and_history_alone(scored: Path) -> None:
    client = _client(scored)
    assert client.get("/api/history").status_code == 403
    bad = {"x-designer-token": "wrong"}
    assert client.get("/api/history/unit?unit=pump1", headers=bad).status_code == 403
    assert client.get("/?token=wrong").status_code == 403
    state = client.get("/api/state", headers=H).json()
    assert state == {"kind": None, "source": None, "history": str(scored)}
    # the other steps say why they cannot run, in one line
    members = client.post("/api/members", json={}, headers=H)
    assert members.status_code == 400
    assert "monitoring history only" in members.json()["error"]
    unknown = client.get("/api/history/unit?unit=nope", headers=H)
    assert unknown.status_code == 400 and "no unit 'nope'" in unknown.json()["error"]
    page = client.get(f"/?token={TOKEN}").text
    assert 'id="tab-history"' in page and 'id="plot-health"' in page


def test_history_beside_an_ensemble_and_without_one(scored: Path) -> None:
    ens = Ensemble({"v": np.zeros((2, 64))}, fs=64.0, conditions={"fault": ["a", "b"]})
    client = _client(scored, Session(Source.from_ensemble(ens)))
    state = client.get("/api/state", headers=H).json()
    assert state["n_members"] == 2 and state["history"] == str(scored)
    assert client.post("/api/members", json={}, headers=H).json()["total"] == 2
    assert client.get("/api/history", headers=H).json()["n_units"] == 3
    plain = TestClient(create_app(Session(Source.from_ensemble(ens)), TOKEN))
    assert plain.get("/api/state", headers=H).json()["history"] is None
    res = plain.get("/api/history", headers=H)
    assert res.status_code == 400 and "--history" in res.json()["error"]


def test_units_are_paged_and_filtered(tmp_path: Path) -> None:
    path = tmp_path / "fleet.sqlite"
    with HealthHistory(path) as history:
        for i in range(7):
            history.record(_rows(30, 10 if i % 2 else None, f"pump{i}"),
                           persistence=2)  # fmt: skip
    client = _client(path)
    first = client.get("/api/history?limit=3", headers=H).json()
    second = client.get("/api/history?limit=3&offset=3", headers=H).json()
    assert first["total"] == 7 and len(first["rows"]) == 3 == len(second["rows"])
    shown = [r["unit"] for r in first["rows"] + second["rows"]]
    assert shown[:3] == ["pump1", "pump3", "pump5"] and len(set(shown)) == 6
    alarmed = client.get("/api/history?alarmed=1", headers=H).json()
    assert [r["unit"] for r in alarmed["rows"]] == ["pump1", "pump3", "pump5"]
    named = client.get("/api/history?contains=UMP4", headers=H).json()
    assert [r["unit"] for r in named["rows"]] == ["pump4"]
    assert client.get("/api/history?limit=x", headers=H).status_code == 400


def _wait(driver, condition, timeout: float = 30.0):
    from selenium.webdriver.support.ui import WebDriverWait

    def check(d):
        status = d.find_element("id", "status")
        if "error" in (status.get_attribute("class") or ""):
            raise AssertionError(f"the page shows an error: {status.text}")
        return condition(d)

    return WebDriverWait(driver, timeout, poll_frequency=0.1).until(check)


def _plot_attr(driver, plot_id: str, expression: str):
    script = f"const p = document.getElementById('{plot_id}');"
    return driver.execute_script(f"{script} return p.data ? {expression} : null")


def test_history_page_in_chromium(tmp_path: Path, start_designer, headless_chrome) -> None:
    """Open ``pdmkit designer --history`` alone: the alarm table and both charts.

    With ``PDMKIT_SCREENSHOTS=DIR`` set, the page is also saved as
    ``DIR/designer_history.png`` (the screenshot in docs/designer.md).
    """
    path = tmp_path / "fleet.sqlite"
    _fleet_with_rul(path)
    driver = headless_chrome("the History page test", "--window-size=1400,1100")
    server = start_designer("--history", path.name)  # run in tmp_path
    try:
        driver.get(server.url)
        rows = _wait(
            driver, lambda d: d.find_elements("css selector", "#history-units tbody tr")
        )
        assert [r.get_attribute("data-unit") for r in rows] == ["pump1", "pump3", "pump2"]
        assert not driver.find_element("id", "tab-data").is_displayed()  # no ensemble
        assert driver.find_element("id", "tab-history").is_displayed()
        # the earliest alarm is drawn first: health index, threshold, alarm span, RUL
        _wait(driver, lambda d: _plot_attr(d, "plot-rul", "p.data.length") == 3)
        health = driver.find_element("id", "plot-health")
        assert health.get_attribute("data-unit") == "pump1"
        title = driver.find_element("id", "plot-health").text
        assert "alarm since 2026-11-" in title and "alarm threshold" in title
        assert _plot_attr(driver, "plot-health", "p.layout.xaxis.type") == "date"
        assert _plot_attr(driver, "plot-health", "p.layout.shapes.length") == 2
        driver.save_screenshot(str(tmp_path / "history_page.png"))
        if os.environ.get("PDMKIT_SCREENSHOTS"):
            folder = Path(os.environ["PDMKIT_SCREENSHOTS"])
            driver.save_screenshot(str(folder / "designer_history.png"))
        # a click draws another unit: healthy, its RUL band open upwards to the edge
        rows[2].click()
        _wait(driver, lambda d: d.find_element("id", "plot-health").get_attribute(
            "data-unit") == "pump2")  # fmt: skip
        assert "no alarm" in driver.find_element("id", "plot-health").text
        top = _plot_attr(driver, "plot-rul", "p.layout.yaxis.range[1]")
        assert _plot_attr(driver, "plot-rul", "p.data[1].y") == [top] * 4
    finally:
        driver.quit()
        server.stop()
