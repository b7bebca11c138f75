"""Sampling rates of member files: a time column's, and members whose signals differ.

:func:`_time_rate` checks that a time column (or a timetable's row times) increases
uniformly and gives its rate. A MATLAB member can hold signals at several rates (a
table of timetables: accelerometers at 1 kHz beside microphones at 40 kHz); such a
member's *main* rate is the rate of its first signal (the one
:meth:`Ensemble.frames` measures frames in), and the others are kept per signal: every
member must have each signal at one rate (:func:`signal_rates`), and ``resample=``
brings each signal from its own rate (:func:`resampled_multi`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from pdmkit._checks import parse_timestamps
from pdmkit.ensembles._member_labels import _ratio
from pdmkit.ensembles._signals import resample_poly_1d
from pdmkit.errors import DataError

__all__: list[str] = []

#: How far a time step may differ from the median step: 1 % of it, or one unit of the
#: last decimal the time stamps are written with when that is more and at most half a
#: step (stamps rounded to microseconds at 25.6 kHz step 39 or 40 us).
_TIME_JITTER = 0.01


def _stamp_resolution(t: np.ndarray) -> float:
    """The decimal step time stamps were written with (``1e-6`` for ``0.000039``), or 0."""
    for d in range(10):
        scaled = t * 10.0**d
        if np.allclose(scaled, np.round(scaled), rtol=1e-12, atol=1e-6):
            return 10.0**-d
    return 0.0


def _time_rate(path: Path, column: pd.Series, where: Callable[[int], str]) -> float | None:
    """The sampling rate a time column states, after checking it increases uniformly.

    Numbers are seconds; text is parsed as timestamps. A missing, repeated, decreasing
    or uneven time stamp is a DataError naming the file and the first bad row.
    """
    name = column.name
    if pd.api.types.is_datetime64_any_dtype(column):
        stamps = column
    elif pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
        stamps = None
    else:
        stamps = parse_timestamps(column)
        if stamps.isna().all():
            raise DataError(
                f"{path}: time column {name!r} holds {str(column.iloc[0])!r} at "
                f"{where(0)}; expected seconds (numbers) or timestamps. Rename the "
                "column if it is no time, or drop it and pass fs= (--fs)"
            )
    if stamps is None:
        t = column.to_numpy(dtype=float)
    else:
        t = (stamps - stamps.dropna().iloc[0]).dt.total_seconds().to_numpy(dtype=float)

    def shown(i: int) -> str:
        return f"{t[i]:g} s" if stamps is None else repr(str(column.iloc[i]))

    missing = np.flatnonzero(~np.isfinite(t))
    if missing.size:
        k = int(missing[0])
        raise DataError(
            f"{path}: time column {name!r} has no valid time at {where(k)} (found "
            f"{str(column.iloc[k])!r}); every row needs its time stamp. Fill it in, or "
            "drop the time column and pass fs= (--fs)"
        )
    if len(t) < 2:
        return None
    dt = np.diff(t)
    back = np.flatnonzero(dt <= 0)
    if back.size:
        k = int(back[0]) + 1
        verb = "repeats" if dt[k - 1] == 0 else "goes back"
        raise DataError(
            f"{path}: time {verb} at {where(k)}: {shown(k)} after {shown(k - 1)} on the "
            "row before; time must increase from row to row. Remove the repeated rows or "
            "sort them, or drop the time column and pass fs= (--fs)"
        )
    step = float(np.median(dt))
    tol = _TIME_JITTER * step
    quantum = _stamp_resolution(t)
    if quantum <= step / 2:  # stamps rounded to a finer decimal than the step
        tol = max(tol, 1.001 * quantum)
    uneven = np.flatnonzero(np.abs(dt - step) > tol)
    if uneven.size:
        k = int(uneven[0]) + 1
        raise DataError(
            f"{path}: time is not uniform at {where(k)}: {shown(k)} is {dt[k - 1]:g} s "
            f"after the row before, the median step is {step:g} s (steps may differ by "
            f"{100 * tol / step:.2g} % of it); a member is one uniformly sampled "
            "recording. Resample it to a uniform grid or split it at the gap, or drop the "
            "time column and pass fs= (--fs)"
        )
    return (len(t) - 1) / float(t[-1] - t[0])


#: Two rates closer than this (relative) are one rate.
_SAME = 1e-6


def _same(a: float | None, b: float | None) -> bool:
    if a is None or b is None:
        return a is b
    return abs(a - b) <= _SAME * max(abs(a), abs(b))


def member_rate(
    signals: dict, fs: float | None, rates: dict[str, float]
) -> float | dict[str, float | None] | None:
    """The rate of a member's signals: one (or None), or per signal when they differ.

    ``rates`` holds the rates row times state (a timetable's signals); the other
    signals are at ``fs`` (the file's ``fs`` variable, or None).

    Examples
    --------
    >>> member_rate({"a": 0, "b": 0}, 10.0, {"a": 10.0})
    10.0
    >>> member_rate({"a": 0, "b": 0}, None, {"a": 1000.0, "b": 40000.0})
    {'a': 1000.0, 'b': 40000.0}
    """
    each = {s: rates.get(s, fs) for s in signals}
    distinct: list[float | None] = []
    for r in each.values():
        if not any(_same(r, d) for d in distinct):
            distinct.append(r)
    if len(distinct) <= 1:
        return distinct[0] if distinct else fs
    return each


def split_rate(
    rate: float | dict | None, signals: dict, wanted: list | None
) -> tuple[float | None, dict[str, float]]:
    """``(main rate, {signal: rate} of the signals at another rate)`` of one member.

    The main rate is the rate of the member's first signal (the first of ``wanted``
    it holds); a signal whose rate is unknown is at the main rate.

    Examples
    --------
    >>> split_rate({"a": 1000.0, "m": 40000.0}, {"a": 0, "m": 0}, None)
    (1000.0, {'m': 40000.0})
    """
    if not isinstance(rate, dict):
        return rate, {}
    first = next((s for s in wanted or () if s in signals), next(iter(signals), None))
    main = rate.get(first) if first is not None else None
    if main is None:
        main = next((r for r in rate.values() if r is not None), None)
    odd = {s: r for s, r in rate.items() if r is not None and not _same(r, main)}
    return main, odd


def signal_rates(
    kept: list,
    rate: float | None,
    odd: dict[Path, dict],
    wanted: list | None,
    fail: Callable,
) -> tuple[list, dict[str, float | None]]:
    """The members whose signals share each signal's rate, and those rates.

    ``kept`` holds ``(member, path, arrays, conditions)``; ``odd[path]`` the signals
    of that file at another rate than the main one, ``rate``. A signal's rate is the
    most common among the members holding it; a member with a signal at another rate
    fails (``fail``) naming both.
    """
    seen: dict[str, dict[float, int]] = {}
    for _, path, arrays, _ in kept:
        for s in arrays:
            r = odd.get(path, {}).get(s, rate)
            if r is not None:
                counts = seen.setdefault(s, {})
                key = next((k for k in counts if _same(k, r)), r)
                counts[key] = counts.get(key, 0) + 1
    common = {s: max(c, key=c.__getitem__) for s, c in seen.items()}
    out = []
    for member, path, arrays, conds in kept:
        bad = next(
            (
                (s, odd.get(path, {}).get(s, rate))
                for s in arrays
                if (wanted is None or s in wanted)
                and s in common
                and not _same(odd.get(path, {}).get(s, rate), common[s])
            ),
            None,
        )
        if bad is None:
            out.append((member, path, arrays, conds))
            continue
        fail(
            member,
            bad[0],
            path,
            f"signal {bad[0]!r} of {path.name} is sampled at {bad[1]:g} Hz, in the other "
            f"member files at {common[bad[0]]:g} Hz; pass resample= (--resample HZ) to "
            "bring every signal to one rate, or read the files apart",
        )
    return out, {s: common.get(s, rate) for s in {s for _, _, a, _ in out for s in a}}


def resampled_multi(
    read: list, odd: dict[Path, dict], target: float, wanted: list | None, fail: Callable
) -> list:
    """Members whose signals are at several rates, each signal resampled to ``target``.

    ``read`` holds ``(member, path, arrays, main rate, conditions)``; each signal goes
    from its own rate (``odd[path]``, else the main one) to ``target`` as
    ``_resampled`` does; ``fs_original`` is the main rate.
    """
    kept = []
    for member, path, arrays, rate, conds in read:
        out = {}
        try:
            for s, x in arrays.items():
                if wanted is not None and s not in wanted:
                    continue
                up, down = _ratio(path, odd[path].get(s, rate), target)
                out[s] = resample_poly_1d(x, up, down) if up != down else x
        except DataError as exc:
            fail(member, None, path, str(exc))
            continue
        kept.append((member, path, out, {**conds, "fs_original": rate}))
    return kept
