"""Each asset's health history in an embedded SQLite database (or one named by a URL).

A plant scores recordings as they arrive; the history must survive crashes and
restarts and be readable by anyone with the ``sqlite3`` tool. Every scored file is
recorded by its SHA-256 in the *same transaction* as its rows, so a file is scored
exactly once: a crash before the commit leaves no trace of it, and a restart scores it
again; after the commit, it is skipped.

A plain path is an SQLite file (the standard library's ``sqlite3``); a database URL
(``sqlite:///h.sqlite``, ``postgresql+psycopg://user@host/db``) goes through
SQLAlchemy (``pdmkit[db]``) with the same schema, SQL and semantics
(:mod:`pdmkit.experiments._monitor_db` is the layer under both).

Schema (``docs/monitoring.md`` shows queries)::

    meta(key TEXT PRIMARY KEY, value TEXT)            -- schema version, model SHA-256
    sources(sha256 TEXT PRIMARY KEY, path TEXT, scored_at TEXT, n_rows INTEGER)
    scores(unit TEXT, time REAL, time_text TEXT, member TEXT, score REAL,
           health_index REAL, exceeds INTEGER, run_length INTEGER, alarm INTEGER,
           top_indicators TEXT, source_sha256 TEXT, PRIMARY KEY (unit, time, member))
    units(unit TEXT PRIMARY KEY, last_time REAL, run_length INTEGER, alarm INTEGER,
          first_alarm REAL, first_alarm_text TEXT)
    rul(unit TEXT, time REAL, time_text TEXT, rul REAL, lower REAL, upper REAL,
        level REAL, note TEXT, source_sha256 TEXT, PRIMARY KEY (unit, time))

``alarm`` latches once ``run_length`` (consecutive rows above the threshold) reaches
the model's persistence; it is computed row by row in time order per unit, carried
across batches by the ``units`` table, so scoring files one by one gives the history a
single batch of the same rows gives.

``rul`` holds, when an RUL model is attached (``pdmkit monitor score --rul``), each
unit's remaining useful life after every scored file that added rows to it: the
estimate at the unit's last time, its interval's bounds and level, in the RUL model's
time unit. It is written in the same transaction as the rows it follows. (A version-1
history from before this table gets it, empty, the first time it is opened.)
"""

from __future__ import annotations

import datetime as _dt
import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.experiments._monitor_db import SQLAlchemyURL, SQLiteFile, is_url, mask_url
from pdmkit.models.diagnosis import alarm_runs

__all__ = ["RUL_COLUMNS", "SCHEMA_VERSION", "HealthHistory"]

SCHEMA_VERSION = "1"

#: table -> its columns (name, kind: text, real or integer), in order
TABLES: dict[str, tuple[tuple[str, str], ...]] = {
    "meta": (("key", "text"), ("value", "text")),
    "sources": (
        ("sha256", "text"), ("path", "text"), ("scored_at", "text"),
        ("n_rows", "integer"),
    ),
    "scores": (
        ("unit", "text"), ("time", "real"), ("time_text", "text"), ("member", "text"),
        ("score", "real"), ("health_index", "real"), ("exceeds", "integer"),
        ("run_length", "integer"), ("alarm", "integer"), ("top_indicators", "text"),
        ("source_sha256", "text"),
    ),
    "units": (
        ("unit", "text"), ("last_time", "real"), ("run_length", "integer"),
        ("alarm", "integer"), ("first_alarm", "real"), ("first_alarm_text", "text"),
    ),
    "rul": (
        ("unit", "text"), ("time", "real"), ("time_text", "text"), ("rul", "real"),
        ("lower", "real"), ("upper", "real"), ("level", "real"), ("note", "text"),
        ("source_sha256", "text"),
    ),
}  # fmt: skip
#: table -> its primary key
KEYS = {
    "meta": ("key",),
    "sources": ("sha256",),
    "scores": ("unit", "time", "member"),
    "units": ("unit",),
    "rul": ("unit", "time"),
}
#: columns of :meth:`HealthHistory.rul_history` (the ``rul`` table less its source)
RUL_COLUMNS = tuple(name for name, _ in TABLES["rul"] if name != "source_sha256")
#: the state a unit carries from batch to batch (``units`` less its key)
_STATE = ("last_time", "run_length", "alarm", "first_alarm", "first_alarm_text")

