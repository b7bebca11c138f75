"""Each asset's health history in an embedded SQLite database.

A plant scores recordings as they arrive; the history must survive crashes and
restarts and be readable by anyone with the ``sqlite3`` tool. Every scored file is
recorded by its SHA-256 in the *same transaction* as its rows, so a file is scored
exactly once: a crash before the commit leaves no trace of it, and a restart scores it
again; after the commit, it is skipped.

Schema (``docs/monitoring.md`` shows queries)::

    meta(key TEXT PRIMARY KEY, value TEXT)            -- schema version, model SHA-256
    sources(sha256 TEXT PRIMARY KEY, path TEXT, scored_at TEXT, n_rows INTEGER)
    scores(unit TEXT, time REAL, time_text TEXT, member TEXT, score REAL,
           health_index REAL, exceeds INTEGER, run_length INTEGER, alarm INTEGER,
           top_indicators TEXT, source_sha256 TEXT, PRIMARY KEY (unit, time, member))
    units(unit TEXT PRIMARY KEY, last_time REAL, run_length INTEGER, alarm INTEGER,
          first_alarm REAL, first_alarm_text TEXT)

``alarm`` latches once ``run_length`` (consecutive rows above the threshold) reaches
the model's persistence; it is computed row by row in time order per unit, carried
across batches by the ``units`` table, so scoring files one by one gives the history a
single batch of the same rows gives.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
import sqlite3
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.models.diagnosis import alarm_runs

__all__ = ["SCHEMA_VERSION", "HealthHistory"]

SCHEMA_VERSION = "1"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS sources (
    sha256 TEXT PRIMARY KEY, path TEXT, scored_at TEXT, n_rows INTEGER);
CREATE TABLE IF NOT EXISTS scores (
    unit TEXT NOT NULL, time REAL NOT NULL, time_text TEXT, member TEXT NOT NULL,
    score REAL, health_index REAL, exceeds INTEGER, run_length INTEGER,
    alarm INTEGER, top_indicators TEXT, source_sha256 TEXT,
    PRIMARY KEY (unit, time, member));
CREATE TABLE IF NOT EXISTS units (
    unit TEXT PRIMARY KEY, last_time REAL, run_length INTEGER, alarm INTEGER,
    first_alarm REAL, first_alarm_text TEXT);
"""

#: columns a batch handed to :meth:`HealthHistory.record` must have
ROW_COLUMNS = ("unit", "time", "member", "score", "health_index", "exceeds")


