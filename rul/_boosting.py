"""A learned RUL model: gradient-boosted trees on windowed indicators.

Each point of a unit's history becomes one row of summary features of its recent
past: for every indicator the mean of the last ``short_window`` and of the last
``window`` samples and the least-squares slope over the last ``window`` samples (per
time unit; fewer samples early in a unit's life), and, by default, the unit's age (its
time column). scikit-learn's :class:`~sklearn.ensemble.HistGradientBoostingRegressor`
regresses the RUL on these rows (capped at ``max_rul`` when one is given, the
piecewise-linear target of the C-MAPSS literature).

Intervals are cross-conformal (CV+ in spirit, Barber et al. 2021): the training units
are split into ``n_folds`` groups, one model is fitted without each group, the mean of
the fold models is the estimate, and the out-of-fold residuals of every point of the
held-out units, binned by the predicted RUL (the error grows with the RUL), give each
bin's interval offsets. The units are what is exchangeable, so the level holds
approximately, not with the finite-sample guarantee of one score per unit.

The fitted trees are kept as plain arrays (split feature, threshold, children, leaf
value) and walked in numpy: the saved model holds numbers only, and predictions equal
scikit-learn's own (a test checks it).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator
from threadpoolctl import threadpool_limits

from pdmkit.errors import DataError
from pdmkit.rul._base import (
    LearnedMixin,
    Unit,
    check_fitted,
    check_max_rul,
    keep_init_args,
)

if TYPE_CHECKING:
    from typing import Self

    from numpy.typing import ArrayLike

    from pdmkit.rul._result import RULPrediction

_CHUNK = 4096  # rows of windows built at once (memory: rows * window * features)


def window_features(
    t: ArrayLike, x: ArrayLike, *, window: int = 30, short_window: int = 5
) -> np.ndarray:
    """Summary features of the recent past at every sample of one unit's history.

    Parameters
    ----------
    t : array_like, shape (n,)
        Times, increasing.
    x : array_like, shape (n, p)
        Indicator values.
    window, short_window : int
        Samples of the long and the short window (fewer at the start of the history).

    Returns
    -------
    numpy.ndarray, shape (n, 3 p)
        Per indicator, in blocks of ``p`` columns: the mean of the last
        ``short_window`` samples, the mean of the last ``window`` samples and the
        least-squares slope over the last ``window`` samples (0 with one sample).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.rul._boosting import window_features
    >>> t = np.arange(6.0)
    >>> f = window_features(t, 2 * t[:, None] + 1, window=4, short_window=2)
    >>> f[-1].tolist()          # mean of 9, 11; mean of 5..11; slope 2
    [10.0, 8.0, 2.0]
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    n, p = x.shape
    w, s = int(window), min(int(short_window), int(window))
    out = np.empty((n, 3 * p))
    tc = t - t[0]  # times from the unit's start: no cancellation in the slope
    pad_t = np.r_[np.full(w - 1, np.nan), tc]
    pad_x = np.vstack([np.full((w - 1, p), np.nan), x])
    tv = np.lib.stride_tricks.sliding_window_view(pad_t, w)  # (n, w)
    xv = np.lib.stride_tricks.sliding_window_view(pad_x, w, axis=0)  # (n, p, w)
    for lo in range(0, n, _CHUNK):
        hi = min(n, lo + _CHUNK)
        tw, xw = tv[lo:hi], xv[lo:hi]
        valid = ~np.isnan(tw)  # (m, w)
        k = valid.sum(axis=1)[:, None]
        out[lo:hi, 2 * p : 3 * p] = 0.0
        mean_long = np.nansum(xw, axis=2) / k
        mean_short = np.nanmean(xw[:, :, w - s :], axis=2)
        tm = np.nansum(tw, axis=1, keepdims=True) / k
        dt = np.where(valid, tw - tm, 0.0)
        sxx = np.sum(dt * dt, axis=1)[:, None]
        dx = np.where(valid[:, None, :], xw - mean_long[:, :, None], 0.0)
        sxy = np.einsum("mw,mpw->mp", dt, dx)
        slope = np.divide(sxy, sxx, out=np.zeros_like(sxy), where=sxx > 0)
        out[lo:hi, :p] = mean_short
        out[lo:hi, p : 2 * p] = mean_long
        out[lo:hi, 2 * p :] = slope
    return out


def _tree_arrays(hgb) -> dict:
    """The trees of a fitted HistGradientBoostingRegressor as flat arrays."""
    feature, threshold, left, right, missing, leaf, value, roots = ([] for _ in range(8))
    offset = 0
    for (predictor,) in hgb._predictors:  # one tree per iteration (regression)
        nodes = predictor.nodes
        if nodes["is_categorical"].any():
            raise DataError("categorical splits are not supported")  # never built here
        roots.append(offset)
        feature.append(nodes["feature_idx"].astype(np.int64))
        threshold.append(nodes["num_threshold"].astype(float))
        left.append(nodes["left"].astype(np.int64) + offset)
        right.append(nodes["right"].astype(np.int64) + offset)
        missing.append(nodes["missing_go_to_left"].astype(bool))
        leaf.append(nodes["is_leaf"].astype(bool))
        value.append(nodes["value"].astype(float))
        offset += len(nodes)
    cat = np.concatenate
    return {
        "feature": cat(feature),
        "threshold": cat(threshold),
        "left": cat(left),
        "right": cat(right),
        "missing_left": cat(missing),
        "leaf": cat(leaf),
        "value": cat(value),
        "roots": np.asarray(roots, dtype=np.int64),
        "baseline": float(np.ravel(hgb._baseline_prediction)[0]),
    }


