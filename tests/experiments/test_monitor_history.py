"""The fleet's health history: exactly once across crashes, readable with plain SQL."""

from __future__ import annotations

import shutil
import signal
import sqlite3
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.experiments._monitor_history import HealthHistory


def _batch(rng, units=("a", "b"), n=40, start=0.0):
    rows = []
    for u in units:
        t = start + np.arange(n, dtype=float)
        score = rng.normal(size=n) + np.where(t > start + n * 0.6, 3.0, 0.0)
        rows.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "time": t,
                    "member": [f"{u}{int(x)}" for x in t],
                    "score": score,
                    "health_index": 1 / (1 + np.exp(score)),
                    "exceeds": score > 1.5,
                }
            )
        )
    return pd.concat(rows, ignore_index=True)


def _chunks(rows: pd.DataFrame, k: int) -> list[pd.DataFrame]:
    """The rows in time order, cut into ``k`` files as a plant would receive them."""
    ordered = rows.sort_values("time", kind="stable")
    return [ordered.iloc[i] for i in np.array_split(np.arange(len(rows)), k)]


def _alarm_reference(exceeds: np.ndarray, persistence: int) -> np.ndarray:
    """The latched persistence rule, written independently: alarm from the first
    index where ``persistence`` consecutive exceedances end."""
    alarm = np.zeros(len(exceeds), dtype=bool)
    for i in range(persistence - 1, len(exceeds)):
        if exceeds[i - persistence + 1 : i + 1].all():
            alarm[i:] = True
            break
    return alarm


def test_file_by_file_equals_one_batch_and_the_reference_rule(tmp_path, rng):
    rows = _batch(rng)
    whole = HealthHistory(tmp_path / "whole.sqlite")
    whole.record(rows, persistence=3, source=("all", "all.csv"))
    parts = HealthHistory(tmp_path / "parts.sqlite")
    for k, chunk in enumerate(_chunks(rows, 7)):
        parts.record(chunk, persistence=3, source=(f"sha{k}", f"f{k}.csv"))
    a = whole.history().drop(columns="source_sha256")
    b = parts.history().drop(columns="source_sha256")
    pd.testing.assert_frame_equal(a, b)
    for unit, part in a.groupby("unit"):
        expected = _alarm_reference(part["exceeds"].to_numpy(), 3)
        assert (part["alarm"].to_numpy() == expected).all()
        first = part["time"][part["alarm"]].min() if expected.any() else None
        assert parts.first_alarms()[unit] == first


def test_a_failed_batch_leaves_nothing_and_rows_must_move_forward(tmp_path, rng):
    db = HealthHistory(tmp_path / "h.sqlite")
    db.record(_batch(rng, n=10), persistence=2, source=("one", "one.csv"))
    before = db.history()
    late = _batch(rng, units=("a", "b"), n=5, start=20.0)
    late.loc[late.unit == "b", "time"] = 3.0  # b goes back in time: the whole file fails
    with pytest.raises(DataError, match=r"unit 'b': a row at time 3 is not after"):
        db.record(late, persistence=2, source=("two", "two.csv"))
    pd.testing.assert_frame_equal(db.history(), before)
    assert not db.seen("two") and db.seen("one")


def test_another_model_or_a_foreign_file_is_refused(tmp_path):
    HealthHistory(tmp_path / "h.sqlite", model_sha256="a" * 64).close()
    with pytest.raises(DataError, match="start another --db"):
        HealthHistory(tmp_path / "h.sqlite", model_sha256="b" * 64)
    (tmp_path / "x.sqlite").write_bytes(b"not a database at all" * 10)
    with pytest.raises(DataError, match="not a pdmkit health history"):
        HealthHistory(tmp_path / "x.sqlite")


@pytest.mark.skipif(shutil.which("sqlite3") is None, reason="no sqlite3 command-line tool")
def test_the_history_opens_with_the_sqlite3_tool(tmp_path, rng):
    db = HealthHistory(tmp_path / "h.sqlite")
    db.record(_batch(rng), persistence=3, source=("s", "s.csv"))
    db.close()
    out = subprocess.run(
        ["sqlite3", str(tmp_path / "h.sqlite"),
         "SELECT unit, COUNT(*), MAX(alarm) FROM scores GROUP BY unit ORDER BY unit;"],
        capture_output=True, text=True, check=True,
    ).stdout.split()  # fmt: skip
    assert out == ["a|40|1", "b|40|1"]


_WRITER = """
import sys, time, numpy as np, pandas as pd
from pdmkit.experiments._monitor_history import HealthHistory
db = HealthHistory(sys.argv[1])
rows = pd.read_parquet(sys.argv[2])
ordered = rows.sort_values("time", kind="stable")
for k, idx in enumerate(np.array_split(np.arange(len(rows)), 40)):
    db.record(ordered.iloc[idx], persistence=3, source=(f"sha{k}", f"f{k}.csv"))
    print(k, flush=True)
    time.sleep(0.02)
"""


def test_kill_9_mid_stream_then_restart_scores_every_file_once(tmp_path, rng):
    rows = _batch(rng, units=("a", "b", "c"), n=200)
    rows.to_parquet(tmp_path / "rows.parquet")
    (tmp_path / "w.py").write_text(_WRITER)
    db_path = tmp_path / "h.sqlite"
    args = [
        sys.executable,
        str(tmp_path / "w.py"),
        str(db_path),
        str(tmp_path / "rows.parquet"),
    ]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True)
    for _ in range(10):  # let it commit some files, then kill it hard
        proc.stdout.readline()
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    with sqlite3.connect(db_path) as con:
        done = con.execute("SELECT COUNT(*) FROM sources").fetchone()[0]
    assert 10 <= done < 40
    # the restart skips what was committed and scores the rest, once each
    db = HealthHistory(db_path)
    for k, chunk in enumerate(_chunks(rows, 40)):
        if not db.seen(f"sha{k}"):
            db.record(chunk, persistence=3, source=(f"sha{k}", f"f{k}.csv"))
    batch = HealthHistory(tmp_path / "batch.sqlite")
    batch.record(rows, persistence=3)
    got = db.history().drop(columns="source_sha256")
    pd.testing.assert_frame_equal(got, batch.history().drop(columns="source_sha256"))
    assert len(got) == len(rows)
