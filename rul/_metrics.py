"""Prognostic performance metrics.

Point metrics over many units (one prediction per unit): :func:`rmse`, :func:`mae`,
:func:`phm08_score` and :func:`interval_coverage`. Metrics over one unit's trajectory of
predictions (Saxena et al. 2009/2010): :func:`alpha_lambda_accuracy`,
:func:`relative_accuracy` and :func:`prognostic_horizon`. Their arguments are the
prediction times, the predicted RULs and the unit's end of life ``eol`` (the time it
failed), so that the true RUL at time ``t`` is ``eol - t``; time is counted from the
start of the unit's life.

References
----------
A. Saxena, K. Goebel, D. Simon, N. Eklund, "Damage propagation modeling for aircraft
engine run-to-failure simulation", PHM 2008 (the PHM08 score).
A. Saxena, J. Celaya, B. Saha, S. Saha, K. Goebel, "Metrics for offline evaluation of
prognostic performance", IJPHM 1 (2010) (alpha-lambda accuracy, relative accuracy,
prognostic horizon).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np

from pdmkit.errors import DataError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def _vector(values, name: str) -> np.ndarray:
    x = np.asarray(values, dtype=float)
    if x.ndim == 0:
        x = x.reshape(1)
    if x.ndim != 1:
        raise DataError(
            f"{name} must be 1-D (one value per unit or time), got shape {x.shape}"
        )
    if x.size == 0:
        raise DataError(f"{name} is empty")
    if np.isnan(x).any():
        raise DataError(f"{name} has {int(np.isnan(x).sum())} NaN value(s)")
    return x


def _pair(rul_true, rul_pred) -> tuple[np.ndarray, np.ndarray]:
    t = _vector(rul_true, "rul_true")
    p = _vector(rul_pred, "rul_pred")
    if t.shape != p.shape:
        raise DataError(
            f"rul_true has {t.size} values and rul_pred {p.size}; give one prediction per "
            "true RUL"
        )
    if not np.isfinite(t).all():
        raise DataError("rul_true must be finite")
    return t, p


def rmse(rul_true: ArrayLike, rul_pred: ArrayLike) -> float:
    """Root mean squared error of the predicted RULs.

    Parameters
    ----------
    rul_true, rul_pred : array_like
        True and predicted RUL, one per unit.

    Returns
    -------
    float
        ``sqrt(mean((rul_pred - rul_true) ** 2))``; ``inf`` if a prediction is infinite.

    Examples
    --------
    >>> from pdmkit.rul import rmse
    >>> rmse([10, 20], [13, 16])
    3.5355339059327378
    """
    t, p = _pair(rul_true, rul_pred)
    return float(np.sqrt(np.mean((p - t) ** 2)))


def mae(rul_true: ArrayLike, rul_pred: ArrayLike) -> float:
    """Mean absolute error of the predicted RULs.

    Examples
    --------
    >>> from pdmkit.rul import mae
    >>> mae([10, 20], [13, 16])
    3.5
    """
    t, p = _pair(rul_true, rul_pred)
    return float(np.mean(np.abs(p - t)))


def phm08_score(rul_true: ArrayLike, rul_pred: ArrayLike) -> float:
    """The asymmetric scoring function of the PHM08 data challenge (lower is better).

    With ``d = rul_pred - rul_true``, each unit scores ``exp(-d / 13) - 1`` when it is
    predicted early (``d < 0``) and ``exp(d / 10) - 1`` when late (``d >= 0``): late
    predictions, which let a machine run past its failure, cost more. The scores are
    summed over units.

    Parameters
    ----------
    rul_true, rul_pred : array_like
        True and predicted RUL, one per unit.

    Returns
    -------
    float
        Sum of the per-unit scores (0 for perfect predictions).

    References
    ----------
    A. Saxena, K. Goebel, D. Simon, N. Eklund, "Damage propagation modeling for
    aircraft engine run-to-failure simulation", PHM 2008, eq. 1.

    Examples
    --------
    >>> from pdmkit.rul import phm08_score
    >>> round(phm08_score([50, 50], [40, 60]), 4)  # exp(10/13) - 1 + exp(1) - 1
    2.8764
    """
    t, p = _pair(rul_true, rul_pred)
    d = p - t
    with np.errstate(over="ignore"):
        s = np.where(d < 0, np.expm1(-d / 13.0), np.expm1(d / 10.0))
    return float(s.sum())


def interval_coverage(rul_true: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> float:
    """Fraction of true RULs inside their predicted intervals ``[lower, upper]``.

    Examples
    --------
    >>> from pdmkit.rul import interval_coverage
    >>> interval_coverage([10, 20, 30, 40], [5, 21, 25, 35], [15, 25, 35, 45])
    0.75
    """
    t = _vector(rul_true, "rul_true")
    lo = _vector(lower, "lower")
    hi = _vector(upper, "upper")
    if not (t.shape == lo.shape == hi.shape):
        raise DataError(
            f"rul_true, lower and upper have {t.size}, {lo.size} and {hi.size} values; "
            "expected one interval per true RUL"
        )
    if (lo > hi).any():
        raise DataError("lower is above upper for some intervals")
    return float(np.mean((t >= lo) & (t <= hi)))


def _trajectory(time, rul_pred, eol):
    t = _vector(time, "time")
    r = _vector(rul_pred, "rul_pred")
    if t.shape != r.shape:
        raise DataError(
            f"time has {t.size} values and rul_pred {r.size}; expected one per time"
        )
    if len(t) > 1 and (np.diff(t) <= 0).any():
        raise DataError("time must be strictly increasing")
    eol = float(eol)
    if not np.isfinite(eol) or eol < t[-1]:
        raise DataError(
            f"eol={eol:g} must be a finite time at or after the last prediction time "
            f"({t[-1]:g}); it is the time the unit failed"
        )
    return t, r, eol


def _at_lambda(t, r, eol, lam, t_start):
    lam = np.asarray(lam, dtype=float)
    if ((lam < 0) | (lam > 1)).any():
        raise ValueError(f"lam must lie in [0, 1], got {lam}")
    t_p = t[0] if t_start is None else float(t_start)
    t_lam = t_p + lam * (eol - t_p)
    # the prediction available at t_lambda: the latest one made at or before it
    idx = np.searchsorted(t, t_lam + 1e-9 * max(1.0, abs(eol)), side="right") - 1
    if (idx < 0).any():
        raise DataError(
            f"no prediction at or before t_lambda={np.min(t_lam):g}; the first prediction "
            f"is at time {t[0]:g}"
        )
    return idx


def alpha_lambda_accuracy(
    time: ArrayLike,
    rul_pred: ArrayLike,
    eol: float,
    *,
    alpha: float = 0.2,
    lam: float | ArrayLike = 0.5,
    t_start: float | None = None,
) -> bool | np.ndarray:
    """Whether the prediction at ``t_lambda`` lies within ``±alpha`` of the true RUL.

    ``t_lambda = t_P + lam * (eol - t_P)`` with ``t_P`` the first prediction time (or
    ``t_start``). The prediction used is the latest one made at or before
    ``t_lambda``, at time ``t_j``; it is accurate when
    ``(1 - alpha) r* <= r(t_j) <= (1 + alpha) r*`` with ``r* = eol - t_j``.

    Parameters
    ----------
    time : array_like
        Increasing prediction times.
    rul_pred : array_like
        Predicted RUL at each time.
    eol : float
        Time the unit failed.
    alpha : float, default 0.2
        Relative accuracy band.
    lam : float or array_like, default 0.5
        Fraction(s) of the prediction window ``[t_P, eol]``.
    t_start : float, optional
        Start of the prediction window (default ``time[0]``).

    Returns
    -------
    bool or numpy.ndarray of bool
        One per ``lam``.

    Examples
    --------
    >>> from pdmkit.rul import alpha_lambda_accuracy
    >>> t = [0, 25, 50, 75]                    # eol = 100: true RUL 100, 75, 50, 25
    >>> alpha_lambda_accuracy(t, [80, 70, 55, 40], 100, alpha=0.2, lam=[0.25, 0.5, 0.75])
    array([ True,  True, False])
    """
    t, r, eol = _trajectory(time, rul_pred, eol)
    if not 0 < alpha:
        raise ValueError(f"alpha must be positive, got {alpha}")
    idx = _at_lambda(t, r, eol, lam, t_start)
    truth = eol - t[idx]
    ok = (r[idx] >= (1 - alpha) * truth) & (r[idx] <= (1 + alpha) * truth)
    return bool(ok) if np.ndim(lam) == 0 else ok


def relative_accuracy(
    time: ArrayLike,
    rul_pred: ArrayLike,
    eol: float,
    *,
    lam: float | ArrayLike = 0.5,
    t_start: float | None = None,
) -> float | np.ndarray:
    """Relative accuracy ``1 - |r* - r| / r*`` of the prediction at ``t_lambda``.

    The prediction is chosen as in :func:`alpha_lambda_accuracy`; 1 is perfect, and it
    can fall below 0 for predictions off by more than the true RUL.

    Examples
    --------
    >>> from pdmkit.rul import relative_accuracy
    >>> relative_accuracy([0, 25, 50, 75], [80, 70, 55, 40], 100, lam=0.5)  # 1 - 5/50
    0.9
    """
    t, r, eol = _trajectory(time, rul_pred, eol)
    idx = _at_lambda(t, r, eol, lam, t_start)
    truth = eol - t[idx]
    with np.errstate(divide="ignore", invalid="ignore"):
        ra = 1.0 - np.abs(truth - r[idx]) / truth
    return float(ra) if np.ndim(lam) == 0 else ra


def prognostic_horizon(
    time: ArrayLike, rul_pred: ArrayLike, eol: float, *, alpha: float = 0.05
) -> float:
    """Prognostic horizon: how long before failure the predictions became trustworthy.

    ``PH = eol - t_i`` where ``t_i`` is the first prediction time from which every
    later prediction stays within ``±alpha * eol`` of the true RUL ``eol - t`` (the
    sustained reading of Saxena et al.'s definition). 0 when the last prediction is
    outside the band.

    Parameters
    ----------
    time, rul_pred : array_like
        Increasing prediction times and the RUL predicted at each.
    eol : float
        Time the unit failed (time counted from the start of its life).
    alpha : float, default 0.05
        Half-width of the band as a fraction of ``eol``.

    Returns
    -------
    float

    Examples
    --------
    >>> from pdmkit.rul import prognostic_horizon
    >>> # eol = 100, band +-10: errors 30, 2, 12, 4, 1 -> inside from t = 60 on
    >>> prognostic_horizon([0, 20, 40, 60, 80], [130, 78, 72, 44, 19], 100, alpha=0.1)
    40.0
    """
    t, r, eol = _trajectory(time, rul_pred, eol)
    if not 0 < alpha:
        raise ValueError(f"alpha must be positive, got {alpha}")
    inside = np.abs(r - (eol - t)) <= alpha * eol
    outside = np.flatnonzero(~inside)
    first = 0 if outside.size == 0 else outside[-1] + 1
    if first >= len(t):
        return 0.0
    return float(eol - t[first])


def rul_metrics(
    rul_true: ArrayLike,
    rul_pred: ArrayLike,
    lower: ArrayLike | None = None,
    upper: ArrayLike | None = None,
) -> dict[str, float]:
    """RMSE, MAE, PHM08 score, mean error and (with intervals) coverage and width.

    Parameters
    ----------
    rul_true, rul_pred : array_like
        True and predicted RUL, one per unit.
    lower, upper : array_like, optional
        Predicted intervals.

    Returns
    -------
    dict
        ``rmse, mae, phm08_score, bias`` (mean of predicted - true), ``n``, and when
        intervals are given ``coverage`` and ``mean_width``.

    Examples
    --------
    >>> from pdmkit.rul import rul_metrics
    >>> m = rul_metrics([10, 20], [12, 20], lower=[8, 21], upper=[14, 30])
    >>> m["mae"], m["bias"], m["coverage"], m["mean_width"]
    (1.0, 1.0, 0.5, 7.5)
    """
    t, p = _pair(rul_true, rul_pred)
    out = {
        "rmse": rmse(t, p),
        "mae": mae(t, p),
        "phm08_score": phm08_score(t, p),
        "bias": float(np.mean(p - t)),
        "n": int(t.size),
    }
    if lower is not None and upper is not None:
        out["coverage"] = interval_coverage(t, lower, upper)
        width = _vector(upper, "upper") - _vector(lower, "lower")
        out["mean_width"] = float(np.mean(width))
    return out


#: The coverage check's rule: intervals are "far below" their level when the covered
#: fraction is more than ``COVERAGE_TOLERANCE`` below it AND a one-sided exact binomial
#: test rejects "the intervals hold their level" at ``COVERAGE_ALPHA``.
COVERAGE_TOLERANCE = 0.05
COVERAGE_ALPHA = 0.01


def coverage_check(
    rul_true: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    level: float,
    *,
    n_units: int | None = None,
    what: str = "held-out units",
    warn: bool = True,
) -> dict:
    """Whether intervals hold their level on units with known RUL; warn when far below.

    The empirical coverage ``c`` (fraction of true RULs inside ``[lower, upper]``) of
    ``n`` units is compared with the nominal ``level``. The rule: the intervals fall
    *far below* their level when ``c < level - COVERAGE_TOLERANCE`` (0.05) **and** a
    one-sided exact binomial test of "each unit is covered with probability ``level``"
    gives ``P(X <= covered) < COVERAGE_ALPHA`` (0.01), ``X ~ Binomial(n, level)``. The
    tolerance keeps a small shortfall on many units quiet, the test a few misses on few
    units (5 units at 90 %: 2 covered warns, 3 do not). Then a ``UserWarning`` says so
    in one sentence with the numbers.

    Predictions along a unit's life (a trajectory) are not independent: pass the number
    of units as ``n_units``, and the test counts ``round(c * n_units)`` covered of
    ``n_units`` (conservative).

    Parameters
    ----------
    rul_true, lower, upper : array_like
        True RUL and predicted interval, one per prediction.
    level : float
        Nominal level of the intervals (e.g. 0.9).
    n_units : int, optional
        Independent units behind the predictions (default: one per prediction).
    what : str, default "held-out units"
        What the predictions are, for the message.
    warn : bool, default True
        Raise the warning (else only return the message).

    Returns
    -------
    dict
        ``coverage``, ``level``, ``n`` (units tested), ``n_covered``, ``p_value``,
        ``far_below`` (bool), ``rule`` and ``message`` (None when not far below).

    Examples
    --------
    >>> import warnings
    >>> from pdmkit.rul import coverage_check
    >>> true = [10.0] * 20
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     bad = coverage_check(true, [11.0] * 18 + [9.0] * 2, [20.0] * 20, 0.9)
    >>> bad["coverage"], bad["far_below"], str(caught[0].message).split(" (")[0]
    (0.1, True, "90 % intervals covered 10 % of held-out units' true RUL")
    >>> coverage_check(true, [9.0] * 19 + [11.0], [20.0] * 20, 0.9)["far_below"]
    False
    """
    from scipy.stats import binom

    lvl = float(level)
    if not 0 < lvl < 1:
        raise DataError(f"level must be in (0, 1), got {level!r}")
    cov = interval_coverage(rul_true, lower, upper)
    n = len(np.asarray(rul_true).reshape(-1)) if n_units is None else int(n_units)
    if n < 1:
        raise DataError(f"n_units must be at least 1, got {n_units!r}")
    k = round(cov * n)
    p = float(binom.cdf(k, n, lvl))
    far = bool(cov < lvl - COVERAGE_TOLERANCE and p < COVERAGE_ALPHA)
    pct = f"{100 * lvl:g} %"
    message = None
    if far:
        counted = (
            f"{k} of {n}"
            if n_units is None
            else f"about {k} of {n} units: the predictions along a unit's life count as one"
        )
        message = (
            f"{pct} intervals covered {100 * cov:.0f} % of {what}' true RUL ({counted}; "
            f"a one-sided binomial test puts this below {pct} at p = {p:.2g}): the "
            f"intervals are far too narrow to be read as {pct} intervals; recalibrate "
            "them (pdmkit.rul.ConformalRUL, pdmkit rul --calibrate) or quote the "
            "measured coverage"
        )
        if warn:
            warnings.warn(message, UserWarning, stacklevel=2)
    return {
        "coverage": cov,
        "level": lvl,
        "n": n,
        "n_covered": k,
        "p_value": p,
        "far_below": far,
        "rule": (
            f"far below: coverage < level - {COVERAGE_TOLERANCE:g} and one-sided "
            f"binomial p < {COVERAGE_ALPHA:g}"
        ),
        "message": message,
    }
