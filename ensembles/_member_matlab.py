"""MATLAB tables, timetables and structs in a member file, unpacked into its variables.

A MATLAB ensemble member is often one table row: each signal a timetable (its row
times give its rate), each condition a scalar (or a one-row table, or a one-row
timetable such as a temperature read once). :func:`unpack_mat` turns what
:func:`~pdmkit.ensembles.read_mat` returns into plain variables that the member reader
takes as signals (numeric vectors) and conditions (scalars, text):

- a timetable: its variables are signals at the rate of its row times (or its
  sample rate); a one-row timetable's variables are conditions;
- a one-row table: each variable is what it holds: a timetable a signal named after
  the table variable (``name_var`` when it holds several), a one-row table or a
  scalar a condition, a numeric vector a signal;
- a table of several rows: its numeric variables are signals (a ``time`` variable
  gives their rate), constant text is a condition;
- a struct: its fields are read as variables (nested structs' fields as
  ``struct_field``);
- a datetime or duration scalar is a condition; anything else (an object pdmkit does
  not read, a categorical or string array, a table of tables per row) is noted as
  skipped, with the reason.

A name met twice is prefixed with its container's (``data_x``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.ensembles._matlab_tables import READ_CLASSES, UnreadObject
from pdmkit.ensembles._member_rates import _time_rate
from pdmkit.errors import DataError

__all__: list[str] = []

#: Time variables of a MATLAB table of several rows (as in a CSV member).
_TIME_NAMES = ("time", "t", "Time", "TIME")
#: The MATLAB classes pdmkit reads (everything else is named as not read).
_KNOWN = (
    *("double", "single", "logical", "char", "struct", "cell", "sparse"),
    *(f"{s}int{b}" for s in ("", "u") for b in (8, 16, 32, 64)),
    *("table", "timetable", "string", "categorical", "datetime", "duration"),
)
_SKIPPED = (
    "skipped. pdmkit reads numeric vectors, timetables, tables of timetables and "
    "structs of them as signals, scalars and text as conditions"
)


class _Unpacked:
    """What unpacking collects: variables, their rates, conditions, notes."""

    def __init__(self, path: Path, notes: list) -> None:
        self.path, self.notes = path, notes
        self.variables: dict[str, Any] = {}
        self.rates: dict[str, float] = {}
        self.conditions: dict[str, Any] = {}

    def put(self, name: str, value: Any, container: str, rate: float | None = None) -> None:
        """Keep ``value`` as variable ``name`` (prefixed with ``container`` if taken)."""
        if name in self.variables or name in self.conditions:
            name = f"{container}_{name}" if container else name
        k, base = 1, name
        while name in self.variables or name in self.conditions:
            name, k = f"{base}_{k}", k + 1
        if isinstance(value, pd.Timestamp | pd.Timedelta):
            self.conditions[name] = value
            return
        self.variables[name] = value
        if rate is not None:
            self.rates[name] = rate

    def skip(self, name: str, why: str) -> None:
        self.notes.append(("variable", name, f"{why}; {_SKIPPED}"))

    def value(self, name: str, value: Any, container: str, depth: int = 0) -> None:
        """Unpack one value held under ``name``."""
        if isinstance(value, pd.DataFrame):
            if value.attrs.get("matlab_class") == "timetable":
                self.timetable(name, value, container, nested=bool(container))
            else:
                self.table(name, value, container, depth)
        elif isinstance(value, dict):
            if not value:
                self.skip(name, "is an empty MATLAB struct")
            for field, v in value.items():
                inner = field if depth == 0 and not container else f"{name}_{field}"
                self.value(inner, v, name, depth + 1)
        elif isinstance(value, UnreadObject):
            why = f" ({value.why})" if value.why else ""
            self.skip(name, f"is a MATLAB {value.classname} object{why}, not read")
        elif isinstance(value, pd.Categorical):
            self.skip(name, f"is a MATLAB categorical array of {len(value)} values")
        else:
            self.put(name, value, container)

    def timetable(
        self, name: str, frame: pd.DataFrame, container: str, nested: bool
    ) -> None:
        """A timetable's variables: signals at its rate, or conditions if one row."""
        names = {
            c: (name if nested and frame.shape[1] == 1 else _joined(name, c, nested))
            for c in frame.columns
        }
        if len(frame) == 0:
            self.skip(name, "is an empty timetable")
            return
        if len(frame) == 1:
            for c, n in names.items():
                self.put(n, _one(frame[c].iloc[0]), container)
            return
        rate = frame.attrs.get("sample_rate") or _row_rate(self.path, name, frame.index)
        for c, n in names.items():
            column = frame[c]
            if _is_numbers(column):
                self.put(n, column.to_numpy(), container, rate)
            elif column.nunique(dropna=False) == 1:
                self.put(n, _one(column.iloc[0]), container)
            else:
                self.skip(n, f"holds {column.dtype} values that change from row to row")

    def table(self, name: str, frame: pd.DataFrame, container: str, depth: int) -> None:
        """A table's variables: one row's values, or the columns of several rows."""
        if len(frame) == 0:
            self.skip(name, "is an empty table")
            return
        if len(frame) == 1:
            for c in frame.columns:
                value = frame[c].iloc[0]
                if isinstance(value, pd.DataFrame):
                    one = value.shape[1] == 1
                    if value.attrs.get("matlab_class") == "timetable":
                        self.timetable(str(c), value, name, nested=True)
                    elif len(value) == 1:
                        for v in value.columns:
                            label = str(c) if one else f"{c}_{v}"
                            self.put(label, _one(value[v].iloc[0]), name)
                    else:
                        self.table(str(c), value, name, depth + 1)
                else:
                    self.value(str(c), _one(value), name, depth + 1)
            return
        time = next((c for c in _TIME_NAMES if c in frame.columns), None)
        rate = None
        if time is not None and _is_numbers(frame[time]):
            rate = _time_rate(
                self.path, frame[time], lambda k: f"row {k + 1} of table {name!r}"
            )
        for c in frame.columns:
            column = frame[c]
            if c == time:
                continue
            if _is_numbers(column):
                self.put(str(c), column.to_numpy(), name, rate)
            elif column.map(lambda v: isinstance(v, pd.DataFrame)).any():
                self.skip(
                    f"{name}.{c}",
                    f"holds a table or timetable in each of its {len(frame)} rows (one "
                    "member each); a member file holds one recording: save one row a file",
                )
            elif column.nunique(dropna=False) == 1:
                self.put(str(c), _one(column.iloc[0]), name)
            else:
                self.skip(
                    f"{name}.{c}",
                    f"holds {column.dtype} values that change from row to row",
                )


