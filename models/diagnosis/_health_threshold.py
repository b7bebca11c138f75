"""Alarm thresholds of a health model: split-conformal level, persistence, health index.

The pieces of :class:`~pdmkit.models.diagnosis.HealthModel` that do not depend on the
detector:

- :func:`conformal_threshold` - the split-conformal quantile of healthy calibration
  scores: with ``n`` scores, the ``ceil((n + 1)(1 - alpha))``-th smallest, so that a
  new healthy row exchangeable with them exceeds it with probability at most
  ``alpha`` (Vovk, Gammerman & Shafer 2005; Lei et al., JASA 113, 2018; for anomaly
  detection Laxhammar & Falkman 2015, Bates et al., Ann. Stat. 51, 2023);
- :func:`persistent_alarm` - an alarm that needs ``persistence`` consecutive
  exceedances to switch on and ``clear_after`` consecutive quiet rows to switch off
  (never, by default): one noisy recording does not alarm;
- :func:`calibration_split` - which healthy rows calibrate: the *last*
  ``fraction`` of each unit's rows, in the order given (time order), never random
  rows, so that the threshold is set on the part of the healthy window nearest to the
  rows it will judge.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pdmkit.errors import DataError, ModelError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["calibration_split", "conformal_threshold", "persistent_alarm"]


def conformal_threshold(scores: ArrayLike, alpha: float) -> float:
    """The split-conformal alarm threshold of healthy calibration scores.

    With ``n`` calibration scores the threshold is the ``k``-th smallest,
    ``k = ceil((n + 1)(1 - alpha))``. For a new score exchangeable with the
    calibration scores (a healthy row from the same process),
    ``P(score_new > threshold) <= alpha``, whatever the scores' distribution (and
    ``>= alpha - 1 / (n + 1)`` when there are no ties).

    Parameters
    ----------
    scores : array_like, shape (n,)
        Anomaly scores of healthy rows that the detector was *not* fitted on; NaN
        values (rows without a score) are dropped.
    alpha : float in (0, 1)
        Target false-alarm rate per row.

    Returns
    -------
    float

    Raises
    ------
    pdmkit.errors.DataError
        Fewer than ``ceil(1 / alpha) - 1`` scores: no finite threshold keeps the
        guarantee (the message says how many rows are needed).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import conformal_threshold
    >>> conformal_threshold(np.arange(1.0, 100.0), 0.05)   # k = ceil(100 * 0.95) = 95
    95.0
    """
    a = float(alpha)
    if not 0 < a < 1:
        raise ModelError(f"false_alarm_rate must be in (0, 1); got {alpha!r}.")
    s = np.asarray(scores, dtype=float).ravel()
    s = np.sort(s[~np.isnan(s)])
    n = s.size
    k = int(np.ceil((n + 1) * (1 - a) - 1e-9))
    if k > n:
        need = int(np.ceil(1 / a)) - 1
        raise DataError(
            f"the calibration part has {n} scored healthy rows; a false-alarm rate of "
            f"{a:g} needs at least {need} (give more healthy rows, a larger "
            "calibration_fraction or a larger false_alarm_rate)."
        )
    return float(s[max(k, 1) - 1])


def _runs(units, n: int) -> list[np.ndarray]:
    """Row positions of each unit, in the order given (one run when ``units`` is None)."""
    if units is None:
        return [np.arange(n)]
    u = np.asarray(units)
    if u.shape != (n,):
        raise DataError(f"units must have one label per row ({n}); got shape {u.shape}.")
    _, first, inverse = np.unique(u, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # units in order of first appearance
    return [np.flatnonzero(inverse == j) for j in order]


def persistent_alarm(
    exceed: ArrayLike,
    persistence: int = 3,
    clear_after: int | None = None,
    units: ArrayLike | None = None,
) -> np.ndarray:
    """Alarm state from threshold exceedances, with persistence and hysteresis.

    Rows are taken in the order given (time order) within each unit. The alarm
    switches on at the row that completes ``persistence`` consecutive exceedances,
    and off after ``clear_after`` consecutive rows without one (``None``: it stays
    on for the rest of the unit's rows, a latched alarm).

    Parameters
    ----------
    exceed : array_like of bool, shape (n,)
        Whether each row's score is above the threshold.
    persistence : int, default 3
        Consecutive exceedances that raise the alarm (1: every exceedance alarms).
    clear_after : int, optional
        Consecutive quiet rows that clear it; default never.
    units : array_like, shape (n,), optional
        Unit of each row: each unit's rows form their own sequence.

    Returns
    -------
    ndarray of bool, shape (n,)

    Examples
    --------
    >>> from pdmkit.models.diagnosis import persistent_alarm
    >>> hits = [0, 1, 1, 0, 1, 1, 1, 0, 0, 0, 1]
    >>> persistent_alarm(hits, persistence=3).astype(int).tolist()
    [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]
    >>> persistent_alarm(hits, persistence=3, clear_after=2).astype(int).tolist()
    [0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0]
    """
    e = np.asarray(exceed, dtype=bool).ravel()
    p = int(persistence)
    if p < 1:
        raise ModelError(f"persistence must be >= 1; got {persistence!r}.")
    c = None if clear_after is None else int(clear_after)
    if c is not None and c < 1:
        raise ModelError(f"clear_after must be >= 1 or None; got {clear_after!r}.")
    out = np.zeros(e.size, dtype=bool)
    for rows in _runs(units, e.size):
        out[rows] = alarm_runs(e[rows], p, c)[0]
    return out


def alarm_runs(
    exceed: ArrayLike,
    persistence: int,
    clear_after: int | None = None,
    *,
    run_length: int = 0,
    alarm: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """One unit's alarm states and exceedance run lengths, continuing a carried state.

    The rule of :func:`persistent_alarm` for rows that continue a sequence scored
    before: ``run_length`` consecutive exceedances and the ``alarm`` state carried in
    from the rows before (a history that scores one file at a time), so that scoring
    in pieces equals scoring at once.

    Returns
    -------
    alarms : ndarray of bool, shape (n,)
    runs : ndarray of int, shape (n,)
        Consecutive exceedances up to and including each row.

    Examples
    --------
    >>> from pdmkit.models.diagnosis import alarm_runs
    >>> alarm_runs([1, 1, 0, 1], persistence=3, run_length=1)[0].astype(int).tolist()
    [0, 1, 1, 1]
    """
    e = np.asarray(exceed, dtype=bool).ravel()
    alarms = np.zeros(e.size, dtype=bool)
    runs = np.zeros(e.size, dtype=int)
    over, quiet, on = int(run_length), 0, bool(alarm)
    for i, hit in enumerate(e):
        over, quiet = (over + 1, 0) if hit else (0, quiet + 1)
        if not on and over >= persistence:
            on = True
        elif on and clear_after is not None and quiet >= clear_after:
            on = False
        alarms[i], runs[i] = on, over
    return alarms, runs


def calibration_split(
    n: int, fraction: float, groups: ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fit and calibration rows: the last ``fraction`` of each unit's rows calibrate.

    Rows are in time order within each unit. Each unit gives its last
    ``round(fraction * n_unit)`` rows (at least one, and at least one left to fit
    on) to calibration, the rest to fitting: the threshold is set on the later part
    of every unit's healthy window, the part nearest to the rows it will judge, and
    no unit's calibration rows sit between its fitting rows.

    Parameters
    ----------
    n : int
        Number of healthy rows.
    fraction : float in (0, 1)
    groups : array_like, shape (n,), optional
        Unit of each row (default: one unit).

    Returns
    -------
    fit_rows, calibration_rows : ndarray of int

    Examples
    --------
    >>> from pdmkit.models.diagnosis import calibration_split
    >>> fit, cal = calibration_split(6, 0.5, groups=["a", "a", "a", "a", "b", "b"])
    >>> fit.tolist(), cal.tolist()
    ([0, 1, 4], [2, 3, 5])
    """
    f = float(fraction)
    if not 0 < f < 1:
        raise ModelError(f"calibration_fraction must be in (0, 1); got {fraction!r}.")
    fit, cal = [], []
    for rows in _runs(groups, int(n)):
        if rows.size < 2:
            raise DataError(
                f"a unit has {rows.size} healthy row(s); each needs at least 2 (one to "
                "fit on, one to calibrate)."
            )
        k = min(max(round(f * rows.size), 1), rows.size - 1)
        fit.append(rows[: rows.size - k])
        cal.append(rows[rows.size - k :])
    return np.sort(np.concatenate(fit)), np.sort(np.concatenate(cal))


def health_index_map(score: np.ndarray, median: float, threshold: float) -> np.ndarray:
    """``2 ** -(max(0, score - median) / (threshold - median))``: 1 -> 0.5 -> 0."""
    span = max(float(threshold) - float(median), np.finfo(float).tiny)
    excess = np.maximum(np.asarray(score, dtype=float) - float(median), 0.0)
    return np.exp2(-excess / span)
