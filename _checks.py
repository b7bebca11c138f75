"""Argument checks shared by every layer (models, features, ...).

Examples
--------
>>> from pdmkit._checks import check_fs
>>> check_fs(12000)
12000.0
"""

from __future__ import annotations

import math

import numpy as np

from pdmkit.errors import DataError

__all__ = ["check_fs", "npy_declared", "uniform_step"]


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
