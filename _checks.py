"""Argument checks shared by every layer (models, features, ...).

Examples
--------
>>> from pdmkit._checks import check_fs
>>> check_fs(12000)
12000.0
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit.errors import DataError, ModelError, did_you_mean

__all__ = [
    "LARGEST_VALUE",
    "check_columns_present",
    "check_fs",
    "check_int",
    "check_magnitude",
    "file_sha256",
    "names_list",
    "npy_declared",
    "parse_timestamps",
    "replace_fields",
    "uniform_step",
]

#: how many names an error message shows before "and N more"
NAMES_SHOWN = 20


def names_list(items: Sequence[Any], limit: int = NAMES_SHOWN) -> str:
    """``'a', 'b' and 3 more``: names for an error message, the first ``limit`` shown.

    Examples
    --------
    >>> from pdmkit._checks import names_list
    >>> names_list(["a", "b", "c"], limit=2)
    "'a', 'b' and 1 more"
    """
    shown = ", ".join(repr(x) for x in list(items)[:limit])
    more = len(items) - limit
    return shown + (f" and {more} more" if more > 0 else "")


def check_columns_present(table: Any, names: Sequence[Any], what: str) -> None:
    """Raise :class:`~pdmkit.errors.DataError` naming the ``names`` not in ``table``.

    ``what`` says what they are ("signal column(s)", "unit="...); the message lists
    the table's columns (the first 30).

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit._checks import check_columns_present
    >>> check_columns_present(pd.DataFrame({"a": [1]}), ["a", "b"], "feature column(s)")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: feature column(s) 'b' not in the table; its columns are 'a'
    """
    missing = [c for c in names if c not in table.columns]
    if missing:
        raise DataError(
            f"{what} {names_list(missing)} not in the table; its columns are "
            f"{names_list(list(table.columns), 30)}"
        )


def replace_fields(obj: Any, changes: Mapping[str, Any], noun: str = "field") -> Any:
    """A copy of the dataclass ``obj`` with ``changes``; unknown names raise ModelError.

    The error names the unknown field, the closest known one and all known ones.

    Examples
    --------
    >>> import dataclasses
    >>> from pdmkit._checks import replace_fields
    >>> @dataclasses.dataclass(frozen=True)
    ... class Valve:
    ...     area: float = 1e-6
    >>> replace_fields(Valve(), {"area": 2e-6}).area
    2e-06
    """
    names = [f.name for f in dataclasses.fields(obj)]
    for key in changes:
        if key not in names:
            raise ModelError(
                f"{type(obj).__name__} has no {noun} {key!r}{did_you_mean(key, names)} "
                f"Known {noun}s: {', '.join(names)}."
            )
    return dataclasses.replace(obj, **changes)


def check_fs(fs: object, name: str = "fs") -> float:
    """Return a sampling rate as a float after checking it is positive and finite.

    Parameters
    ----------
    fs : object
        The sampling rate in Hz, as the user gave it.
    name : str, default "fs"
        The argument's name, for the message.

    Returns
    -------
    float

    Raises
    ------
    pdmkit.errors.DataError
        ``fs`` is not a number, or not positive and finite.

    Examples
    --------
    >>> from pdmkit._checks import check_fs
    >>> check_fs("1000")
    1000.0
    >>> check_fs(0)
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: fs must be a positive, finite sampling rate in Hz; got 0.
    """
    try:
        value = float(fs)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise DataError(
            f"{name} must be a positive, finite sampling rate in Hz; got {fs!r}."
        )
    return value


def check_int(
    value: object, name: str, *, minimum: int = 1, error: type[Exception] = DataError
) -> int:
    """Return ``value`` as an int after checking it is an integer >= ``minimum``.

    Booleans are refused (``True`` is not a count).

    Parameters
    ----------
    value : object
        What the user gave.
    name : str
        The argument's name, for the message.
    minimum : int, default 1
        Smallest value allowed.
    error : exception class, default DataError
        What to raise (estimators' parameters raise ``ValueError``, as scikit-learn's).

    Returns
    -------
    int

    Examples
    --------
    >>> from pdmkit._checks import check_int
    >>> check_int(3, "batch_size")
    3
    >>> check_int(0, "batch_size")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: batch_size must be a positive integer; got 0
    """
    if (
        isinstance(value, bool)
        or not isinstance(value, int | np.integer)
        or value < minimum
    ):
        what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise error(f"{name} must be {what}; got {value!r}")
    return int(value)


def parse_timestamps(column):
    """A column of timestamps (text or datetimes) as pandas datetimes; NaT where unread.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit._checks import parse_timestamps
    >>> parse_timestamps(pd.Series(["2004-03-04 09:27:46", "later"])).isna().tolist()
    [False, True]
    """
    import warnings

    import pandas as pd

    if pd.api.types.is_datetime64_any_dtype(column):
        return column
    with warnings.catch_warnings():  # "could not infer format": parsed one by one
        warnings.simplefilter("ignore", UserWarning)
        return pd.to_datetime(column, errors="coerce")


def time_as_seconds(column):
    """A time column as float numbers: as given, or seconds since 1970 for timestamps.

    Returns ``(values, unread)``: ``unread`` is the first value that is neither a
    number nor a timestamp (None when all read); missing values stay NaN.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit._checks import time_as_seconds
    >>> stamps = pd.Series(["1970-01-01 00:01:00", "1970-01-02 00:00:00"])
    >>> time_as_seconds(stamps)[0].tolist()
    [60.0, 86400.0]
    >>> time_as_seconds(pd.Series(["2004-03-04", "later"]))[1]
    'later'
    """
    import pandas as pd

    if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
        return column.to_numpy(dtype=float), None
    stamps = parse_timestamps(column)
    unread = stamps.isna() & column.notna()
    seconds = (stamps - pd.Timestamp("1970-01-01")).dt.total_seconds().to_numpy(dtype=float)
    return seconds, (column[unread].iloc[0] if unread.any() else None)


def uniform_step(time: object, source: str) -> float:
    """The sampling step of a time column, after checking it increases uniformly.

    Parameters
    ----------
    time : array_like
        Time stamps in s.
    source : str
        The file or table the column comes from, for the message.

    Returns
    -------
    float
        The median step in s.

    Raises
    ------
    pdmkit.errors.DataError
        The time does not increase, or a step differs from the median by more than 0.1 %.

    Examples
    --------
    >>> from pdmkit._checks import uniform_step
    >>> uniform_step([0.0, 0.1, 0.2, 0.3], "run.csv")
    0.1
    >>> uniform_step([0.0, 0.1, 0.3, 0.4], "run.csv")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: run.csv: time must be uniform; row 2 (time 0.3) is 0.2 s after the previous sample, the usual step is 0.1 s. Resample to a uniform grid.
    """  # noqa: E501
    t = np.asarray(time, dtype=float)
    dt = np.diff(t)
    step = float(np.median(dt)) if dt.size else math.nan
    if not step > 0:
        raise DataError(f"{source}: time must increase; the median step is {step:g} s.")
    deviation = np.abs(dt - step)
    if np.any(deviation > 1e-3 * step):
        k = int(np.argmax(deviation)) + 1
        raise DataError(
            f"{source}: time must be uniform; row {k} (time {t[k]:g}) is {dt[k - 1]:g} s "
            f"after the previous sample, the usual step is {step:g} s. Resample to a "
            "uniform grid."
        )
    return step


def npy_declared(handle) -> tuple[tuple[int, ...], np.dtype, int]:
    """``(shape, dtype, header length)`` that an ``.npy`` stream declares; data unread.

    Used on untrusted archives (``.npz`` members, saved models) to compare the declared
    size with the ceiling and with what the entry holds *before* numpy allocates the
    array. Raises ``ValueError`` on a damaged or unknown header.

    Examples
    --------
    >>> import io
    >>> buffer = io.BytesIO()
    >>> np.save(buffer, np.zeros((3, 4)))
    >>> _ = buffer.seek(0)
    >>> npy_declared(buffer)[:2]
    ((3, 4), dtype('float64'))
    """
    fmt = np.lib.format
    version = fmt.read_magic(handle)
    if version == (1, 0):
        shape, _, dtype = fmt.read_array_header_1_0(handle)
    elif version in ((2, 0), (3, 0)):  # 3.0 differs only in the text encoding
        shape, _, dtype = fmt.read_array_header_2_0(handle)
    else:
        raise ValueError(f"unknown .npy format version {version}")
    return tuple(shape), dtype, handle.tell()


def file_sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a file's bytes, read in blocks (the integrity check users keep).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "x.bin"
    >>> _ = path.write_bytes(b"abc")
    >>> file_sha256(path)[:16]
    'ba7816bf8f01cfea'
    """
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


