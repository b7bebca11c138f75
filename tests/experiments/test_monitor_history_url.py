"""The health history by database URL (SQLAlchemy): the SQLite file's history, exactly.

No database server runs here, so the URL path is exercised through ``sqlite:///``
URLs: SQLAlchemy's dialect, connection pool and transactions, on a file that plain
``sqlite3`` can then read back row by row. The tests that need SQLAlchemy skip with
the reason when it is absent; the error that says so, and the masking of a URL's
password, are tested either way.
"""

from __future__ import annotations

import importlib.util
import json
import sqlite3
import sys

import numpy as np
import pandas as pd
import pytest

from pdmkit import save_model
from pdmkit.errors import DataError, MissingExtraError
from pdmkit.experiments._cli import main
from pdmkit.experiments._monitor_db import db_target, mask_url
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.models.diagnosis import HealthModel

needs_sqlalchemy = pytest.mark.skipif(
    importlib.util.find_spec("sqlalchemy") is None,
    reason="sqlalchemy is not installed (pip install 'pdmkit[db]')",
)
SECRET = "s3cret"


def _scored_rows(rng, n: int = 30) -> pd.DataFrame:
    """Three pumps; pump p1 runs hot in the last third (its score rises over 1.5)."""
    frames = []
    for k, unit in enumerate(("p0", "p1", "p2")):
        hours = np.arange(n, dtype=float)
        score = rng.normal(size=n) + 3.0 * (k == 1) * (hours >= 2 * n / 3)
        frames.append(
            pd.DataFrame({
                "unit": unit, "time": hours, "time_text": [f"h{h:03.0f}" for h in hours],
                "member": [f"{unit}-{h:.0f}" for h in hours], "score": score,
                "health_index": 1 / (1 + np.exp(score)), "exceeds": score > 1.5,
            })
        )  # fmt: skip
    return pd.concat(frames, ignore_index=True)


def _files(rows: pd.DataFrame, k: int) -> list[tuple[pd.DataFrame, list]]:
    """The rows in time order cut into ``k`` files, each with its top indicators."""
    ordered = rows.sort_values("time", kind="stable")
    parts = np.array_split(np.arange(len(ordered)), k)
    return [(ordered.iloc[p], [["rms", str(i)] for i in p]) for p in parts]


def _table(path, sql: str) -> list[tuple]:
    with sqlite3.connect(path) as con:
        return con.execute(sql).fetchall()


@needs_sqlalchemy
def test_url_and_file_histories_are_identical_row_by_row(tmp_path, rng):
    rows = _scored_rows(rng)
    targets = {"file": tmp_path / "file.sqlite", "url": tmp_path / "url.sqlite"}
    for how, path in targets.items():
        target = f"sqlite:///{path}" if how == "url" else path
        with HealthHistory(target, model_sha256="c" * 64) as history:
            for k, (part, tops) in enumerate(_files(rows, 6)):
                history.record(part, persistence=3, source=(f"sha{k}", f"f{k}.csv"),
                               top_indicators=tops)  # fmt: skip
    for sql in (
        "SELECT * FROM scores ORDER BY unit, time, member",
        "SELECT * FROM units ORDER BY unit",
        "SELECT sha256, path, n_rows FROM sources ORDER BY sha256",
        "SELECT * FROM meta ORDER BY key",
    ):
        got, want = _table(targets["url"], sql), _table(targets["file"], sql)
        assert got == want and len(got) > 1, sql
    alarms = _table(targets["url"], "SELECT unit, first_alarm_text FROM units")
    assert {u for u, t in alarms if t is not None} == {"p1"}


@needs_sqlalchemy
def test_a_file_scored_again_adds_nothing(tmp_path, rng):
    rows = _scored_rows(rng, n=10)
    url = f"sqlite:///{tmp_path / 'h.sqlite'}"
    with HealthHistory(url) as history:
        assert history.record(rows, persistence=2, source=("one", "a.csv")) is not None
        assert history.seen("one")
        assert history.record(rows, persistence=2, source=("one", "a.csv")) is None
        assert len(history.history()) == len(rows)
    with HealthHistory(url) as reopened:  # committed: seen after a restart too
        assert reopened.record(rows, persistence=2, source=("one", "a.csv")) is None
    assert _table(tmp_path / "h.sqlite", "SELECT COUNT(*) FROM sources") == [(1,)]


