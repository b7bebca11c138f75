"""The History page's data: a fleet's monitoring history, read without writing to it.

``pdmkit designer --history PATH|URL`` shows the health history that ``pdmkit monitor
score`` and ``watch`` keep (:class:`~pdmkit.experiments.HealthHistory`): the alarm
table (:func:`~pdmkit.experiments._monitor_report.alarm_table`, one row per unit,
alarmed units first), and per unit its health index over time and, when an RUL model
was attached, its remaining useful life with the interval.

The history is opened read-only for each request and closed at once (SQLite's
``mode=ro``: the file is never created, written or locked beyond one read), so a
running ``monitor watch`` keeps writing while the page reads. The alarm table is kept
until the file (or its journal) changes. A unit's chart gets at most
:data:`MAX_POINTS` points: min/max decimation of the health index
(:func:`~pdmkit.experiments.designer._views.minmax_decimate`) plus every row where the
alarm rises or clears, and the first and last rows.
"""

from __future__ import annotations

import json
import os
import threading
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.experiments._monitor_report import _axis_times, alarm_table
from pdmkit.experiments.designer._views import minmax_decimate

__all__ = [
    "MAX_POINTS",
    "MAX_RUL_POINTS",
    "MAX_UNITS",
    "HistorySource",
    "chart_indices",
    "fleet_alarm_table",
    "rul_series",
    "unit_series",
    "units_page",
]

#: most points of one unit's health-index chart
MAX_POINTS = 2000
#: most points of one unit's RUL chart
MAX_RUL_POINTS = 500
#: most rows of the alarm table sent at once
MAX_UNITS = 500
#: the health index at the alarm threshold
THRESHOLD = 0.5


def _plain(value: Any) -> Any:
    """A JSON value: numpy scalars as Python's, NaN as None."""
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _records(frame: pd.DataFrame) -> list[dict]:
    return [{str(k): _plain(v) for k, v in r.items()} for r in frame.to_dict("records")]


def fleet_alarm_table(history: HealthHistory) -> pd.DataFrame:
    """``alarm_table(history.history())``, read one unit at a time.

    Of each unit only its row count, its first alarmed row and its last row are read
    (:meth:`HealthHistory.key_rows`: all that
    :func:`~pdmkit.experiments._monitor_report.alarm_table` reads of them), not its
    history: a million rows read at once take about 1 GB. The ``rows`` column is
    then set to the units' row counts.

    Examples
    --------
    >>> import tempfile, pathlib, pandas as pd
    >>> h = HealthHistory(pathlib.Path(tempfile.mkdtemp()) / "h.sqlite")
    >>> for unit, hi in (("b", [0.9, 0.2, 0.1, 0.8]), ("a", [0.9, 0.8, 0.9, 0.7])):
    ...     _ = h.record(pd.DataFrame({"unit": unit, "time": [1.0, 2.0, 3.0, 4.0],
    ...         "member": "m", "score": 0.0, "health_index": hi,
    ...         "exceeds": [x < 0.5 for x in hi]}), persistence=2)
    >>> fleet_alarm_table(h).equals(alarm_table(h.history()))
    True
    """
    kept, counts = [], {}
    for unit in history.first_alarms():
        n, part = history.key_rows(unit)
        if n == 0:
            continue
        counts[str(unit)] = n
        kept.append(part)
    if not kept:
        return alarm_table(history.history())
    table = alarm_table(pd.concat(kept, ignore_index=True))
    table["rows"] = table["unit"].map(counts).astype(np.int64)
    return table


