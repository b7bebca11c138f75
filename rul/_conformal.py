"""Intervals that hold their level: conformal calibration of any RUL model.

A model's intervals are only as good as its assumptions. A linear degradation model on
an indicator that is really a random walk, for example, gives intervals that cover the
true RUL far less often than they claim (its noise model does not know that a walk's
deviations persist). :class:`ConformalRUL` keeps the model's estimates and rescales its
intervals so that they hold their level on units the model has not seen:

1. the training units are split into ``n_folds`` groups; for each, a copy of the model
   is fitted on the other units and follows the held-out units through their lives
   (``predict_trajectory``, every ``every``-th sample), where the true RUL is known
   (capped at the model's ``max_rul``, as its answers are);
2. each held-out prediction gives two scores, how far the true RUL lies beyond the
   upper and below the lower end in units of the model's own half-widths:
   ``(true - estimate) / (upper - estimate)`` and
   ``(estimate - true) / (estimate - lower)`` (half-widths floored at 1 % of their
   median, so a model with zero-width intervals still gets a scale);
3. the ``1 - (1 - level) / 2`` quantile of each side's scores (with the finite-sample
   correction ``ceil((n + 1) q) / n``) is the factor by which that side of the final
   model's intervals is stretched (or shrunk): ``upper' = estimate + f_up (upper -
   estimate)``, ``lower' = max(0, estimate - f_lo (estimate - lower))``.

The final model is fitted on all training units. This is split-conformal calibration
with normalised scores (Papadopoulos et al. 2002; Lei et al. 2018) applied across
folds; the units are what is exchangeable, not the many cuts of one unit, so the level
is met approximately (it is tested on simulated fleets), not with the finite-sample
guarantee of one score per unit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, clone

from pdmkit.errors import DataError
from pdmkit.rul._base import (
    RULModel,
    check_fitted,
    check_level,
    check_positive_int,
    check_rul_model,
    resolve_keys,
)
from pdmkit.rul._result import RULPrediction

if TYPE_CHECKING:
    from typing import Self


def _conformal_quantile(scores: np.ndarray, q: float) -> float:
    """The ``ceil((n + 1) q) / n`` empirical quantile (``inf`` when that exceeds 1)."""
    scores = np.sort(scores[np.isfinite(scores)])
    n = scores.size
    if n == 0:
        return np.inf
    k = int(np.ceil((n + 1) * q))
    return float(scores[k - 1]) if k <= n else np.inf


class ConformalRUL(BaseEstimator):
    """Wrap a RUL model so that its intervals hold their level on unseen units.

    See the module notes: out-of-fold trajectories of the training units give the
    factors by which each side of the model's intervals is stretched.

    Parameters
    ----------
    model : estimator
        Any pdmkit RUL model with intervals (``fit``, ``predict``,
        ``predict_trajectory``).
    level : float, optional
        Level of the calibrated intervals (default the model's ``level``, else 0.9).
    n_folds : int, default 5
        Groups of training units (at most the number of units).
    every : int, default 1
        Step between the cuts of each held-out unit.
    random_state : int, default 0
        Seed of the assignment of units to folds.
    unit, time : str
        Key columns (``time`` default ``"time"``, else ``"cycle"``).

    Attributes
    ----------
    model_ : estimator
        The model fitted on all training units.
    upper_factor_, lower_factor_ : float
        The stretch of each side of the model's intervals.
    scores_ : pandas.DataFrame
        The out-of-fold predictions (``unit``, ``time``, ``rul``, ``lower``,
        ``upper``, ``rul_true``) and their two scores.
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import ConformalRUL, LinearDegradationModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(30):                  # a random walk read as a straight line
    ...     x = np.r_[0, np.cumsum(rng.gamma(4.0, 0.25 * rng.uniform(0.02, 0.04), 99))]
    ...     end = np.flatnonzero(x >= 1.0)[0]
    ...     rows.append(pd.DataFrame({"unit": u, "time": np.arange(end + 1.0),
    ...                               "hi": x[: end + 1]}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> model = ConformalRUL(LinearDegradationModel(threshold=1.0)).fit(train)
    >>> bool(model.upper_factor_ > 1 and model.lower_factor_ > 1)   # widened
    True
    """

    def __init__(
        self,
        model: RULModel | None = None,
        *,
        level: float | None = None,
        n_folds: int = 5,
        every: int = 1,
        random_state: int = 0,
        unit: str = "unit",
        time: str | None = None,
    ) -> None:
        self.model = model
        self.level = level
        self.n_folds = n_folds
        self.every = every
        self.random_state = random_state
        self.unit = unit
        self.time = time

    def _level(self) -> float:
        if self.level is not None:
            return check_level(self.level)
        return check_level(getattr(self.model, "level", 0.9) or 0.9)

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Calibrate on out-of-fold trajectories, then fit the model on all units.

        Parameters
        ----------
        table : pandas.DataFrame
            Run-to-failure training units (a unit's last row is its failure; rows of
            units with ``failed`` False are used for fitting but not for scores).

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            Fewer than 2 training units, or no held-out prediction to score.
        """
        check_rul_model(self.model, "ConformalRUL")
        n_folds = check_positive_int(self.n_folds, "n_folds", 2)
        every = check_positive_int(self.every, "every")
        level = self._level()
        unit_col, time_col = resolve_keys(table, self.unit, self.time)
        units = pd.unique(table[unit_col])
        if len(units) < 2:
            raise DataError(
                f"ConformalRUL needs at least 2 training units to hold some out; got "
                f"{len(units)}"
            )
        failed_col = getattr(self.model, "failed", None) or "failed"
        last = table.groupby(unit_col, sort=False)[time_col].max()
        if failed_col in table.columns:
            ends = table.groupby(unit_col, sort=False)[failed_col].last().astype(bool)
            last = last[ends.reindex(last.index).to_numpy()]
        cap = getattr(self.model, "max_rul", None)
        folds = np.random.default_rng(self.random_state).permutation(len(units))
        folds = folds % min(n_folds, len(units))
        parts = []
        for k in np.unique(folds):
            held = set(units[folds == k])
            inside = table[unit_col].isin(held)
            fitted = clone(self.model).fit(table[~inside])
            scored = table[inside & table[unit_col].isin(last.index)]
            if scored.empty:
                continue
            path = fitted.predict_trajectory(scored, every=every).to_pandas()
            path["rul_true"] = last.reindex(path["unit"]).to_numpy() - path["time"]
            if cap is not None:  # the model answers min(RUL, cap): score it on that
                path["rul_true"] = np.minimum(path["rul_true"], cap)
            parts.append(path[["unit", "time", "rul", "lower", "upper", "rul_true"]])
        if not parts:
            raise DataError(
                "no held-out training unit ran to failure: nothing to calibrate on"
            )
        scores = pd.concat(parts, ignore_index=True)
        scores = scores[np.isfinite(scores["rul"]) & (scores["rul_true"] >= 0)]
        up_w = (scores["upper"] - scores["rul"]).to_numpy()
        lo_w = (scores["rul"] - scores["lower"]).to_numpy()
        floor = 0.01 * np.median(np.r_[up_w[up_w > 0], lo_w[lo_w > 0], 1e-12])
        err = (scores["rul_true"] - scores["rul"]).to_numpy()
        with np.errstate(invalid="ignore", divide="ignore"):
            scores["score_upper"] = err / np.maximum(up_w, floor)
            scores["score_lower"] = -err / np.maximum(lo_w, floor)
        q = 1 - (1 - level) / 2
        self.upper_factor_ = max(
            _conformal_quantile(scores["score_upper"].to_numpy(), q), 0
        )
        self.lower_factor_ = max(
            _conformal_quantile(scores["score_lower"].to_numpy(), q), 0
        )
        self._floor = float(floor)
        self.level_ = level
        self.scores_ = scores.reset_index(drop=True)
        self.model_ = clone(self.model).fit(table)
        self.n_units_ = len(units)
        return self

    def _calibrated(self, pred: RULPrediction) -> RULPrediction:
        est = pred.estimate
        up_w = np.maximum(pred.upper - est, self._floor)
        lo_w = np.maximum(est - pred.lower, self._floor)
        with np.errstate(invalid="ignore"):
            upper = np.where(np.isfinite(est), est + self.upper_factor_ * up_w, np.inf)
            lower = np.where(
                np.isfinite(est),
                np.maximum(est - self.lower_factor_ * lo_w, 0.0),
                pred.lower,
            )
        cap = getattr(self.model_, "max_rul", None)
        if cap is not None:
            upper, lower = np.minimum(upper, cap), np.minimum(lower, cap)
        return RULPrediction(
            pred.unit,
            pred.time,
            est,
            lower,
            upper,
            level=self.level_,
            model=f"ConformalRUL({pred.model})",
            extra=pred.extra,
        )

    def predict(self, table: pd.DataFrame) -> RULPrediction:
        """The model's RUL of each unit at its last time, with calibrated intervals."""
        check_fitted(self, "model_")
        return self._calibrated(self.model_.predict(table))

    def predict_trajectory(self, table: pd.DataFrame, **kwargs: Any) -> RULPrediction:
        """The model's trajectory predictions with calibrated intervals."""
        check_fitted(self, "model_")
        return self._calibrated(self.model_.predict_trajectory(table, **kwargs))