def _joined(name: str, column: Any, nested: bool) -> str:
    return f"{name}_{column}" if nested else str(column)


def _is_numbers(column: pd.Series) -> bool:
    return column.dtype.kind in "biuf"


def _one(value: Any) -> Any:
    """A value of one table cell: numpy scalars as Python ones, a 1-element array too."""
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind != "O":
        return value.reshape(-1)[0].item()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _row_rate(path: Path, name: str, index: pd.Index) -> float | None:
    """The rate of a timetable's row times (durations or datetimes), checked uniform."""
    if isinstance(index, pd.DatetimeIndex | pd.TimedeltaIndex):
        seconds = (index - index[0]) / pd.Timedelta(seconds=1)
    else:
        raise DataError(f"{path}: the row times of timetable {name!r} are no times")
    series = pd.Series(np.asarray(seconds, dtype=float), name=f"row times of {name!r}")
    return _time_rate(path, series, lambda k: f"row {k + 1}")


def unpack_mat(path: Path, data: dict, notes: list) -> tuple[dict, dict[str, float], dict]:
    """``(variables, rates, conditions)`` of a ``.mat`` member's tables and structs.

    ``variables`` are plain values (the member reader makes numeric vectors signals,
    scalars and text conditions), ``rates`` the sampling rates their row times state
    (a timetable's signals), ``conditions`` what is already a condition (a datetime or
    duration). What is skipped is appended to ``notes`` as ``("variable", name, why)``.

    Examples
    --------
    >>> t = pd.to_timedelta(np.arange(4) * 0.5, unit="s")
    >>> tt = pd.DataFrame({"Data": [0.0, 1.0, 0.0, 1.0]}, index=t)
    >>> tt.attrs["matlab_class"] = "timetable"
    >>> row = pd.DataFrame({"vib": pd.Series([tt], dtype=object), "load": [6.25]})
    >>> row.attrs["matlab_class"] = "table"
    >>> variables, rates, _ = unpack_mat(Path("m.mat"), {"data": row}, [])
    >>> sorted(variables), rates
    (['load', 'vib'], {'vib': 2.0})
    """
    unpacked = _Unpacked(path, notes)
    for key, value in data.items():
        unpacked.value(key, value, "")
    return unpacked.variables, unpacked.rates, unpacked.conditions


def _why_not(var: Any) -> str:
    """Why a listed variable is not read, when its class says so ("" otherwise)."""
    if var.classname not in _KNOWN:
        return "a class pdmkit does not read"
    if var.mclass == 0 and var.classname in READ_CLASSES:  # listed from a v7.3 file
        return "an object in a v7.3 file: re-save it with -v7"
    return ""


def nothing_to_read(path: Path, listing: list) -> DataError:
    """The one-line error of a ``.mat`` member without a signal: what it holds, what to do.

    Examples
    --------
    >>> from pdmkit.ensembles._matlab_v5 import MatVariable
    >>> error = nothing_to_read(Path("a.mat"), [MatVariable("names", 1, "cell", (1, 3))])
    >>> str(error).split(";")[0]
    "a.mat holds no signal pdmkit reads: it holds 'names' (cell 1x3)"
    """
    shown = ", ".join(v.describe(_why_not(v)) for v in listing[:8])
    more = f" and {len(listing) - 8} more" if len(listing) > 8 else ""
    return DataError(
        f"{path} holds no signal pdmkit reads: it holds {shown or 'no variables'}{more}; "
        "save each signal as a numeric vector or a timetable (a member's labels as "
        f"scalars or text), e.g. save('{path.name}', 'vib', 'fs', 'fault', '-v7')"
    )
