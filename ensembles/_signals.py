"""Signals of an ensemble's members: checks, conversion, resampling ratios.

The small pieces shared by :class:`~pdmkit.ensembles.Ensemble`, its views, the Parquet
store and the loaders: the member-id name, a signal's list of per-member arrays and
their checks, and polyphase resampling by an exact ratio.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from fractions import Fraction
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import names_list
from pdmkit.errors import DataError

__all__ = ["MEMBER", "SignalList", "resample_poly_1d", "resample_ratio"]

MEMBER = "member"
"""Name of the member-id index (and of the id column on disk)."""

_SHOW = 5  # how many offending members an error message names
_RESAMPLE_BLOCK = 1 << 24  # samples resampled in one vectorised call (128 MiB of float64)

SignalList = list  # list[np.ndarray | None], one entry per member


def _names_list(items: Sequence[Any], limit: int = _SHOW) -> str:
    return names_list(items, limit)


def _readonly(a: np.ndarray) -> np.ndarray:
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def resample_ratio(fs_from: float, fs_to: float, what: str = "signal") -> tuple[int, int]:
    """Return ``(up, down)`` with ``fs_to / fs_from == up / down`` in small integers.

    Examples
    --------
    >>> resample_ratio(48000.0, 12000.0)
    (1, 4)
    """
    exact = Fraction(fs_to) / Fraction(fs_from)
    ratio = exact.limit_denominator(10_000)
    if abs(float(ratio) - fs_to / fs_from) > 1e-9 * (fs_to / fs_from):
        raise DataError(
            f"cannot resample {what} from {fs_from:g} Hz to {fs_to:g} Hz: the ratio is not "
            "a fraction of integers below 10000; choose a target rate with a simpler ratio"
        )
    return ratio.numerator, ratio.denominator


def resample_poly_1d(x: np.ndarray, up: int, down: int) -> np.ndarray:
    """Polyphase-resample the last axis of ``x`` by ``up / down`` (scipy defaults).

    Examples
    --------
    >>> resample_poly_1d(np.ones(8), 1, 2).shape
    (4,)
    """
    from scipy.signal import resample_poly

    if up == down:
        return np.asarray(x, dtype=np.float64)
    return resample_poly(np.asarray(x, dtype=np.float64), up, down, axis=-1)


def _as_float(x: Any, signal: str, member: str | None) -> np.ndarray:
    where = f"signal {signal!r}" + (f" of member {member!r}" if member is not None else "")
    try:
        a = np.asarray(x)
    except (ValueError, TypeError) as exc:
        raise DataError(f"{where} is not a numeric array ({exc})") from None
    if a.dtype.kind == "c":
        raise DataError(
            f"{where} holds complex values; store real and imaginary parts as two signals"
        )
    if a.dtype.kind not in "biuf":
        raise DataError(
            f"{where} holds values of dtype {a.dtype}; expected numbers (float samples)"
        )
    return a.astype(np.float64, copy=False)


def _nonfinite_error(signal: str, member: str, x: np.ndarray, others: int = 0) -> DataError:
    bad = ~np.isfinite(x)
    first = int(np.argmax(bad))
    more = f" ({others} other member(s) too)" if others else ""
    return DataError(
        f"signal {signal!r} of member {member!r} holds {int(bad.sum())} non-finite "
        f"value(s) (first at sample {first}){more}; clean or drop the member"
    )


def _convert_signal(name: Any, value: Any, ids: Sequence[str]) -> SignalList:
    """Validate one signal (2-D array or per-member sequence) into a list of 1-D arrays."""
    n = len(ids)
    if isinstance(value, pd.DataFrame):
        value = value.to_numpy()
    if isinstance(value, np.ndarray) and value.dtype != object:
        if value.ndim != 2:
            raise DataError(
                f"signal {name!r} must be a 2-D array (n_members, n_samples) or a sequence "
                f"of one 1-D array (or None) per member; got an array of shape "
                f"{value.shape}. Wrap a single recording in a list: {{{name!r}: [x]}}"
            )
        a = _as_float(value, name, None)
        if a.shape[1] == 0:
            raise DataError(f"signal {name!r} has no samples (shape {a.shape})")
        finite = np.isfinite(a).all(axis=1)
        if not finite.all():
            rows = np.flatnonzero(~finite)
            raise _nonfinite_error(name, ids[rows[0]], a[rows[0]], len(rows) - 1)
        return list(_readonly(a))
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise DataError(
            f"signal {name!r} must be a 2-D array or a sequence of 1-D arrays (None where "
            f"a member lacks it); got {type(value).__name__}"
        )
    seq = list(value)
    if len(seq) != n:
        raise DataError(
            f"signal {name!r} has {len(seq)} entries; expected one per member ({n})"
        )
    out: SignalList = []
    for member, x in zip(ids, seq, strict=True):
        if x is None:
            out.append(None)
            continue
        a = _as_float(x, name, member)
        if a.ndim != 1:
            raise DataError(
                f"signal {name!r} of member {member!r} must be 1-D; got shape {a.shape}. "
                "Flatten it (np.ravel) or pass None when the member lacks the signal"
            )
        if a.size == 0:
            raise DataError(
                f"signal {name!r} of member {member!r} has no samples; pass None when the "
                "member lacks the signal"
            )
        if not np.isfinite(a).all():
            raise _nonfinite_error(name, member, a)
        out.append(_readonly(a))
    return out


def _column_values(value: Any, n: int, column: Any) -> Any:
    """Column values for a conditions table of ``n`` rows (scalars broadcast)."""
    if isinstance(value, pd.Series | pd.Index):
        value = pd.Series(value).reset_index(drop=True)
    elif np.ndim(value) == 0:
        return value
    if len(value) != n:
        raise DataError(
            f"condition column {column!r} has {len(value)} values; expected one per "
            f"member ({n})"
        )
    return value


def _n_rows(conditions: Any) -> int | None:
    if conditions is None:
        return None
    if isinstance(conditions, pd.DataFrame):
        return len(conditions)
    lengths = {len(v) for v in conditions.values() if np.ndim(v) != 0}
    if len(lengths) > 1:
        raise DataError(
            f"condition columns have different lengths {sorted(lengths)}; give one value "
            "per member in every column (or a scalar)"
        )
    return lengths.pop() if lengths else None