class HealthHistory:
    """The health history of a fleet in one SQLite file.

    Parameters
    ----------
    path : path
        The database file (created with its schema when missing).
    model_sha256 : str, optional
        The health model's file hash: a database started with one model refuses
        rows scored by another (their thresholds differ), naming both.

    Examples
    --------
    >>> import tempfile, pathlib, pandas as pd
    >>> db = HealthHistory(pathlib.Path(tempfile.mkdtemp()) / "h.sqlite")
    >>> rows = pd.DataFrame({"unit": "pump1", "time": [1.0, 2.0, 3.0],
    ...                      "member": ["a", "b", "c"], "score": [0.1, 2.0, 3.0],
    ...                      "health_index": [0.9, 0.3, 0.2],
    ...                      "exceeds": [False, True, True]})
    >>> db.record(rows, persistence=2, source=("file1", "a.csv"))["alarm"].tolist()
    [False, False, True]
    >>> db.record(rows, persistence=2, source=("file1", "a.csv")) is None  # seen
    True
    >>> db.first_alarms()
    {'pump1': 3.0}
    """

    def __init__(self, path: str | os.PathLike, model_sha256: str | None = None) -> None:
        self.path = Path(path)
        try:
            self._db = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
            self._db.executescript(_SCHEMA)
            meta = dict(self._db.execute("SELECT key, value FROM meta").fetchall())
        except sqlite3.DatabaseError as exc:
            raise DataError(
                f"{self.path} is not a pdmkit health history (SQLite said: {exc})"
            ) from None
        version = meta.get("schema_version")
        if version is not None and version != SCHEMA_VERSION:
            raise DataError(
                f"{self.path} holds schema version {version}; this pdmkit writes "
                f"{SCHEMA_VERSION}"
            )
        known = meta.get("model_sha256")
        if known and model_sha256 and known != model_sha256:
            raise DataError(
                f"{self.path} holds scores of the model {known[:12]}...; this model is "
                f"{model_sha256[:12]}...: start another --db for another model"
            )
        with self._transaction():
            self._db.execute(
                "INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,)
            )
            if model_sha256:
                self._db.execute(
                    "INSERT OR IGNORE INTO meta VALUES ('model_sha256', ?)", (model_sha256,)
                )

    def close(self) -> None:
        """Close the connection (the file stays as committed)."""
        self._db.close()

    def __enter__(self) -> HealthHistory:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @contextlib.contextmanager
    def _transaction(self):
        """One IMMEDIATE transaction: committed when the block ends, else rolled back."""
        self._db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    def seen(self, sha256: str) -> bool:
        """Whether a file with this hash has been scored (and committed)."""
        row = self._db.execute("SELECT 1 FROM sources WHERE sha256 = ?", (sha256,))
        return row.fetchone() is not None

    def record(
        self,
        rows: pd.DataFrame,
        *,
        persistence: int,
        source: tuple[str, str] | None = None,
        top_indicators: Iterable[Any] | None = None,
    ) -> pd.DataFrame | None:
        """Add scored rows (one transaction); return them with ``run_length``, ``alarm``.

        Parameters
        ----------
        rows : pandas.DataFrame
            Columns :data:`ROW_COLUMNS` (``time`` numeric; ``time_text`` optional,
            the time as the user's table writes it).
        persistence : int
            Consecutive rows above the threshold that raise the alarm.
        source : (sha256, path), optional
            The file the rows come from: recorded with them; a file already recorded
            returns None and adds nothing.
        top_indicators : iterable, optional
            Per row, what drove its score (stored as JSON).

        Returns
        -------
        pandas.DataFrame or None
        """
        missing = [c for c in ROW_COLUMNS if c not in rows.columns]
        if missing:
            raise DataError(f"rows to record lack the columns {missing}")
        rows = rows.assign(
            top_json=list(top_indicators) if top_indicators is not None else None
        )
        rows = rows.sort_values(["unit", "time"], kind="stable").reset_index(drop=True)
        with self._transaction():
            if source is not None and self.seen(source[0]):
                return None
            out = [self._record_unit(str(u), part, persistence, source) for u, part in
                   rows.groupby("unit", sort=False)]  # fmt: skip
            if source is not None:
                now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
                self._db.execute(
                    "INSERT INTO sources VALUES (?, ?, ?, ?)",
                    (source[0], str(source[1]), now, len(rows)),
                )
        return (
            pd.concat(out).drop(columns="top_json")
            if out
            else rows.drop(columns="top_json")
        )

    def _record_unit(self, unit: str, part: pd.DataFrame, persistence: int, source):
        state = self._db.execute(
            "SELECT last_time, run_length, alarm, first_alarm, first_alarm_text "
            "FROM units WHERE unit = ?",
            (unit,),
        ).fetchone()
        last, run, alarm, first, first_text = state or (-np.inf, 0, 0, None, None)
        times = part["time"].to_numpy(dtype=float)
        if times[0] <= last:
            raise DataError(
                f"unit {unit!r}: a row at time {times[0]:g} is not after the last one "
                f"scored ({last:g}); rows are added in time order, each once"
            )
        texts = part["time_text"] if "time_text" in part.columns else part["time"]
        exceeds = part["exceeds"].to_numpy(dtype=bool)
        alarms, runs = alarm_runs(exceeds, persistence, run_length=run, alarm=bool(alarm))
        if alarms.any() and not alarm:
            k = int(np.argmax(alarms))
            first, first_text = float(times[k]), str(np.asarray(texts)[k])
        run, alarm = int(runs[-1]), int(alarms[-1])
        part = part.assign(run_length=runs, alarm=alarms)
        self._db.executemany(
            "INSERT INTO scores VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            [
                (
                    unit,
                    float(r.time),
                    str(text),
                    str(r.member),
                    float(r.score),
                    float(r.health_index),
                    int(bool(r.exceeds)),
                    int(r.run_length),
                    int(r.alarm),
                    None if r.top_json is None else json.dumps(r.top_json),
                    None if source is None else source[0],
                )
                for r, text in zip(part.itertuples(), texts, strict=True)
            ],
        )
        self._db.execute(
            "INSERT OR REPLACE INTO units VALUES (?, ?, ?, ?, ?, ?)",
            (unit, float(times[-1]), int(run), int(alarm), first, first_text),
        )
        return part

    def history(self, unit: str | None = None) -> pd.DataFrame:
        """The scored rows, per unit in time order (one unit, or all).

        Examples
        --------
        See :class:`HealthHistory`.
        """
        query = "SELECT * FROM scores"
        args: tuple = ()
        if unit is not None:
            query, args = query + " WHERE unit = ?", (str(unit),)
        frame = pd.read_sql_query(query + " ORDER BY unit, time, member", self._db,
                                  params=args)  # fmt: skip
        for col in ("exceeds", "alarm"):
            frame[col] = frame[col].astype(bool)
        return frame

    def first_alarms(self, text: bool = False) -> dict:
        """Unit -> the time of its first alarm (None when it never alarmed).

        ``text=True`` gives the time as the user's table wrote it.

        Examples
        --------
        See :class:`HealthHistory`.
        """
        col = "first_alarm_text" if text else "first_alarm"
        rows = self._db.execute(f"SELECT unit, {col} FROM units ORDER BY unit")
        return {u: v for u, v in rows.fetchall()}
