"""Conditions a member file gets from its name: a pattern's groups, a labels table's row.

Used by :func:`pdmkit.ensembles.read_members` (``label_from_name=``, ``labels=``), with
the rate such a condition states (``fs``) and the frame lengths of ``frame=`` / ``hop=``
(samples, or seconds turned into samples at the members' rate).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.ensembles._limits import _why
from pdmkit.ensembles._signals import resample_poly_1d
from pdmkit.ensembles._table_files import read_table
from pdmkit.errors import DataError, DataWarning, did_you_mean

__all__: list[str] = []


class _NameConditions:
    """Condition values a member gets from its file name.

    A regular expression's groups (``label_from_name``) and a labels table's row
    (``labels``).
    """

    _KEYS = ("file", "member", "name", "filename", "path")

    def __init__(self, label_from_name: Any, labels: Any) -> None:
        self.pattern = self._pattern(label_from_name)
        self.table, self.source = self._table(labels)
        self.used: set = set()

    @staticmethod
    def _pattern(regex: Any) -> re.Pattern | None:
        if regex is None:
            return None
        try:
            pattern = re.compile(regex)
        except (re.error, TypeError) as exc:
            raise DataError(
                f"label_from_name (--label-from-name) {regex!r} is not a regular "
                f"expression ({_why(exc)})"
            ) from None
        if not pattern.groupindex and pattern.groups != 1:
            raise DataError(
                f"label_from_name (--label-from-name) {pattern.pattern!r} has "
                f"{pattern.groups} groups; it needs one group (...) for the label, or "
                r"named groups (?P<label>...) (?P<load>\d+) for condition columns, "
                r"e.g. '^\d+_([A-Za-z]+)'"
            )
        return pattern

    def _table(self, labels: Any) -> tuple[dict | None, str]:
        if labels is None:
            return None, ""
        if isinstance(labels, pd.DataFrame):
            table, source = labels, "the labels table"
        else:
            table, source = read_table(labels), f"labels table {labels}"
        lower = {str(c).lower(): c for c in table.columns}
        key = next((lower[k] for k in self._KEYS if k in lower), None)
        if key is None:
            raise DataError(
                f"{source}: no column names the member files; expected one of "
                f"{list(self._KEYS)} (the file name, e.g. a.csv, or its member id a), "
                f"found {[str(c) for c in table.columns]}"
            )
        if table.shape[1] < 2:
            raise DataError(
                f"{source}: only the column {key!r}; add the label / condition columns "
                "beside it (e.g. file,fault)"
            )
        # keyed by member id: "a.csv" and "a" name the same member
        names = table[key].astype(str).map(lambda v: Path(v.strip()).name.split(".")[0])
        dup = names[names.duplicated()].unique().tolist()
        if dup:
            raise DataError(
                f"{source}: member file(s) {dup[:5]} are listed more than once; give "
                "each member one row"
            )
        rows = table.drop(columns=[key]).to_dict(orient="records")
        out = {}
        for name, row in zip(names, rows, strict=True):
            out[name] = {str(k): v for k, v in row.items()}
        return out, source

    def conditions(self, path: Path) -> dict:
        """The conditions ``path``'s name gives; DataError when it gives none."""
        extra: dict = {}
        if self.pattern is not None:
            match = self.pattern.search(path.name)
            if match is None:
                raise DataError(
                    f"{path.name}: its name does not match label_from_name "
                    f"(--label-from-name) {self.pattern.pattern!r}, so it has no label; "
                    "rename the file or widen the expression"
                )
            found = match.groupdict() if self.pattern.groupindex else {"label": match[1]}
            # a group that took no part in the match gives no value
            extra.update({k: v for k, v in found.items() if v is not None})
        if self.table is not None:
            key = stem = path.name.split(".")[0]
            if key not in self.table:
                raise DataError(
                    f"{path.name} is not listed in {self.source}; add a row for it "
                    f"(by file name {path.name!r} or member id {stem!r})"
                    f"{did_you_mean(path.name, self.table)}"
                )
            self.used.add(key)
            for name, value in self.table[key].items():
                if name in extra and str(extra[name]) != str(value):
                    raise DataError(
                        f"{path.name}: condition {name!r} is {extra[name]!r} by its name "
                        f"(label_from_name) but {value!r} in {self.source}; keep one"
                    )
                extra[name] = value
        return extra

    @staticmethod
    def merge(path: Path, conditions: dict, extra: dict) -> dict:
        """The file's own ``conditions`` and ``extra``; a clash is a DataError."""
        for name, value in extra.items():
            own = conditions.get(name)
            if own is not None and str(own) != str(value):
                raise DataError(
                    f"{path.name}: condition {name!r} is {own!r} in the file but "
                    f"{value!r} from its name or the labels table; keep one"
                )
        return {**conditions, **extra}

    def warn_unused(self) -> None:
        """A DataWarning for labels-table rows that name no member file read."""
        if self.table is None:
            return
        unused = [k for k in self.table if k not in self.used]
        if unused:
            warnings.warn(
                f"{self.source}: {len(unused)} row(s) name no member file read: "
                f"{unused[:5]}{' ...' if len(unused) > 5 else ''}; check the names",
                DataWarning,
                stacklevel=3,
            )