class HistorySource:
    """A monitoring history the page reads: an SQLite file or a database URL.

    Parameters
    ----------
    location : path or str
        As ``pdmkit monitor score --db`` takes it. Opened once here to check it (a
        missing file or one that is not a health history is a one-line
        :class:`~pdmkit.errors.DataError` naming it), then again for each read.

    Examples
    --------
    >>> import tempfile, pathlib, pandas as pd
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "h.sqlite"
    >>> with HealthHistory(path) as h:
    ...     _ = h.record(pd.DataFrame({"unit": "p1", "time": [1.0, 2.0], "member": "m",
    ...         "score": [0.1, 3.0], "health_index": [0.9, 0.2],
    ...         "exceeds": [False, True]}), persistence=1)
    >>> source = HistorySource(path)
    >>> source.alarm_table()[["unit", "first_alarm"]].values.tolist()
    [['p1', '2.0']]
    >>> HistorySource(path.with_name("none.sqlite"))
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: ...none.sqlite: no such health history file
    """

    def __init__(self, location: str | os.PathLike) -> None:
        self.location = str(location)
        if self.location.startswith("sqlite:///"):  # SQLite would create it
            file = self.location[len("sqlite:///") :].split("?")[0]
            if not os.path.isfile(file):
                raise DataError(f"{self.location}: no such health history file")
        with self.open() as history:
            self.name = history.name
            self.is_file = history.path is not None
        self._lock = threading.Lock()
        self._cached: tuple[Any, pd.DataFrame, dict] | None = None

    def open(self) -> HealthHistory:
        """The history, read-only (close it when done)."""
        return HealthHistory(self.location, read_only=True)

    def _signature(self) -> tuple | None:
        """Size and mtime of the file and its journals (None for a URL: always read)."""
        if not self.is_file:
            return None
        out = []
        for suffix in ("", "-wal", "-journal"):
            try:
                st = os.stat(self.location + suffix)
            except FileNotFoundError:
                out.append(None)
                continue
            out.append((st.st_mtime_ns, st.st_size))
        if out[0] is None:
            raise DataError(f"{self.name}: no such health history file")
        return tuple(out)

    def _read(self) -> tuple[pd.DataFrame, dict]:
        signature = self._signature()
        with self._lock:
            if signature is not None and self._cached and self._cached[0] == signature:
                return self._cached[1], self._cached[2]
        with self.open() as history:
            table = fleet_alarm_table(history)
            rul = history.rul_history()
        last_rul = {
            str(unit): {k: _plain(part[k].iloc[-1]) for k in ("rul", "lower", "upper")}
            for unit, part in rul.groupby("unit", sort=True)
        }
        with self._lock:
            self._cached = (signature, table, last_rul)
        return table, last_rul

    def alarm_table(self) -> pd.DataFrame:
        """:func:`~pdmkit.experiments._monitor_report.alarm_table` of the history."""
        return self._read()[0]

    def units(self, **query: Any) -> dict:
        """A page of the alarm table (see :func:`units_page`), read now."""
        table, last_rul = self._read()
        return {"history": self.name, **units_page(table, last_rul=last_rul, **query)}

    def unit(self, unit: str, points: int = MAX_POINTS) -> dict:
        """One unit's health-index series and RUL series (see :func:`unit_series`).

        ``points`` is kept between 10 and :data:`MAX_POINTS`.
        """
        points = min(MAX_POINTS, max(10, int(points)))
        with self.open() as history:
            frame = history.history(unit)
            rul = history.rul_history(unit)
        if frame.empty:
            raise DataError(f"no unit {unit!r} in the history {self.name}")
        out = unit_series(frame, points)
        out["rul"] = rul_series(rul) if len(rul) else None
        return out