def _walk(trees: dict, X: np.ndarray) -> np.ndarray:
    """Sum of the trees' leaf values for each row of ``X`` plus the baseline."""
    n = len(X)
    total = np.full(n, trees["baseline"])
    if n == 0:
        return total
    rows = np.arange(n)
    feature, threshold = trees["feature"], trees["threshold"]
    left, right, leaf = trees["left"], trees["right"], trees["leaf"]
    missing = trees["missing_left"]
    node = np.repeat(trees["roots"][None, :], n, axis=0)  # (n, trees)
    active = ~leaf[node]
    while active.any():
        r, c = np.nonzero(active)
        nd = node[r, c]
        v = X[rows[r], feature[nd]]
        go_left = np.where(np.isnan(v), missing[nd], v <= threshold[nd])
        node[r, c] = np.where(go_left, left[nd], right[nd])
        active[r, c] = ~leaf[node[r, c]]
    return total + trees["value"][node].sum(axis=1)


class BoostingRULModel(LearnedMixin, BaseEstimator):
    """RUL regression by gradient-boosted trees on windowed indicators.

    See the module notes: features of the recent past of each point of a history,
    :class:`~sklearn.ensemble.HistGradientBoostingRegressor` per fold of training
    units, the fold models' mean as the estimate, out-of-fold residuals for the
    intervals.

    Parameters
    ----------
    features : sequence of str, optional
        Indicator columns; default every numeric column but the keys and labels
        (``rul``, ``rul_true_final``, ``failed``), constant ones dropped.
    window : int, default 30
        Samples of the long window (means and slopes).
    short_window : int, default 5
        Samples of the short window (the recent level).
    time_feature : bool, default True
        Add the unit's age (its time column) as a feature: useful when every unit's
        clock starts when it is new, as in C-MAPSS.
    max_rul : float or None, default None
        Training targets are ``min(RUL, max_rul)``; predictions lie in
        ``[0, max_rul]``. None: the true RUL, uncapped.
    n_folds : int, default 5
        Fold models (each without one group of units); at most the number of units.
    level : float, default 0.9
        Level of the intervals.
    max_iter, learning_rate, max_leaf_nodes, min_samples_leaf, l2_regularization
        Settings of each :class:`~sklearn.ensemble.HistGradientBoostingRegressor`
        (default 100, 0.1, 31, 20, 0; no early stopping: the rows of one unit are
        too alike for a random validation split).
    n_bins : int, default 4
        Bins of predicted RUL for the interval offsets.
    random_state : int, default 0
        Seed of the fold split and of the boosting.
    n_threads : int, default 1
        OpenMP threads of the boosting. One by default: on a machine shared with
        other work, scikit-learn's default (every core) spins waiting for busy cores
        (a 1 s fit took 74 s on 2 loaded cores).
    unit, time, failed : str
        Key columns.

    Attributes
    ----------
    features_ : list of str
    dropped_ : dict
        Constant features left out.
    feature_names_ : list of str
        Names of the columns the trees read (``<indicator>/mean5`` ...).
    trees_ : list of dict
        Each fold model's trees as arrays.
    residual_bins_ : pandas.DataFrame
        Per bin of predicted RUL: its edges, the count and the interval offsets.
    train_range_ : (float, float)
        Smallest and largest training target.
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import BoostingRULModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(12):
    ...     life = int(rng.integers(60, 100)); t = np.arange(1, life + 1)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t,
    ...         "x": (t / life) ** 2 + rng.normal(0, 0.02, life)}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> model = BoostingRULModel(window=10, n_folds=3, max_iter=50).fit(train)
    >>> p = model.predict(train[(train.unit == 0) & (train.time <= 40)])
    >>> bool(p.lower[0] <= p.estimate[0] <= p.upper[0])
    True
    """

    _int_settings = (
        ("window", 2),
        ("short_window", 1),
        ("n_folds", 2),
        ("max_iter", 1),
        ("max_leaf_nodes", 2),
        ("min_samples_leaf", 1),
        ("n_bins", 1),
        ("n_threads", 1),
    )

    def __init__(
        self,
        features: Sequence[str] | None = None,
        *,
        window: int = 30,
        short_window: int = 5,
        time_feature: bool = True,
        max_rul: float | None = None,
        n_folds: int = 5,
        level: float = 0.9,
        max_iter: int = 100,
        learning_rate: float = 0.1,
        max_leaf_nodes: int = 31,
        min_samples_leaf: int = 20,
        l2_regularization: float = 0.0,
        n_bins: int = 4,
        random_state: int = 0,
        n_threads: int = 1,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    # ------------------------------------------------------------------ data
    def _rows(self, u: Unit, last_only: bool = False) -> np.ndarray:
        """Feature rows of a unit: every sample, or only its last one."""
        w = int(self.window)
        t, x = (u.t[-w:], u.x[-w:]) if last_only else (u.t, u.x)
        f = window_features(t, x, window=w, short_window=int(self.short_window))
        if last_only:
            f = f[-1:]
            t = t[-1:]
        if self.time_feature:
            f = np.column_stack([f, t])
        return f

    def _target(self, u: Unit) -> np.ndarray:
        rul = u.t[-1] - u.t
        return rul if self._cap is None else np.minimum(rul, self._cap)

    # ------------------------------------------------------------------ training
    def _hgb(self, seed: int):
        from sklearn.ensemble import HistGradientBoostingRegressor

        return HistGradientBoostingRegressor(
            max_iter=int(self.max_iter),
            learning_rate=float(self.learning_rate),
            max_leaf_nodes=int(self.max_leaf_nodes),
            min_samples_leaf=int(self.min_samples_leaf),
            l2_regularization=float(self.l2_regularization),
            early_stopping=False,
            random_state=seed,
        )

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Fit one boosted model per fold of units and calibrate the intervals.

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            Censored training units, fewer than 2 units, every feature constant,
            NaN values.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import BoostingRULModel
        >>> t = pd.DataFrame({"unit": np.repeat([1, 2, 3], 20),
        ...                   "time": np.tile(np.arange(20), 3),
        ...                   "x": np.r_[np.arange(20) / 20, np.arange(20) / 15,
        ...                              np.arange(20) / 18]})
        >>> BoostingRULModel(window=5, n_folds=3, max_iter=10).fit(t).n_units_
        3
        """
        from pdmkit._progress import progress

        units, level = self._start_fit(table)
        self._cap = check_max_rul(self.max_rul)
        if len(units) < 2:
            raise DataError(
                f"BoostingRULModel needs at least 2 training units (its intervals come "
                f"from units held out); got {len(units)}"
            )
        self.feature_names_ = [
            f"{c}/{kind}"
            for kind in (f"mean{self.short_window}", f"mean{self.window}", "slope")
            for c in self.features_
        ] + (["age"] if self.time_feature else [])
        X = [self._rows(u) for u in units]
        Y = [self._target(u) for u in units]
        n_folds = min(int(self.n_folds), len(units))
        fold_of = np.random.default_rng(self.random_state).permutation(len(units)) % n_folds
        self.trees_ = []
        oof_pred, oof_true = [], []
        for f in progress(range(n_folds), desc="boosting folds", total=n_folds):
            inside = fold_of != f
            with threadpool_limits(int(self.n_threads), user_api="openmp"):
                model = self._hgb(int(self.random_state) * 1000 + f).fit(
                    np.concatenate([X[i] for i in np.flatnonzero(inside)]),
                    np.concatenate([Y[i] for i in np.flatnonzero(inside)]),
                )
            trees = _tree_arrays(model)
            self.trees_.append(trees)
            held = np.flatnonzero(~inside)
            oof_pred.append(self._clip(_walk(trees, np.concatenate([X[i] for i in held]))))
            oof_true.append(np.concatenate([Y[i] for i in held]))
        pred, true = np.concatenate(oof_pred), np.concatenate(oof_true)
        self.train_range_ = (float(true.min()), float(true.max()))
        self._calibrate(pred, true, level, int(self.n_bins))
        self.level_ = level
        self.n_units_ = len(units)
        return self

    def _top(self) -> float:
        """The largest RUL the model answers (``max_rul``, or no limit)."""
        return np.inf if self._cap is None else self._cap

    def _clip(self, values: np.ndarray) -> np.ndarray:
        return np.clip(values, 0.0, self._top())

    # ------------------------------------------------------------------ prediction
    def _estimate(self, X: np.ndarray) -> np.ndarray:
        return self._clip(np.mean([_walk(trees, X) for trees in self.trees_], axis=0))

    def _predict_units(self, units):
        X = np.vstack([self._rows(u, last_only=True) for u in units])
        est = self._estimate(X)
        return self._binned_prediction(units, est, self._top(), float(self.level_))

    def predict(self, table: pd.DataFrame) -> RULPrediction:
        """Predict the RUL of each unit from the recent past of its history.

        Returns
        -------
        RULPrediction

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import BoostingRULModel
        >>> t = pd.DataFrame({"unit": np.repeat([1, 2, 3], 20),
        ...                   "time": np.tile(np.arange(20), 3),
        ...                   "x": np.r_[np.arange(20) / 20, np.arange(20) / 15,
        ...                              np.arange(20) / 18]})
        >>> m = BoostingRULModel(window=5, n_folds=3, max_iter=10).fit(t)
        >>> len(m.predict(t))
        3
        """
        check_fitted(self, "trees_")
        return self._predict_units(self._split(table))
