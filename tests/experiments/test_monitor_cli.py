"""``pdmkit monitor``: baseline, scoring into the history, watching a folder."""

from __future__ import annotations

import json
import signal
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments._cli import main


def _fleet(rng, n=800):
    """Two pumps; pump a degrades from hour 600 (its RMS drifts up), pump b stays."""
    rows = []
    for u, fails in (("a", True), ("b", False)):
        t = np.arange(n, dtype=float)
        drift = np.where(fails & (t >= 600), 0.08 * (t - 600), 0.0)
        rows.append(
            pd.DataFrame(
                {
                    "pump": u,
                    "hour": t,
                    "v/stats/RMS": 1 + 0.05 * rng.normal(size=n) + drift,
                    "v/stats/Kurtosis": 3 + 0.1 * rng.normal(size=n),
                }
            )
        )
    return pd.concat(rows, ignore_index=True)


def _n_sources(path) -> int:
    """Files the watcher has committed so far (0 before it made its tables)."""
    if not path.exists():
        return 0
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as con:
        try:
            return con.execute("SELECT COUNT(*) FROM sources").fetchone()[0]
        except sqlite3.OperationalError:
            return 0


def _fit(tmp_path, table) -> str:
    table.to_csv(tmp_path / "fleet.csv", index=False)
    args = ["monitor", "fit", "--features", str(tmp_path / "fleet.csv"), "--unit", "pump"]
    args += ["--time", "hour", "--healthy-first", "0.3", "--out", str(tmp_path / "m")]
    assert main(args) == 0
    return str(tmp_path / "m" / "model.pdmkit")


def test_fit_then_score_names_each_units_first_alarm(tmp_path, rng):
    table = _fleet(rng)
    model = _fit(tmp_path, table)
    args = ["monitor", "score", "--model", model, "--features", str(tmp_path / "fleet.csv")]
    args += ["--unit", "pump", "--time", "hour", "--db", str(tmp_path / "h.sqlite")]
    args += ["--json", str(tmp_path / "s.json"), "--out", str(tmp_path / "s")]
    assert main(args) == 0
    units = json.loads((tmp_path / "s.json").read_text())["units"]
    assert units["b"]["first_alarm"] is None
    first = float(units["a"]["first_alarm"])
    assert 600 < first < 620  # the drift passes 1 % false alarms within a few hours
    # the same file again adds nothing
    again_args = [*args[:-4], "--json", str(tmp_path / "s2.json")]
    assert main([*again_args, "--out", str(tmp_path / "s2")]) == 0
    again = json.loads((tmp_path / "s2.json").read_text())
    assert again["n_scored"] == 0 and again["units"] == units
    with sqlite3.connect(tmp_path / "h.sqlite") as con:
        n = con.execute("SELECT COUNT(*) FROM scores").fetchone()[0]
    assert n == len(table)