def units_page(
    table: pd.DataFrame,
    offset: int = 0,
    limit: int = 100,
    alarmed_only: bool = False,
    contains: str = "",
    last_rul: dict | None = None,
) -> dict:
    """Rows ``offset`` to ``offset + limit`` of the alarm table, optionally filtered.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`~pdmkit.experiments._monitor_report.alarm_table`'s (kept in its order:
        alarmed units first, earliest alarm first).
    offset, limit : int
        The page (``limit`` at most :data:`MAX_UNITS`).
    alarmed_only : bool
        Only the units that alarmed.
    contains : str
        Only the units whose name contains this text (any case).
    last_rul : dict, optional
        Unit -> its last RUL (``rul``, ``lower``, ``upper``); sent for the page's units.

    Returns
    -------
    dict
        ``total`` (units after the filter), ``n_units``, ``n_alarmed``, ``offset``,
        ``columns``, ``rows`` (records of the table), ``last_rul``.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"unit": ["b", "a", "c"], "first_alarm": ["5", "", ""]})
    >>> page = units_page(t, offset=1, limit=1)
    >>> page["total"], page["n_alarmed"], [r["unit"] for r in page["rows"]]
    (3, 1, ['a'])
    >>> units_page(t, alarmed_only=True)["total"]
    1
    """
    offset = max(0, int(offset))
    limit = min(MAX_UNITS, max(1, int(limit)))
    n_units = len(table)
    if not n_units:  # a history with no rows yet
        table = pd.DataFrame({"unit": [], "first_alarm": []}, dtype=str)
    alarmed = table["first_alarm"] != ""
    keep = pd.Series(True, index=table.index)
    if alarmed_only:
        keep &= alarmed
    if contains:
        keep &= table["unit"].str.contains(contains, case=False, regex=False)
    shown = table[keep]
    page = shown.iloc[offset : offset + limit]
    units = set(page["unit"])
    return {
        "total": len(shown),
        "n_units": n_units,
        "n_alarmed": int(alarmed.sum()),
        "offset": offset,
        "columns": [str(c) for c in table.columns],
        "rows": _records(page),
        "last_rul": {u: v for u, v in (last_rul or {}).items() if u in units},
    }