@pytest.mark.parametrize("how", ["file", pytest.param("url", marks=needs_sqlalchemy)])
def test_a_crash_before_the_commit_leaves_neither_rows_nor_hash(tmp_path, rng, how):
    path = tmp_path / "h.sqlite"
    history = HealthHistory(f"sqlite:///{path}" if how == "url" else path)
    first, second = _files(_scored_rows(rng, n=12), 2)
    history.record(first[0], persistence=2, source=("one", "one.csv"))
    before = [_table(path, f"SELECT * FROM {t}") for t in ("scores", "units", "sources")]
    execute = history._db.execute

    def crash_after_the_hash(sql, params=None):
        execute(sql, params)  # the rows and the file's hash are written...
        if "INSERT INTO sources" in sql:
            raise RuntimeError("power cut")  # ...but never committed

    history._db.execute = crash_after_the_hash
    with pytest.raises(RuntimeError, match="power cut"):
        history.record(second[0], persistence=2, source=("two", "two.csv"))
    after = [_table(path, f"SELECT * FROM {t}") for t in ("scores", "units", "sources")]
    assert after == before and not history.seen("two")
    history._db.execute = execute  # the restart scores the file, once
    assert len(history.record(second[0], persistence=2, source=("two", "two.csv"))) == 18
    assert _table(path, "SELECT COUNT(*) FROM scores") == [(36,)]
    history.close()


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """(folder, model file, feature table): two pumps, b drifting from hour 150."""
    folder = tmp_path_factory.mktemp("monitor_url")
    rng = np.random.default_rng(7)
    hours = np.arange(200.0)
    table = pd.concat(
        pd.DataFrame({
            "pump": pump, "hour": hours,
            "v/stats/RMS": 1 + 0.05 * rng.normal(size=200) + drift * (hours >= 150),
            "v/stats/Kurtosis": 3 + 0.1 * rng.normal(size=200),
        })
        for pump, drift in (("a", 0.0), ("b", 1.0))
    )  # fmt: skip
    table.to_csv(folder / "fleet.csv", index=False)
    healthy = table[table["hour"] < 100]  # what monitor fit --healthy-first 0.5 takes
    model = HealthModel(false_alarm_rate=0.05).fit(
        healthy[["v/stats/RMS", "v/stats/Kurtosis"]], groups=healthy["pump"]
    )
    save_model(model, folder / "model.pdmkit")
    return folder, str(folder / "model.pdmkit"), table


def _score_args(fitted, db: str, out: str) -> list[str]:
    folder, model, _ = fitted
    args = ["monitor", "score", "--model", model, "--features", str(folder / "fleet.csv")]
    args += ["--unit", "pump", "--time", "hour", "--db", db, "--quiet"]
    return [*args, "--json", str(folder / f"{out}.json"), "--out", str(folder / out)]


@needs_sqlalchemy
def test_the_cli_scores_into_a_url_end_to_end(fitted):
    folder, _, table = fitted
    url = f"sqlite:///{folder / 'cli.sqlite'}"
    assert main(_score_args(fitted, url, "s1")) == 0
    units = json.loads((folder / "s1.json").read_text())["units"]
    assert units["a"]["first_alarm"] is None
    assert 150 <= float(units["b"]["first_alarm"]) < 155  # the drift is 20 sigma
    assert main(_score_args(fitted, url, "s2")) == 0  # the same file: nothing added
    again = json.loads((folder / "s2.json").read_text())
    assert again["n_scored"] == 0 and again["units"] == units
    assert _table(folder / "cli.sqlite", "SELECT COUNT(*) FROM scores") == [(len(table),)]


def test_without_sqlalchemy_a_url_is_one_line_naming_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "sqlalchemy", None)  # as if not installed
    url = f"postgresql+psycopg://scada:{SECRET}@db.plant/history"
    with pytest.raises(MissingExtraError) as caught:
        HealthHistory(url)
    message = str(caught.value)
    assert message == (
        "the health history at postgresql+psycopg://scada:***@db.plant/history "
        "(a URL) needs sqlalchemy: pip install 'pdmkit[db]'"
    )
    # a plain path never imports SQLAlchemy: it works with it blocked
    with HealthHistory(tmp_path / "h.sqlite") as history:
        assert history.first_alarms() == {}


def test_a_urls_password_is_masked_and_a_path_stays_a_path(tmp_path):
    assert mask_url(f"postgresql://scada:{SECRET}@h:5432/db?sslmode=require") == (
        "postgresql://scada:***@h:5432/db?sslmode=require"
    )
    assert mask_url("mysql://u:p@ss/w@h/db") == "mysql://u:***@h/db"  # raw '@' and '/'
    for plain in ("postgresql://scada@h/db", "sqlite:///a@b/h.sqlite"):
        assert mask_url(plain) == plain
    assert db_target("sqlite:////var/h.sqlite") == "sqlite:////var/h.sqlite"
    assert db_target(str(tmp_path / "h.sqlite")) == tmp_path / "h.sqlite"


@needs_sqlalchemy
@pytest.mark.parametrize(
    ("url", "says"),
    [
        (f"nosuchdb://scada:{SECRET}@plant/history", "Can't load plugin"),
        (f"sqlite://scada:{SECRET}@/h.sqlite", "Invalid SQLite URL"),
        ("sqlite:////no/such/folder/h.sqlite", "unable to open"),
    ],
)
def test_a_bad_url_is_one_line_naming_it_without_its_password(url, says):
    with pytest.raises(DataError) as caught:
        HealthHistory(url)
    message = str(caught.value)
    assert mask_url(url) in message and says in message
    assert SECRET not in message and "\n" not in message
    assert caught.value.__cause__ is None and caught.value.__suppress_context__


@needs_sqlalchemy
def test_the_cli_error_of_a_bad_url_is_one_line_without_the_password(fitted, capsys):
    folder, _, _ = fitted
    url = f"nosuchdb://scada:{SECRET}@plant/history"
    assert main(_score_args(fitted, url, "bad")) == 2
    err = capsys.readouterr().err
    assert err.startswith("pdmkit: error: ") and len(err.strip().splitlines()) == 1
    assert "nosuchdb://scada:***@plant/history" in err and SECRET not in err
    written = [p for p in (folder / "bad").rglob("*") if p.is_file()]
    assert not any(SECRET in p.read_text(errors="replace") for p in written)
