"""Shared input handling for the signal feature functions (private).

Every signal function accepts an array of any shape with the samples along ``axis``;
internally it works on a 2-D ``(n_rows, n_samples)`` view and puts the batch shape back
on the way out.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pdmkit._checks import check_fs
from pdmkit.errors import DataError

__all__ = [
    "MemberDataError",
    "check_finite",
    "check_fs",
    "from_rows",
    "nonfinite_rows",
    "raise_nonfinite",
    "to_rows",
]

#: How many offending rows an error message lists before it says "and N more".
_MAX_LISTED = 8


class MemberDataError(DataError):
    """A :class:`~pdmkit.errors.DataError` about particular member rows.

    ``rows`` holds the offending row indices (relative to the array that was checked) and
    ``problem`` the message without the row wording, so that callers that know the
    member ids (``extract_ensemble``) can restate the message with those ids.
    """

    def __init__(self, message: str, *, rows: Sequence[int] = (), problem: str = ""):
        super().__init__(message)
        self.rows = [int(r) for r in rows]
        self.problem = problem or message


def list_rows(rows: Sequence[int]) -> str:
    """Return ``"3, 17 and 40"``-style text naming at most a few rows."""
    rows = [int(r) for r in rows]
    shown = ", ".join(str(r) for r in rows[:_MAX_LISTED])
    if len(rows) > _MAX_LISTED:
        shown += f" and {len(rows) - _MAX_LISTED} more"
    return shown


def to_rows(x, axis: int = -1, name: str = "x") -> tuple[np.ndarray, tuple[int, ...]]:
    """Return a float 2-D ``(n_rows, n_samples)`` view of ``x`` and its batch shape.

    The samples lie along ``axis``; all other axes are flattened into rows. The data is
    not copied when it already is float64 with the samples on the last axis.
    """
    arr = np.asarray(x)
    if arr.dtype.kind not in "fiub":
        raise DataError(
            f"{name} must hold real numbers (float or int samples), got dtype {arr.dtype}; "
            "convert it with np.asarray(..., dtype=float)"
        )
    if arr.ndim == 0:
        raise DataError(
            f"{name} is a scalar; expected a 1-D signal or a 2-D (members, samples) array"
        )
    try:
        arr = np.moveaxis(arr, axis, -1)
    except np.exceptions.AxisError:
        raise DataError(
            f"axis={axis} is out of range for {name} with {arr.ndim} dimension(s) "
            f"(shape {arr.shape}); use axis=-1 for samples on the last axis"
        ) from None
    if arr.shape[-1] == 0:
        raise DataError(
            f"{name} is empty: 0 samples along axis {axis} (shape {np.shape(x)}); "
            "pass at least one sample per member"
        )
    batch_shape = arr.shape[:-1]
    if arr.dtype != np.float64:
        arr = arr.astype(np.float64)
    return arr.reshape(-1, arr.shape[-1]), batch_shape


def from_rows(values: np.ndarray, batch_shape: tuple[int, ...]):
    """Give per-row results the batch shape back (a Python float for a 1-D input)."""
    values = np.asarray(values)
    if batch_shape == ():
        return float(values.reshape(-1)[0])
    return values.reshape(batch_shape)


def nonfinite_rows(x2d: np.ndarray, row_offset: int = 0) -> tuple[list[int], list[str]]:
    """Rows of ``x2d`` holding NaN or inf (plus ``row_offset``), and what each holds.

    One cheap pass: a row sum is non-finite whenever the row holds a NaN or an inf, and
    only those candidate rows are inspected sample by sample (a sum can also overflow to
    inf for huge finite values, which the second look rules out).
    """
    if x2d.dtype.kind != "f":
        return [], []
    with np.errstate(over="ignore", invalid="ignore"):
        sums = np.add.reduce(x2d, axis=-1)
    bad: list[int] = []
    details: list[str] = []
    for r in np.flatnonzero(~np.isfinite(sums)):
        row = x2d[r]
        n_nan = int(np.isnan(row).sum())
        n_inf = int(np.isinf(row).sum())
        if n_nan or n_inf:
            first = int(np.flatnonzero(~np.isfinite(row))[0])
            bad.append(int(r) + row_offset)
            details.append(
                f"row {int(r) + row_offset}: {n_nan} NaN and {n_inf} inf, "
                f"first at sample {first}"
            )
    return bad, details


def raise_nonfinite(bad: Sequence[int], details: Sequence[str], name: str = "x") -> None:
    """Raise :class:`MemberDataError` for the rows ``bad`` (no-op when empty)."""
    if not bad:
        return
    problem = (
        "NaN or inf samples; expected finite values. Drop those members or fill the "
        "gaps (e.g. pandas interpolate) before extracting features"
    )
    plural = "s" if len(bad) > 1 else ""
    raise MemberDataError(
        f"{name}: member row{plural} {list_rows(bad)}: {problem} "
        f"({'; '.join(details[:3])})",
        rows=bad,
        problem=problem,
    )


def check_finite(x2d: np.ndarray, name: str = "x", row_offset: int = 0) -> None:
    """Raise :class:`MemberDataError` naming the rows of ``x2d`` holding NaN or inf."""
    raise_nonfinite(*nonfinite_rows(x2d, row_offset), name=name)