def test_watch_killed_and_restarted_scores_each_file_once(tmp_path, rng):
    table = _fleet(rng)
    model = _fit(tmp_path, table)
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    days = [part for _, part in table.groupby(table["hour"] // 40)]
    watch = [sys.executable, "-m", "pdmkit", "monitor", "watch", str(inbox), "--model"]
    watch += [model, "--db", str(tmp_path / "w.sqlite"), "--unit", "pump"]
    watch += ["--time", "hour", "--interval", "0.2"]
    proc = subprocess.Popen(watch, stderr=subprocess.DEVNULL)
    for k, day in enumerate(days[:12]):  # files land while it runs
        day.to_csv(inbox / f"day{k:02d}.csv", index=False)
        time.sleep(0.15)
    deadline = time.time() + 60
    while time.time() < deadline:
        if _n_sources(tmp_path / "w.sqlite") >= 6:
            break
        time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)  # mid-stream
    proc.wait()
    for k, day in enumerate(days[12:], start=12):
        day.to_csv(inbox / f"day{k:02d}.csv", index=False)
    assert main([*watch[3:], "--once"]) == 0  # the restart
    assert _n_sources(tmp_path / "w.sqlite") == len(days)
    # the history equals one batch score of the same rows
    args = ["monitor", "score", "--model", model, "--features", str(tmp_path / "fleet.csv")]
    args += ["--unit", "pump", "--time", "hour", "--db", str(tmp_path / "b.sqlite")]
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    cols = ["unit", "time", "score", "health_index", "exceeds", "run_length", "alarm"]
    with (
        sqlite3.connect(tmp_path / "w.sqlite") as w,
        sqlite3.connect(tmp_path / "b.sqlite") as b,
    ):
        query = f"SELECT {', '.join(cols)} FROM scores ORDER BY unit, time"
        got, batch = pd.read_sql_query(query, w), pd.read_sql_query(query, b)
    pd.testing.assert_frame_equal(got, batch)


def test_ims_test2_bearing1_alarms_after_half_its_life(tmp_path, require_data):
    """IMS test 2 (Lee et al., NASA repository): bearing 1 failed (outer race). The
    baseline on the first 30 % of the run; the alarm must not come in the first half."""
    folder = require_data("ims_bearing_features")
    wide = pd.read_csv(folder / "merged_dataset_BearingTest_2.csv", index_col=0)
    long = wide.reset_index(names="when").melt("when", var_name="bearing", value_name="m")
    long = long.sort_values(["bearing", "when"], kind="stable")
    by = long.groupby("bearing")["m"]
    long["vib/stats/MeanAbs"] = long["m"]
    long["vib/stats/Rolling6"] = by.transform(lambda s: s.rolling(6, min_periods=1).mean())
    long.drop(columns="m").to_csv(tmp_path / "ims2.csv", index=False)
    args = ["monitor", "fit", "--features", str(tmp_path / "ims2.csv"), "--unit", "bearing"]
    args += ["--time", "when", "--healthy-first", "0.3", "--persistence", "8"]
    assert main([*args, "--out", str(tmp_path / "m")]) == 0
    args = ["monitor", "score", "--model", str(tmp_path / "m" / "model.pdmkit")]
    args += [
        "--features",
        str(tmp_path / "ims2.csv"),
        "--unit",
        "bearing",
        "--time",
        "when",
    ]
    args += ["--db", str(tmp_path / "h.sqlite"), "--json", str(tmp_path / "s.json")]
    assert main([*args, "--out", str(tmp_path / "s")]) == 0
    units = json.loads((tmp_path / "s.json").read_text())["units"]
    stamps = pd.to_datetime(wide.index)
    life = (stamps[-1] - stamps[0]).total_seconds()
    first = pd.Timestamp(units["Bearing 1"]["first_alarm"])
    assert 0.5 < (first - stamps[0]).total_seconds() / life < 0.85


def test_score_report_shows_health_over_time_and_the_drivers_of_each_alarm(tmp_path, rng):
    table = _fleet(rng)
    model = _fit(tmp_path, table)
    args = ["monitor", "score", "--model", model, "--features", str(tmp_path / "fleet.csv")]
    args += ["--unit", "pump", "--time", "hour", "--db", str(tmp_path / "h.sqlite")]
    assert main([*args, "--out", str(tmp_path / "s")]) == 0
    page = (tmp_path / "s" / "report.html").read_text()
    assert "Health over time" in page and 'src="data:image/png;base64,' in page
    with sqlite3.connect(tmp_path / "h.sqlite") as con:
        first = con.execute(
            "SELECT time_text, top_indicators FROM scores WHERE unit = 'a' AND alarm = 1 "
            "ORDER BY time LIMIT 1"
        ).fetchone()
    drivers = json.loads(first[1])
    assert drivers[0] == "v/stats/RMS"  # the drifting indicator drives pump a's alarm
    assert f"<td>{first[0]}</td>" in page and ", ".join(drivers) in page


def test_false_alarms_per_time_become_a_rate_per_row_of_the_time_step(tmp_path, rng):
    from pdmkit.errors import DataError
    from pdmkit.experiments._monitor import false_alarm_spec

    assert false_alarm_spec("0.02") == (0.02, None)
    assert false_alarm_spec("2/1w") == (None, 2 / 604800)
    for bad in ("0", "1.5", "x/30d", "1/30y", "1/0d"):
        with pytest.raises(DataError, match="--false-alarms"):
            false_alarm_spec(bad)
    table = _fleet(rng)
    stamps = pd.Timestamp("2026-01-01") + pd.to_timedelta(table["hour"] * 10, unit="min")
    table["stamp"] = stamps.dt.strftime("%Y-%m-%d %H:%M:%S")
    table.drop(columns="hour").to_csv(tmp_path / "fleet.csv", index=False)
    args = ["monitor", "fit", "--features", str(tmp_path / "fleet.csv"), "--unit", "pump"]
    args += ["--time", "stamp", "--healthy-first", "0.3"]
    assert main([*args, "--false-alarms", "1/1d", "--out", str(tmp_path / "m")]) == 0
    summary = json.loads((tmp_path / "m" / "summary.json").read_text())
    assert summary["row_step_s"] == 600.0
    assert summary["false_alarm_rate"] == pytest.approx(600 / 86400)
    # 2 x 72 calibration rows cannot certify 1 per 30 days (1 per 4320 rows)
    assert main([*args, "--false-alarms", "1/30d", "--out", str(tmp_path / "m2")]) == 2
    assert not (tmp_path / "m2").exists()
