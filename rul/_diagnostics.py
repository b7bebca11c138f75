"""Checks of RUL inputs that a model cannot make itself.

- :func:`ood_scores`: how far each unit's recent rows lie outside the training rows
  (a model trained on one fleet says nothing reliable about a unit unlike any of it;
  C-MAPSS FD003, fan and compressor wear, on a model of FD001, compressor wear only,
  doubles the error).
- :func:`shutdown_endings`: units whose last rows look like a machine switched off
  (values dropping to about zero, or frozen), not like the end of its life; a model
  reads them as the failure signature.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.rul._base import as_columns, check_columns, check_table, resolve_keys

#: A unit whose score exceeds this lies beyond the training rows (see ood_scores).
OOD_THRESHOLD = 1.0


def _numeric_keys(table, unit, time):
    table = check_table(table)
    unit, time = resolve_keys(table, unit, time)
    return table, unit, time


def ood_scores(
    train: pd.DataFrame,
    test: pd.DataFrame,
    columns: str | Sequence[str],
    *,
    unit: str = "unit",
    time: str | None = None,
    tail: int = 20,
    quantile: float = 0.99,
) -> pd.Series:
    """Out-of-distribution score of each test unit against the training rows.

    The Mahalanobis distance of a row to the training rows (their mean and covariance,
    with a small ridge so that collinear sensors do not blow up) is divided by the
    ``quantile`` of the training rows' own distances; a unit's score is the median of
    this ratio over its last ``tail`` rows (its current state). A score above 1
    (:data:`OOD_THRESHOLD`) says that most of the unit's recent rows lie further out
    than 99 % of the training rows: the model would extrapolate.

    Parameters
    ----------
    train, test : pandas.DataFrame
        Long tables (``unit``, time column, ``columns``).
    columns : sequence of str
        The indicator columns the model reads (constant ones in ``train`` are left out).
    unit, time : str
        Key columns (``time`` default ``"time"``, else ``"cycle"``).
    tail : int, default 20
        Recent rows of each test unit scored.
    quantile : float, default 0.99
        Quantile of the training rows' distances that scores 1.

    Returns
    -------
    pandas.Series
        Indexed by test unit, in order of first appearance.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import ood_scores
    >>> rng = np.random.default_rng(0)
    >>> train = pd.DataFrame({"unit": np.repeat([1, 2], 200), "time": np.tile(
    ...     np.arange(200), 2), "a": rng.normal(0, 1, 400), "b": rng.normal(0, 1, 400)})
    >>> test = pd.DataFrame({"unit": np.repeat(["near", "far"], 30),
    ...     "time": np.tile(np.arange(30), 2),
    ...     "a": np.r_[rng.normal(0, 1, 30), rng.normal(8, 1, 30)], "b": 0.0})
    >>> s = ood_scores(train, test, ["a", "b"])
    >>> bool(s["near"] < 1 < s["far"])
    True
    """
    train, unit, _ = _numeric_keys(train, unit, time)
    test, _, time_te = _numeric_keys(test, unit, time)
    columns = as_columns(columns)
    check_columns(train, columns, "columns")
    check_columns(test, columns, "columns")
    x = train[columns].to_numpy(dtype=float)
    # constant columns (up to rounding: C-MAPSS stores some at 1e-15 spread) say nothing
    keep = np.nanstd(x, axis=0) > 1e-9 * np.maximum(np.nanmean(np.abs(x), axis=0), 1.0)
    names = list(pd.unique(test[unit]))
    if not keep.any() or len(x) < 3:
        return pd.Series(np.zeros(len(names)), index=names, dtype=float, name="ood_score")
    x = x[:, keep]
    x = x[np.isfinite(x).all(axis=1)]
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    z = (x - mean) / scale
    cov = np.atleast_2d(np.cov(z, rowvar=False))
    cov += 1e-3 * np.eye(len(cov))
    inv = np.linalg.inv(cov)

    def distance(values):
        d = (values - mean) / scale
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", d, inv, d), 0.0))

    reference = float(np.quantile(distance(x), quantile))
    reference = reference if reference > 0 else 1.0
    scores = {}
    ordered = test.sort_values([unit, time_te], kind="stable")
    for name, part in ordered.groupby(unit, sort=False):
        rows = part[columns].to_numpy(dtype=float)[:, keep][-int(tail) :]
        rows = rows[np.isfinite(rows).all(axis=1)]
        scores[name] = float(np.median(distance(rows)) / reference) if len(rows) else 0.0
    return pd.Series([scores[n] for n in names], index=names, name="ood_score")


def shutdown_endings(
    table: pd.DataFrame,
    columns: str | Sequence[str],
    *,
    unit: str = "unit",
    time: str | None = None,
    max_rows: int = 5,
    zero_fraction: float = 0.1,
    min_flat: int = 3,
) -> pd.DataFrame:
    """Units whose last rows look like a shut-down rather than the end of a life.

    A trailing row is *near zero* when, in most of the columns that stay away from
    zero over the unit's history (their 5th percentile of ``|x|`` above 0), its
    ``|x|`` is below ``zero_fraction`` of that percentile; the trailing rows are
    *flat* when ``min_flat`` or more of them repeat the same values in every column
    that varied before. Only the last ``max_rows`` rows are examined.

    Parameters
    ----------
    table : pandas.DataFrame
        Long table of units.
    columns : sequence of str
        Indicator columns.
    unit, time : str
        Key columns.
    max_rows : int, default 5
    zero_fraction : float, default 0.1
    min_flat : int, default 3

    Returns
    -------
    pandas.DataFrame
        One row per flagged unit: ``unit``, ``kind`` (``"near zero"`` or ``"flat"``),
        ``rows`` (trailing rows affected), ``history_level`` (the median ``|x|`` of
        the first affected column before the ending), ``column``.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import shutdown_endings
    >>> v = np.r_[np.linspace(1, 2, 50), 0.001, 0.002]
    >>> table = pd.DataFrame({"unit": "b1", "time": np.arange(52), "vib": v})
    >>> shutdown_endings(table, ["vib"])[["unit", "kind", "rows"]].to_dict("records")
    [{'unit': 'b1', 'kind': 'near zero', 'rows': 2}]
    """
    table, unit, time = _numeric_keys(table, unit, time)
    columns = as_columns(columns)
    check_columns(table, columns, "columns")
    if not 0 < zero_fraction < 1:
        raise DataError(f"zero_fraction must be in (0, 1), got {zero_fraction!r}")
    rows = []
    ordered = table.sort_values([unit, time], kind="stable")
    for name, part in ordered.groupby(unit, sort=False):
        x = part[columns].to_numpy(dtype=float)
        n = len(x)
        if n < max_rows + 5:
            continue
        body = x[: n - max_rows]
        floor = np.nanpercentile(np.abs(body), 5, axis=0)
        away = floor > 0
        found = None
        if away.any():
            near = np.abs(x[-max_rows:, away]) < zero_fraction * floor[away]
            is_near = near.mean(axis=1) > 0.5
            k = _trailing(is_near)
            if k:
                col = np.array(columns)[away][0]
                level = float(np.nanmedian(np.abs(body[:, away][:, 0])))
                found = {
                    "kind": "near zero",
                    "rows": k,
                    "history_level": level,
                    "column": col,
                }
        varied = np.nanstd(body, axis=0) > 0
        if found is None and varied.any():
            same = np.r_[False, (np.diff(x[:, varied], axis=0) == 0).all(axis=1)]
            k = _trailing(same)
            if k + 1 >= min_flat:
                col = np.array(columns)[varied][0]
                level = float(np.nanmedian(np.abs(body[:, varied][:, 0])))
                found = {
                    "kind": "flat",
                    "rows": k + 1,
                    "history_level": level,
                    "column": col,
                }
        if found is not None:
            rows.append({"unit": name, **found})
    return pd.DataFrame(rows, columns=["unit", "kind", "rows", "history_level", "column"])


def _trailing(flags: np.ndarray) -> int:
    """Number of True values at the end of ``flags``."""
    k = 0
    for flag in flags[::-1]:
        if not flag:
            break
        k += 1
    return k