#: Largest magnitude a recorded value may have: squares summed over a record must stay
#: finite in float64 (max 1.8e308).
LARGEST_VALUE = 1e150


def check_magnitude(values: object, what: str) -> None:
    """Refuse values beyond ±:data:`LARGEST_VALUE` (their arithmetic overflows).

    Parameters
    ----------
    values : array_like
        One column (any shape; NaN ignored).
    what : str
        The file and column, for the message (e.g. ``"run.csv: column 'y'"``).

    Examples
    --------
    >>> check_magnitude([1.0, 2.0], "run.csv: column 'y'")
    >>> check_magnitude([1.0, 1e300], "run.csv: column 'y'")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: run.csv: column 'y' holds 1e+300 (row 1); values beyond ±1e+150 overflow 64-bit arithmetic (their squares). Rescale it (e.g. to SI units) or check the file.
    """  # noqa: E501
    x = np.asarray(values, dtype=float).ravel()
    with np.errstate(invalid="ignore"):
        huge = np.flatnonzero(np.abs(x) > LARGEST_VALUE)
    if huge.size:
        row = int(huge[0])
        raise DataError(
            f"{what} holds {x[row]:g} (row {row}); values beyond ±{LARGEST_VALUE:g} "
            "overflow 64-bit arithmetic (their squares). Rescale it (e.g. to SI units) "
            "or check the file."
        )
