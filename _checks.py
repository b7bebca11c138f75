"""Argument checks shared by every layer (models, features, ...).

Examples
--------
>>> from pdmkit._checks import check_fs
>>> check_fs(12000)
12000.0
"""

from __future__ import annotations

import math

from pdmkit.errors import DataError

__all__ = ["check_fs"]


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