#: columns a batch handed to :meth:`HealthHistory.record` must have
ROW_COLUMNS = ("unit", "time", "member", "score", "health_index", "exceeds")


class HealthHistory:
    """The health history of a fleet in one SQLite file, or a database by URL.

    Parameters
    ----------
    path : path or str
        The database file (created with its schema when missing), or a SQLAlchemy
        database URL (a string with ``://``; needs ``pdmkit[db]``): the same tables
        are created there when missing.
    model_sha256 : str, optional
        The health model's file hash: a database started with one model refuses
        rows scored by another (their thresholds differ), naming both.
    read_only : bool, default False
        Only read (a viewer): a missing file is an error instead of a new history,
        no table is created and nothing is written.

    Attributes
    ----------
    name : str
        The file, or the URL with its password masked: what messages print.
    path : pathlib.Path or None
        The file (None for a URL).

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

    def __init__(
        self,
        path: str | os.PathLike,
        model_sha256: str | None = None,
        *,
        read_only: bool = False,
    ) -> None:
        url = is_url(path)
        backend = SQLAlchemyURL if url else SQLiteFile
        self.path = None if url else Path(path)
        self.name = mask_url(str(path)) if url else str(path)
        self.read_only = read_only
        if read_only and not url and not Path(path).is_file():
            raise DataError(f"{self.name}: no such health history file")
        try:
            self._db = backend(path, read_only=read_only)
            self.name = self._db.name
            self._has_rul = True
            if read_only:
                self._check_meta(None, write=False)
                self._has_rul = self._table_exists("rul")  # not in an older history
            else:
                self._db.create(TABLES, KEYS)
                with self._db.transaction():
                    self._check_meta(model_sha256)
        except backend.errors as exc:
            raise DataError(
                f"{self.name} is not a pdmkit health history ({backend.said} said: {exc})"
            ) from None

    def _check_meta(self, model_sha256: str | None, write: bool = True) -> None:
        """Refuse another schema version or model; record ours where absent."""
        meta = dict(self._db.query(self._db.sql("SELECT {key}, {value} FROM {meta}"))[1])
        version = meta.get("schema_version")
        if version is not None and version != SCHEMA_VERSION:
            raise DataError(
                f"{self.name} holds schema version {version}; this pdmkit writes "
                f"{SCHEMA_VERSION}"
            )
        known = meta.get("model_sha256")
        if known and model_sha256 and known != model_sha256:
            raise DataError(
                f"{self.name} holds scores of the model {known[:12]}...; this model is "
                f"{model_sha256[:12]}...: start another --db for another model"
            )
        if not write:
            return
        mine = {"schema_version": SCHEMA_VERSION, "model_sha256": model_sha256}
        new = [{"key": k, "value": v} for k, v in mine.items() if v and k not in meta]
        self._db.execute(self._insert("meta"), new)

    def _table_exists(self, table: str) -> bool:
        try:
            self._db.query(self._db.sql(f"SELECT 1 FROM {{{table}}} WHERE 1 = 0"))
        except (DataError, *type(self._db).errors):
            return False
        return True

    def _insert(self, table: str) -> str:
        """``INSERT INTO table (every column) VALUES (:every column)``."""
        names = [name for name, _ in TABLES[table]]
        columns = ", ".join("{" + name + "}" for name in names)
        values = ", ".join(":" + name for name in names)
        return self._db.sql(f"INSERT INTO {{{table}}} ({columns}) VALUES ({values})")

    def close(self) -> None:
        """Close the connection (the database stays as committed)."""
        self._db.close()

    def __enter__(self) -> HealthHistory:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def seen(self, sha256: str) -> bool:
        """Whether a file with this hash has been scored (and committed)."""
        sql = self._db.sql("SELECT {sha256} FROM {sources} WHERE {sha256} = :sha256")
        return bool(self._db.query(sql, {"sha256": sha256})[1])

    def record(
        self,
        rows: pd.DataFrame,
        *,
        persistence: int,
        source: tuple[str, str] | None = None,
        top_indicators: Iterable[Any] | None = None,
        rul: pd.DataFrame | None = None,
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
        rul : pandas.DataFrame, optional
            The RUL model's answers after these rows, one per unit: columns
            :data:`RUL_COLUMNS` (``time`` the unit's last time); recorded in the same
            transaction.

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
        with self._db.transaction():
            if source is not None and self.seen(source[0]):
                return None
            out = [self._record_unit(str(u), part, persistence, source) for u, part in
                   rows.groupby("unit", sort=False)]  # fmt: skip
            if rul is not None and len(rul):
                self._record_rul(rul, source)
            if source is not None:
                now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
                self._db.execute(
                    self._insert("sources"),
                    {"sha256": source[0], "path": str(source[1]), "scored_at": now,
                     "n_rows": len(rows)},
                )  # fmt: skip
        return (
            pd.concat(out).drop(columns="top_json")
            if out
            else rows.drop(columns="top_json")
        )

    def _record_unit(self, unit: str, part: pd.DataFrame, persistence: int, source):
        columns = ", ".join("{" + name + "}" for name in _STATE)
        state = self._db.query(
            self._db.sql(f"SELECT {columns} FROM {{units}} WHERE {{unit}} = :unit"),
            {"unit": unit},
        )[1]
        last, run, alarm, first, first_text = (
            state[0] if state else (-np.inf, 0, 0, None, None)
        )
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
        part = part.assign(run_length=runs, alarm=alarms)
        self._db.execute(
            self._insert("scores"),
            [
                {
                    "unit": unit,
                    "time": float(r.time),
                    "time_text": str(text),
                    "member": str(r.member),
                    "score": float(r.score),
                    "health_index": float(r.health_index),
                    "exceeds": int(bool(r.exceeds)),
                    "run_length": int(r.run_length),
                    "alarm": int(r.alarm),
                    "top_indicators": None
                    if r.top_json is None
                    else json.dumps(r.top_json),
                    "source_sha256": None if source is None else source[0],
                }
                for r, text in zip(part.itertuples(), texts, strict=True)
            ],
        )
        carried = dict(zip(_STATE, (float(times[-1]), int(runs[-1]), int(alarms[-1]),
                                    first, first_text), strict=True))  # fmt: skip
        if state:  # check, then update or insert: portable where REPLACE is not
            assign = ", ".join(f"{{{name}}} = :{name}" for name in _STATE)
            update = f"UPDATE {{units}} SET {assign} WHERE {{unit}} = :unit"
            self._db.execute(self._db.sql(update), {"unit": unit, **carried})
        else:
            self._db.execute(self._insert("units"), {"unit": unit, **carried})
        return part

    def _record_rul(self, rul: pd.DataFrame, source) -> None:
        missing = [c for c in RUL_COLUMNS if c not in rul.columns]
        if missing:
            raise DataError(f"RUL rows to record lack the columns {missing}")

        def number(v):
            return None if v is None or not np.isfinite(float(v)) else float(v)

        self._db.execute(
            self._insert("rul"),
            [
                {"unit": str(r.unit), "time": float(r.time), "time_text": str(r.time_text),
                 "rul": number(r.rul), "lower": number(r.lower), "upper": number(r.upper),
                 "level": number(r.level), "note": str(r.note or ""),
                 "source_sha256": None if source is None else source[0]}
                for r in rul.itertuples()
            ],
        )  # fmt: skip

    def rul_history(self, unit: str | None = None) -> pd.DataFrame:
        """Each unit's RUL after every scored file (empty when no RUL model was attached).

        Returns
        -------
        pandas.DataFrame
            Columns :data:`RUL_COLUMNS`, per unit in time order; a missing bound
            (an interval open at that side) is NaN.

        Examples
        --------
        >>> import tempfile, pathlib
        >>> db = HealthHistory(pathlib.Path(tempfile.mkdtemp()) / "h.sqlite")
        >>> db.rul_history().columns.tolist()
        ['unit', 'time', 'time_text', 'rul', 'lower', 'upper', 'level', 'note']
        """
        where, args = ("", {}) if unit is None else (" WHERE {unit} = :unit",
                                                     {"unit": str(unit)})  # fmt: skip
        if not self._has_rul:
            return pd.DataFrame({c: [] for c in RUL_COLUMNS})
        names = ", ".join("{" + c + "}" for c in RUL_COLUMNS)
        sql = self._db.sql(f"SELECT {names} FROM {{rul}}" + where +
                           " ORDER BY {unit}, {time}")  # fmt: skip
        columns, rows = self._db.query(sql, args)
        frame = pd.DataFrame.from_records(rows, columns=columns, coerce_float=True)
        for col in ("time", "rul", "lower", "upper", "level"):
            frame[col] = pd.to_numeric(frame[col]).astype(float)
        return frame

    def history(self, unit: str | None = None) -> pd.DataFrame:
        """The scored rows, per unit in time order (one unit, or all).

        Examples
        --------
        See :class:`HealthHistory`.
        """
        where, args = ("", {}) if unit is None else (" WHERE {unit} = :unit",
                                                     {"unit": str(unit)})  # fmt: skip
        sql = self._db.sql("SELECT * FROM {scores}" + where +
                           " ORDER BY {unit}, {time}, {member}")  # fmt: skip
        columns, rows = self._db.query(sql, args)
        frame = pd.DataFrame.from_records(rows, columns=columns, coerce_float=True)
        for col in ("exceeds", "alarm"):
            frame[col] = frame[col].astype(bool)
        return frame

    def key_rows(self, unit: str) -> tuple[int, pd.DataFrame]:
        """A unit's row count and its key rows: the first alarmed row and the last.

        Three indexed queries instead of the unit's whole history: what an alarm
        table needs of a unit (:func:`~pdmkit.experiments._monitor_report.alarm_table`
        reads no other row), in :meth:`history`'s order and columns (one row when
        the first alarm is the last row or the unit never alarmed).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> db = HealthHistory(pathlib.Path(tempfile.mkdtemp()) / "h.sqlite")
        >>> _ = db.record(pd.DataFrame({"unit": "p1", "time": [1.0, 2.0, 3.0, 4.0],
        ...     "member": "m", "score": 0.0, "health_index": [0.9, 0.2, 0.1, 0.3],
        ...     "exceeds": [False, True, True, True]}), persistence=1)
        >>> n, rows = db.key_rows("p1")
        >>> n, rows["time"].tolist(), rows["alarm"].tolist()
        (4, [2.0, 4.0], [True, True])
        """
        args = {"unit": str(unit)}
        count = self._db.sql("SELECT COUNT(*) FROM {scores} WHERE {unit} = :unit")
        n = int(self._db.query(count, args)[1][0][0])
        parts = []
        for condition, order in (
            (" AND {alarm} = 1", "{time}, {member}"),
            ("", "{time} DESC, {member} DESC"),
        ):
            sql = self._db.sql("SELECT * FROM {scores} WHERE {unit} = :unit" + condition
                               + " ORDER BY " + order + " LIMIT 1")  # fmt: skip
            cols, found = self._db.query(sql, args)
            parts.append(pd.DataFrame.from_records(found, columns=cols, coerce_float=True))
        frame = pd.concat([p for p in parts if len(p)] or parts[:1], ignore_index=True)
        frame = frame.drop_duplicates(["time", "member"]).reset_index(drop=True)
        for col in ("exceeds", "alarm"):
            frame[col] = frame[col].astype(bool)
        return n, frame

    def first_alarms(self, text: bool = False) -> dict:
        """Unit -> the time of its first alarm (None when it never alarmed).

        ``text=True`` gives the time as the user's table wrote it.

        Examples
        --------
        See :class:`HealthHistory`.
        """
        col = "{first_alarm_text}" if text else "{first_alarm}"
        sql = self._db.sql("SELECT {unit}, " + col + " FROM {units} ORDER BY {unit}")
        return dict(self._db.query(sql)[1])