#: The condition that states a member's sampling rate (a labels-table column or a named
#: group of label_from_name); consumed as the rate, never kept as a condition.
RATE_CONDITION = "fs"
_HZ = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)\s*(hz|khz|k)?\s*$", re.I)


def _stated_hz(value: Any) -> float | None:
    """A rate condition's value in Hz (``12000``, ``"12k"``, ``"12 kHz"``), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float | np.integer | np.floating):
        rate = float(value)
    else:
        match = _HZ.match(str(value))
        if match is None:
            return None
        unit = (match[2] or "").lower()
        rate = float(match[1]) * (1e3 if unit in ("k", "khz") else 1.0)
    return rate if math.isfinite(rate) and rate > 0 else None


def _condition_rate(path: Path, conditions: dict, rate: float | None) -> float | None:
    """The member's rate: its own, or the ``fs`` condition's (taken out of conditions).

    A blank ``fs`` (NaN, an empty cell) states nothing. A rate the file states itself
    and a different ``fs`` condition (by more than 0.1 %) are a DataError naming the
    file and both rates: nothing the file states is overridden.
    """
    if RATE_CONDITION not in conditions:
        return rate
    value = conditions.pop(RATE_CONDITION)
    if value is None or (not isinstance(value, str) and pd.isna(value)):
        return rate
    stated = _stated_hz(value)
    if stated is None:
        raise DataError(
            f"{path.name}: condition 'fs' (labels table or file name) is {value!r}; "
            "expected the sampling rate in Hz, a positive number (12000, 12k, 12 kHz)"
        )
    if rate is not None and abs(stated - rate) > 1e-3 * rate:
        raise DataError(
            f"{path.name} states its sampling rate as {rate:g} Hz (time column or fs "
            f"variable) but its fs condition (labels table or file name) says "
            f"{stated:g} Hz; correct one of them"
        )
    return rate if rate is not None else stated


_LENGTH = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)\s*(s|ms|us)?\s*$", re.I)
_SECONDS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}


def _length_spec(value: Any, what: str) -> tuple[float, str]:
    """``(number, unit)`` of a frame length or hop: samples (``2048``) or seconds.

    ``unit`` is ``"samples"`` or ``"s"`` (``"0.1s"``, ``"100ms"``, ``"250us"`` are
    seconds). A count of samples must be a whole positive number; a duration positive.
    """
    if isinstance(value, int | np.integer) and not isinstance(value, bool):
        number, unit = float(value), ""
    else:
        match = _LENGTH.match(value) if isinstance(value, str) else None
        if match is None:
            raise DataError(
                f"{what} must be a number of samples (2048) or a duration (0.1s, 100ms); "
                f"got {value!r}"
            )
        number, unit = float(match[1]), (match[2] or "").lower()
    if not unit and number != int(number):
        raise DataError(
            f"{what} {value!r} is no whole number of samples; give samples (2048) or a "
            "duration with its unit (0.1s, 100ms)"
        )
    if number <= 0:
        raise DataError(f"{what} must be positive; got {value!r}")
    return (number, "samples") if not unit else (number * _SECONDS[unit], "s")


def _in_samples(spec: tuple[float, str], fs: float | None, what: str) -> int:
    """A length ``spec`` in samples: seconds times ``fs``, rounded to the nearest one."""
    number, unit = spec
    if unit == "samples":
        return int(number)
    if fs is None:
        raise DataError(
            f"{what} {number:g} s needs the members' sampling rate, which none states; "
            "give the rate (fs= / --fs) or the length in samples"
        )
    samples = math.floor(number * fs + 0.5)  # half a sample rounds up
    if samples < 1:
        raise DataError(
            f"{what} {number:g} s is {number * fs:.3g} samples at {fs:g} Hz, less than "
            "one; give a longer one"
        )
    return samples


#: How ``frame`` and ``hop`` are named in messages.
_FRAME_WORDS = ("frame (--frame)", "hop (--hop)")


def _frame_specs(frame: Any, hop: Any) -> tuple | None:
    """The ``(number, unit)`` of ``frame`` and of ``hop`` (default ``frame``), or None."""
    if frame is None:
        if hop is not None:
            raise DataError(
                f"hop (--hop) {hop!r} needs frame (--frame LENGTH): the hop is the step "
                "between the starts of frames; give the frame length too"
            )
        return None
    length = _length_spec(frame, _FRAME_WORDS[0])
    return length, length if hop is None else _length_spec(hop, _FRAME_WORDS[1])


def _at_one_rate(
    read: list, fs: float | None, on_error: str, fail: Callable
) -> tuple[list, float]:
    """The members at the expected rate (``fs``, or the most common) and that rate.

    Members at another rate: with ``on_error="raise"`` one DataError naming them all
    (with their rates) and suggesting ``resample``; else each is skipped.
    """
    expected, whose = _expected_rate(read, fs)
    odd = [r for r in read if r[3] is not None and abs(r[3] - expected) > 1e-3 * expected]
    if odd and on_error == "raise":
        raise DataError(_rates_message(read, odd, expected, whose))
    for member, path, _, rate, _ in odd:
        fail(
            member,
            None,
            path,
            f"{path.name} is sampled at {rate:g} Hz; expected {expected:g} Hz "
            f"({whose}); pass resample= (--resample HZ) to read it",
        )
    ids = {id(row) for row in odd}
    kept = [(m, p, a, c) for m, p, a, _, c in (row for row in read if id(row) not in ids)]
    return kept, expected


def _names(paths: list[Path], show: int = 3) -> str:
    """Up to ``show`` file names, and how many more."""
    names = ", ".join(p.name for p in paths[:show])
    return names + (f" and {len(paths) - show} more" if len(paths) > show else "")


def _rates_message(read: list, odd: list, expected: float, whose: str) -> str:
    """One line naming the files at other rates than ``expected``, and the others."""
    by_rate: dict[float, list[Path]] = {}
    for _, path, _, rate, _ in odd:
        by_rate.setdefault(rate, []).append(path)
    parts = [
        f"{_names(ps)} {'is' if len(ps) == 1 else 'are'} sampled at {r:g} Hz"
        for r, ps in sorted(by_rate.items())
    ]
    odd_ids = {id(row) for row in odd}
    others = [row[1] for row in read if row[3] is not None and id(row) not in odd_ids]
    at = f"; {_names(others)} at {expected:g} Hz" if others else ""
    return (
        f"member files at different sampling rates: {'; '.join(parts)}{at} (expected "
        f"{expected:g} Hz, {whose}). A file is never read at another rate than its "
        "own: pass resample=HZ (--resample HZ) to resample every member to one rate, "
        "or read the files of each rate apart"
    )


def _resampled(
    read: list, fs: float | None, target: float, wanted: list | None, fail: Callable
) -> list:
    """The members resampled to ``target`` Hz, each with its ``fs_original``.

    Only the ``wanted`` signals (default all) are resampled: the others are not kept. A
    member whose rate is unknown (the file, its ``fs`` condition and ``fs`` state none)
    or too odd a ratio of rates is that member's error.
    """
    kept = []
    for member, path, arrays, rate, conds in read:
        rate = fs if rate is None else rate
        try:
            up, down = _ratio(path, rate, target)
        except DataError as exc:
            fail(member, None, path, str(exc))
            continue
        if up != down:
            arrays = {
                s: resample_poly_1d(x, up, down) if wanted is None or s in wanted else x
                for s, x in arrays.items()
            }
        kept.append((member, path, arrays, {**conds, "fs_original": rate}))
    return kept


def _ratio(path: Path, rate: float | None, target: float) -> tuple[int, int]:
    """``(up, down)``: ``target / rate`` as a fraction of integers of at most 10000.

    The fraction is the nearest one with a denominator of at most 10000; it must give
    ``target`` within 1e-6 of it (a time column's rate is a measured one: 12000.0004 Hz
    resampled to 12000 Hz is not resampled), and up and down at most 10000.
    """
    from fractions import Fraction

    if rate is None:
        raise DataError(
            f"{path.name} states no sampling rate (no time column, fs variable or fs "
            "condition), so it cannot be resampled; pass fs= (--fs) or give its rate in "
            "an fs column of the labels table (--labels)"
        )
    ratio = (Fraction(target) / Fraction(rate)).limit_denominator(10_000)
    if ratio.numerator > 10_000 or abs(rate * ratio / target - 1) > 1e-6:
        raise DataError(
            f"{path.name}: cannot resample from {rate:g} Hz to {target:g} Hz (resample=, "
            "--resample): the ratio of the rates is no fraction of integers of at most "
            "10000; choose a target rate with a simpler ratio"
        )
    return ratio.numerator, ratio.denominator


def _long_enough(
    kept: list, length: int, rate: float, wanted: list | None, fail: Callable
) -> list:
    """The members at least one frame of ``length`` samples long (others fail)."""
    out = []
    for member, path, arrays, conds in kept:
        n = min(len(x) for s, x in arrays.items() if wanted is None or s in wanted)
        if n >= length:
            out.append((member, path, arrays, conds))
            continue
        fail(
            member,
            None,
            path,
            f"{path.name} has {n} samples ({n / rate:g} s at {rate:g} Hz), fewer than "
            f"one frame of {length} samples ({length / rate:g} s); choose a shorter "
            "frame (--frame) or leave the file out",
        )
    return out


def _expected_rate(read: list, fs: float | None) -> tuple[float | None, str]:
    """The rate every member must have and whose it is: ``fs``, or the most common."""
    rates = [r for _, _, _, r, _ in read if r is not None]
    expected, whose = fs, "fs as given"
    if expected is None and rates:
        values, counts = np.unique(np.round(rates, 6), return_counts=True)
        expected, whose = (
            float(values[np.argmax(counts)]),
            "the most common rate of the files",
        )
    if expected is None and read:
        raise DataError(
            f"none of the {len(read)} member files states its sampling rate (no time "
            "column, no fs variable, no fs condition); pass fs= (--fs), or give each "
            "file's rate in an fs column of the labels table (--labels)"
        )
    return expected, whose


#: column names a clock field or a counter goes by; in a header-less table
#: (``column_0``, ...) every column is checked
CLOCK_NAMES = re.compile(
    r"(?i)^(column_\d+|hours?|minutes?|min|seconds?|sec|ms|us|µs|microseconds?|"
    r"milliseconds?|time_?stamp|counter|sample_index|ticks?)$"
)


def clock_column(name: str, values: np.ndarray) -> str | None:
    """Whether a member file's column is a clock: ``"constant"``, ``"counter"`` or None.

    Raw recorders write the time of day beside the samples (PRONOSTIA's snapshots:
    hour, minute, second, microsecond, then the two accelerations, no header). Such a
    column, read as a signal, becomes a "health indicator" that ranks first by
    monotonicity. A column is a clock when its name is a clock's (or the table has
    no header) and its values are whole numbers that are constant (a field of the
    time stamp) or count up with at most two resets (microseconds wrapping at the
    second), or tick over once by one (a seconds field within a 0.1 s snapshot). A
    header-less on/off signal that switches on once would look like the last: the
    warning names every column left out.

    Examples
    --------
    >>> clock_column("column_3", np.array([65664.0, 65703, 65742, 3, 42]))
    'counter'
    >>> clock_column("column_0", np.array([9.0, 9, 9])), clock_column("acc", np.arange(5.0))
    ('constant', None)
    >>> clock_column("column_4", np.array([0.552, 0.501, 0.138]))
    """
    if not CLOCK_NAMES.match(name) or values.size < 2:
        return None
    if not np.all(np.isfinite(values)) or not np.all(values == np.round(values)):
        return None
    steps = np.diff(values)
    if np.all(steps == 0):
        return "constant"
    resets = np.count_nonzero(steps < 0)
    distinct = np.unique(values)
    ticks_once = distinct.size == 2 and resets == 0 and distinct[1] - distinct[0] == 1
    if (resets <= 2 and distinct.size >= 3) or ticks_once:  # a second ticking over
        return "counter"
    return None