def chart_indices(
    health_index: np.ndarray, alarm: np.ndarray, points: int = MAX_POINTS
) -> np.ndarray:
    """The rows a chart keeps: at most ``points``, every alarm change, first and last.

    The alarm changes (the row before and the row at each rise or clear) and the
    first and last rows are kept (up to a quarter of ``points``); the rest of the
    budget goes to min/max decimation of the health index, so dips survive.

    Examples
    --------
    >>> import numpy as np
    >>> hi = np.linspace(1, 0, 100_000); alarm = hi < 0.5
    >>> keep = chart_indices(hi, alarm, points=100)
    >>> len(keep) <= 100, int(np.argmax(alarm)) in keep, keep[0], keep[-1]
    (True, True, np.int64(0), np.int64(99999))
    """
    n = len(health_index)
    if n <= points:
        return np.arange(n)
    alarm = np.asarray(alarm, dtype=bool)
    changes = np.flatnonzero(alarm[1:] != alarm[:-1]) + 1
    must = np.unique(np.concatenate([[0, n - 1], changes, changes - 1]))
    if len(must) > points // 4:  # a flickering alarm: its first changes
        must = np.unique(np.concatenate([[0, n - 1], must[: points // 4 - 2]]))
    positions, _ = minmax_decimate(
        np.arange(n, dtype=float), np.asarray(health_index, float), points - len(must)
    )
    return np.unique(np.concatenate([must, positions.astype(np.int64)]))


def _axis(frame: pd.DataFrame) -> tuple[list, str, str]:
    """(x values, ``"date"`` or ``"number"``, axis title) of a history's rows.

    Timestamps (the user's table wrote ``time_text`` as dates) come as text Plotly
    reads as dates, in the wall time the table wrote; numbers as numbers.
    """
    times, label = _axis_times(frame)
    if label == "time" and pd.api.types.is_datetime64_any_dtype(times):
        text = times.dt.strftime("%Y-%m-%d %H:%M:%S.%f").str.replace(
            r"\.?0+$", "", regex=True
        )
        return text.tolist(), "date", "time"
    return [_plain(v) for v in frame["time"].to_numpy(float)], "number", label


def _drivers(top: Any) -> str:
    if not isinstance(top, str) or not top:
        return ""
    try:
        return ", ".join(str(name) for name in json.loads(top))
    except ValueError:
        return top


def unit_series(frame: pd.DataFrame, points: int = MAX_POINTS) -> dict:
    """One unit's health index over time, decimated to at most ``points`` points.

    Parameters
    ----------
    frame : pandas.DataFrame
        ``HealthHistory.history(unit)``: one unit's rows in time order.
    points : int
        Most points sent (see :func:`chart_indices`).

    Returns
    -------
    dict
        ``unit``, ``n_rows``, ``n_points``, ``decimated``, ``x_kind`` (``"date"`` or
        ``"number"``), ``x_label``, per kept row ``x``, ``time_text``,
        ``health_index``, ``score``, ``alarm``, ``drivers``; ``first_alarm`` (``x``,
        ``time_text``, ``health_index``, ``drivers`` of the first alarmed row, or
        None), ``x_end`` (the last row's x), ``threshold`` (0.5).

    Examples
    --------
    >>> import pandas as pd
    >>> f = pd.DataFrame({"unit": "p", "time": [0.0, 1.0, 2.0],
    ...     "time_text": ["2026-01-01", "2026-01-02", "2026-01-03"],
    ...     "score": [0.1, 3.0, 4.0], "health_index": [0.9, 0.3, 0.2],
    ...     "alarm": [False, False, True], "top_indicators": [None, None, '["v"]']})
    >>> s = unit_series(f)
    >>> s["x_kind"], s["first_alarm"]["x"], s["first_alarm"]["drivers"]
    ('date', '2026-01-03 00:00:00', 'v')
    """
    if frame.empty:
        raise DataError("the unit has no rows in the history")
    frame = frame.reset_index(drop=True)
    alarm = frame["alarm"].to_numpy(dtype=bool)
    keep = chart_indices(frame["health_index"].to_numpy(float), alarm, points)
    x, kind, label = _axis(frame)
    first = int(np.argmax(alarm)) if alarm.any() else None
    rows = frame.iloc[keep]
    drivers = [_drivers(v) for v in rows["top_indicators"]]
    return {
        "unit": str(frame["unit"].iloc[0]),
        "n_rows": len(frame),
        "n_points": len(keep),
        "decimated": len(keep) < len(frame),
        "x_kind": kind,
        "x_label": label,
        "x": [x[k] for k in keep],
        "time_text": rows["time_text"].astype(str).tolist(),
        "health_index": [_plain(v) for v in rows["health_index"].to_numpy(float)],
        "score": [_plain(v) for v in rows["score"].to_numpy(float)],
        "alarm": alarm[keep].tolist(),
        "drivers": drivers,
        "first_alarm": None
        if first is None
        else {
            "x": x[first],
            "time_text": str(frame["time_text"].iloc[first]),
            "health_index": _plain(frame["health_index"].iloc[first]),
            "drivers": _drivers(frame["top_indicators"].iloc[first]),
        },
        "x_end": x[-1],
        "threshold": THRESHOLD,
    }


def rul_series(frame: pd.DataFrame, points: int = MAX_RUL_POINTS) -> dict:
    """One unit's RUL estimates over time with their interval (at most ``points``).

    Parameters
    ----------
    frame : pandas.DataFrame
        ``HealthHistory.rul_history(unit)``.
    points : int
        Most points sent (evenly spaced rows, the last one always).

    Returns
    -------
    dict
        ``n_rows``, ``x_kind``, ``x_label``, per kept row ``x``, ``time_text``,
        ``rul``, ``lower``, ``upper`` (None where the interval is open at that side),
        ``level``, ``note``.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> f = pd.DataFrame({"unit": "p", "time": [1.0, 2.0], "time_text": ["1", "2"],
    ...     "rul": [9.0, 8.0], "lower": [np.nan, 6.0], "upper": [12.0, 10.0],
    ...     "level": 0.9, "note": ""})
    >>> s = rul_series(f)
    >>> s["x"], s["lower"], s["upper"]
    ([1.0, 2.0], [None, 6.0], [12.0, 10.0])
    """
    frame = frame.reset_index(drop=True)
    n = len(frame)
    keep = np.arange(n)
    if n > points:
        keep = np.unique(np.linspace(0, n - 1, points).round().astype(np.int64))
    x, kind, label = _axis(frame)
    rows = frame.iloc[keep]

    def numbers(column: str) -> list:
        return [_plain(v) for v in rows[column].to_numpy(float)]

    return {
        "n_rows": n,
        "x_kind": kind,
        "x_label": label,
        "x": [x[k] for k in keep],
        "time_text": rows["time_text"].astype(str).tolist(),
        "rul": numbers("rul"),
        "lower": numbers("lower"),
        "upper": numbers("upper"),
        "level": numbers("level"),
        "note": rows["note"].fillna("").astype(str).tolist(),
    }
