"""Condition monitoring in service: a health model fitted on healthy rows only.

:class:`HealthModel` learns what a machine's features look like while it is healthy
(unlabelled rows from the start of its service, say) and then answers, for every new
row: how abnormal is it (:meth:`~HealthModel.score`, :meth:`~HealthModel.health_index`),
is the machine in alarm (:meth:`~HealthModel.alarm_state`), since when
(:meth:`~HealthModel.first_alarm`), and which features make it abnormal
(:meth:`~HealthModel.contributions`).

Detectors (``method``), all on the features standardised with the mean and standard
deviation of the rows they are fitted on:

- ``"pca_t2"`` / ``"pca_q"`` / ``"pca"``: principal component analysis of the healthy
  rows; Hotelling's ``T² = sum_i t_i² / lambda_i`` in the kept components (a change
  *along* the healthy correlations), the squared prediction error
  ``Q = ||z - P^T P z||²`` off them (a broken correlation), or both combined as
  ``T² / mean(T²) + Q / mean(Q)`` (means over the fitting rows; the spirit of Yue &
  Qin's combined index, J. Process Control 11, 2001), which sees either;
- ``"mahalanobis"``: squared Mahalanobis distance from the minimum covariance
  determinant (MCD) location and scatter (Rousseeuw & Van Driessen 1999, scikit-learn's
  ``MinCovDet``). MCD rather than the sample or a Ledoit-Wolf shrunk covariance
  because a healthy window recorded in service holds transients and outliers (a
  start-up, a sensor glitch) that would inflate a plain or shrunk covariance and hide
  later drifts; MCD ignores up to half the rows. Shrinkage helps when rows are few
  against features, which is not the monitoring case (tens of features, hundreds of
  rows);
- ``"isolation_forest"``: scikit-learn's ``IsolationForest``, the score its
  ``score_samples`` sign-flipped (higher = more abnormal, about 0.5 for typical rows);
- ``"symbolic"``: the symbolic-dynamics measure of Khatkhate, Ray & Keller (2007; Ray
  2004, :class:`~pdmkit.models.diagnosis.SymbolicAnomaly`) on each feature's last
  ``window`` rows: the feature is coarse-grained into ``n_symbols`` symbols by the
  maximum-entropy partition of its healthy values, and the score is the sum over
  features of the squared L2 distance between the window's symbol probabilities and
  the healthy ones (D-Markov depth 1). It needs time-ordered rows; the first
  ``window - 1`` rows of each unit have no score (NaN, never in alarm).

The alarm threshold is set by split-conformal calibration: the detector is fitted on
the first rows of each unit's healthy window and the threshold is the
``ceil((n + 1)(1 - alpha))``-th smallest score of the ``n`` later (calibration) rows
(:func:`~pdmkit.models.diagnosis.conformal_threshold`), so a new healthy row
exchangeable with them exceeds it with probability at most ``alpha =
false_alarm_rate``. Rows of a machine's history are not exchangeable (they drift and
are autocorrelated; overlapping symbolic windows share rows): calibrating on the
*last* part of each unit's healthy window, not on random rows, makes the threshold
judge the healthy state nearest to the rows that follow, and the per-row guarantee is
then approximate. :func:`~pdmkit.models.diagnosis.persistent_alarm` turns exceedances
into an alarm that needs ``persistence`` consecutive ones.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.diagnosis._health_threshold import (
    _runs,
    calibration_split,
    conformal_threshold,
    health_index_map,
    persistent_alarm,
)
from pdmkit.models.diagnosis._symbolic import SymbolicAnomaly, symbolize

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["METHODS", "HealthModel"]

#: The detectors a HealthModel can use.
METHODS = ("pca", "pca_t2", "pca_q", "mahalanobis", "isolation_forest", "symbolic")


def _column(X: Any, value: Any, what: str) -> Any:
    """``X[value]`` when ``value`` names a column of the table ``X``, else ``value``."""
    if isinstance(value, str) and isinstance(X, pd.DataFrame):
        if value not in X.columns:
            raise DataError(f"{what}={value!r} is no column of X.")
        return X[value].to_numpy()
    return value


def _nonfinite_message(arr: np.ndarray, rows: Any, cols: list, what: str) -> str:
    bad = ~np.isfinite(arr)
    r = np.flatnonzero(bad.any(axis=1))
    c = np.flatnonzero(bad.any(axis=0))
    shown = ", ".join(str(rows[i]) for i in r[:5]) + (", ..." if r.size > 5 else "")
    return (
        f"{what} holds NaN/inf in {r.size} row(s) ({shown}) of column(s) "
        f"{[cols[j] for j in c]}; drop or fill them first."
    )


class HealthModel(BaseEstimator):
    """Health model fitted on healthy rows: anomaly score, health index and alarms.

    Parameters
    ----------
    method : {"pca", "pca_t2", "pca_q", "mahalanobis", "isolation_forest", \
"symbolic"}, default "pca"
        The detector (see the module description): PCA with ``T²`` and ``Q``
        combined, ``T²`` alone or ``Q`` alone; squared robust (MCD) Mahalanobis
        distance; isolation forest; symbolic dynamics over ``window`` rows.
    false_alarm_rate : float in (0, 1), default 0.01
        Target probability that a healthy row's score exceeds the threshold (per row,
        before persistence). The calibration part needs at least
        ``ceil(1 / false_alarm_rate) - 1`` rows (99 for 0.01).
    persistence : int, default 3
        Consecutive rows above the threshold that raise the alarm.
    clear_after : int, optional
        Consecutive rows at or below the threshold that clear it; default never (the
        alarm holds for the rest of the unit's rows).
    calibration_fraction : float in (0, 1), default 0.3
        Share of each unit's healthy rows (its last ones, in the order given) that set
        the threshold; the detector is fitted on the rest.
    n_components : float in (0, 1] or int, default 0.95
        PCA methods: the share of the healthy variance the kept components explain,
        or their number. With ``Q`` (``"pca"``, ``"pca_q"``) at most ``p - 1`` are
        kept, so that there is a residual.
    random_state : int, default 0
        Seed of the isolation forest and of MCD's random subsets.
    window : int, default 20
        ``"symbolic"``: rows per window.
    n_symbols : int, default 4
        ``"symbolic"``: symbols of each feature's maximum-entropy partition.
    margin : float >= 1, default 1.0
        Stretches the threshold away from the healthy median score:
        ``threshold = m + margin (q - m)``, ``q`` the conformal quantile and ``m`` the
        calibration rows' median. 1 is the plain conformal threshold; a larger margin
        keeps its guarantee (the threshold only rises) and leaves room for slow
        healthy drift the healthy window did not show (see ``docs/monitoring.md``).

    Attributes
    ----------
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        Only when fitted on a DataFrame with string column names; later tables are
        matched by these names.
    mean_, scale_ : ndarray, shape (n_features,)
        Standardisation (fitting rows' mean and standard deviation, 1 where constant).
    threshold_ : float
        The alarm threshold of :meth:`score`.
    conformal_quantile_ : float
        The split-conformal quantile (``threshold_`` when ``margin`` is 1).
    calibration_median_ : float
        Median score of the calibration rows (health index 1 up to it).
    n_fit_, n_calibration_ : int
        Rows the detector was fitted on and rows that set the threshold.
    components_, explained_variance_ : ndarray
        PCA methods: kept directions (rows) and their variances.
    location_, precision_ : ndarray
        ``"mahalanobis"``: MCD location and inverse scatter (standardised units).
    forest_ : sklearn.ensemble.IsolationForest
        ``"isolation_forest"``.
    boundaries_, p0_ : ndarray
        ``"symbolic"``: partition boundaries and healthy symbol probabilities, one row
        per feature.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.models.diagnosis import HealthModel
    >>> rng = np.random.default_rng(0)
    >>> healthy = pd.DataFrame(rng.normal(size=(600, 3)), columns=["a", "b", "c"])
    >>> model = HealthModel(method="pca", false_alarm_rate=0.01).fit(healthy)
    >>> later = pd.DataFrame(rng.normal(size=(40, 3)), columns=["a", "b", "c"])
    >>> later.loc[20:, "b"] += 6.0                  # a fault from row 20 on
    >>> alarm = model.alarm_state(later)
    >>> int(np.argmax(alarm))                       # the third row above threshold
    22
    >>> hi = model.health_index(later)
    >>> bool(hi[:20].min() > 0.5), bool(np.median(hi[20:]) < 0.2)   # 0.5 = threshold
    (True, True)
    """

    def __init__(
        self,
        method: str = "pca",
        false_alarm_rate: float = 0.01,
        persistence: int = 3,
        clear_after: int | None = None,
        calibration_fraction: float = 0.3,
        n_components: float | int = 0.95,
        random_state: int = 0,
        *,
        window: int = 20,
        n_symbols: int = 4,
        margin: float = 1.0,
    ):
        self.method = method
        self.false_alarm_rate = false_alarm_rate
        self.persistence = persistence
        self.clear_after = clear_after
        self.calibration_fraction = calibration_fraction
        self.n_components = n_components
        self.random_state = random_state
        self.window = window
        self.n_symbols = n_symbols
        self.margin = margin

    # ------------------------------------------------------------------ inputs
    def _check_params(self) -> None:
        if self.method not in METHODS:
            raise ModelError(f"method must be one of {list(METHODS)}; got {self.method!r}.")
        if not 0 < float(self.false_alarm_rate) < 1:
            raise ModelError(
                f"false_alarm_rate must be in (0, 1); got {self.false_alarm_rate!r}."
            )
        persistent_alarm([], self.persistence, self.clear_after)  # checks both
        if not float(self.margin) >= 1:
            raise ModelError(f"margin must be >= 1; got {self.margin!r}.")
        if self.method == "symbolic" and (int(self.window) < 2 or int(self.n_symbols) < 2):
            raise ModelError(
                f"window and n_symbols must be >= 2; got {self.window!r}, "
                f"{self.n_symbols!r}."
            )

    def _matrix(self, X: Any, *, fitting: bool, drop: Any = None) -> np.ndarray:
        """``X`` as a float matrix, its columns matched by name to the fitted ones."""
        if isinstance(X, pd.DataFrame):
            if isinstance(drop, str) and drop in X.columns:
                X = X.drop(columns=drop)
            names = list(X.columns)
            if fitting and names and all(isinstance(c, str) for c in names):
                self.feature_names_in_ = np.asarray(names, dtype=object)
            elif not fitting and hasattr(self, "feature_names_in_"):
                want = list(self.feature_names_in_)
                missing = [c for c in want if c not in X.columns]
                if missing:
                    raise DataError(
                        f"X lacks the column(s) {missing} the model was fitted on."
                    )
                X, names = X[want], want
            nonnum = [c for c in names if not pd.api.types.is_numeric_dtype(X[c])]
            if nonnum:
                raise DataError(f"X has non-numeric column(s) {nonnum}.")
            arr, rows = X.to_numpy(dtype=float), X.index
        else:
            arr = np.asarray(X, dtype=float)
            if arr.ndim != 2:
                raise DataError(
                    f"X must be 2-D (rows, features); got shape {arr.shape} "
                    "(one feature: reshape(-1, 1))."
                )
            names, rows = list(range(arr.shape[1])), np.arange(arr.shape[0])
        if arr.shape[0] == 0 or arr.shape[1] == 0:
            raise DataError(f"X has shape {arr.shape}; it needs rows and features.")
        if not np.all(np.isfinite(arr)):
            raise DataError(_nonfinite_message(arr, rows, names, "X"))
        if fitting:
            self.n_features_in_ = arr.shape[1]
        elif arr.shape[1] != self.n_features_in_:
            raise DataError(
                f"X has {arr.shape[1]} feature(s); the model was fitted on "
                f"{self.n_features_in_}."
            )
        return arr

    def _check_fitted(self) -> None:
        if not hasattr(self, "threshold_"):
            raise NotFittedError("HealthModel is not fitted; call fit(X_healthy) first.")

    def _prepare(self, X: Any, units: Any) -> tuple[np.ndarray, Any]:
        self._check_fitted()
        Z = (self._matrix(X, fitting=False, drop=units) - self.mean_) / self.scale_
        return Z, _column(X, units, "units")

    # ------------------------------------------------------------------ fitting
    def fit(self, X: ArrayLike, y: None = None, *, groups: ArrayLike | None = None):
        """Fit the detector on healthy rows and calibrate the alarm threshold.

        Parameters
        ----------
        X : array_like or DataFrame, shape (n_rows, n_features)
            Healthy rows, in time order within each unit.
        y : None
            Ignored (scikit-learn's signature).
        groups : array_like, shape (n_rows,), or str, optional
            Unit of each row (a column name of ``X`` when it is a DataFrame; that
            column is then no feature). Each unit's last ``calibration_fraction`` of
            rows calibrate the threshold.

        Returns
        -------
        HealthModel
            ``self``, fitted.

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> X = np.random.default_rng(1).normal(size=(400, 2))
        >>> m = HealthModel(method="mahalanobis").fit(X, groups=np.repeat([1, 2], 200))
        >>> m.n_fit_, m.n_calibration_
        (280, 120)
        """
        self._check_params()
        self.__dict__.pop("feature_names_in_", None)  # a refit on an array has none
        Xa = self._matrix(X, fitting=True, drop=groups)
        groups = _column(X, groups, "groups")
        fit_rows, cal_rows = calibration_split(
            Xa.shape[0], self.calibration_fraction, groups
        )
        part = Xa[fit_rows]
        self.mean_ = part.mean(axis=0)
        sd = part.std(axis=0)
        self.scale_ = np.where(sd > 0, sd, 1.0)
        Z = (Xa - self.mean_) / self.scale_
        self._fit_detector(Z[fit_rows])
        scores = self._score_z(Z, groups)
        q = conformal_threshold(scores[cal_rows], self.false_alarm_rate)
        self.conformal_quantile_ = q
        self.calibration_median_ = float(np.nanmedian(scores[cal_rows]))
        m = self.calibration_median_
        # margin 1 is the conformal quantile itself (m + (q - m) may differ in the last bit)
        k = float(self.margin)
        self.threshold_ = q if k == 1.0 else m + k * (q - m)
        self.n_fit_, self.n_calibration_ = int(fit_rows.size), int(cal_rows.size)
        return self

    def _fit_detector(self, Z: np.ndarray) -> None:
        n, p = Z.shape
        method = self.method
        if method.startswith("pca"):
            self._fit_pca(Z)
        elif method == "mahalanobis":
            self._fit_mcd(Z)
        elif method == "isolation_forest":
            from sklearn.ensemble import IsolationForest

            self.forest_ = IsolationForest(random_state=self.random_state).fit(Z)
            self.feature_median_ = np.median(Z, axis=0)
        else:
            if n < int(self.window):
                raise DataError(
                    f"the fitting part has {n} rows; the symbolic measure needs at "
                    f"least window={self.window}."
                )
            b, p0 = [], []
            for j in range(p):
                sym = SymbolicAnomaly(n_symbols=int(self.n_symbols), depth=1)
                sym.fit(Z[:, j])
                b.append(sym.boundaries_)
                p0.append(sym.p0_)
            self.boundaries_, self.p0_ = np.array(b), np.array(p0)

    def _fit_pca(self, Z: np.ndarray) -> None:
        n, p = Z.shape
        with_q = self.method in ("pca", "pca_q")
        if with_q and p < 2:
            raise ModelError(
                f"method={self.method!r} needs at least 2 features (Q is the residual "
                "off the kept components); use 'pca_t2' or 'mahalanobis'."
            )
        if n < 3:
            raise DataError(f"the fitting part has {n} rows; PCA needs at least 3.")
        _, s, vt = np.linalg.svd(Z - Z.mean(axis=0), full_matrices=False)
        var = s**2 / (n - 1)
        nc = self.n_components
        if isinstance(nc, float | np.floating) and 0 < nc <= 1:
            share = np.cumsum(var) / max(var.sum(), np.finfo(float).tiny)
            k = int(np.searchsorted(share, float(nc) - 1e-12) + 1)
        elif isinstance(nc, int | np.integer) and nc >= 1:
            k = int(nc)
        else:
            raise ModelError(
                f"n_components must be a float in (0, 1] or an int >= 1; got {nc!r}."
            )
        k = min(k, p - 1 if with_q else p, int(np.sum(var > 1e-12 * var[0])) or 1)
        self.components_, self.explained_variance_ = vt[:k], var[:k]
        t2, q = self._pca_terms(Z)
        self.t2_mean_ = float(t2.sum(axis=1).mean())
        self.q_mean_ = max(float(q.sum(axis=1).mean()), np.finfo(float).tiny)

    def _fit_mcd(self, Z: np.ndarray) -> None:
        from sklearn.covariance import MinCovDet

        n, p = Z.shape
        if n < 2 * p + 2:
            raise DataError(
                f"the fitting part has {n} rows; the robust covariance of {p} features "
                f"needs at least {2 * p + 2}."
            )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            mcd = MinCovDet(random_state=self.random_state).fit(Z)
        self.location_ = mcd.location_
        self.precision_ = mcd.get_precision()
        w, v = np.linalg.eigh((self.precision_ + self.precision_.T) / 2)
        self.precision_sqrt_ = (v * np.sqrt(np.maximum(w, 0))) @ v.T

    # ------------------------------------------------------------------ scores
    def _pca_terms(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-feature terms of T² (complete decomposition) and of Q; rows sum to them."""
        P, lam = self.components_, self.explained_variance_
        root = (P.T / np.sqrt(lam)) @ P  # M^(1/2) of M = P^T diag(1/lam) P
        t2 = (Z @ root) ** 2
        q = (Z - (Z @ P.T) @ P) ** 2
        return t2, q

    def _terms(self, Z: np.ndarray, units: Any) -> np.ndarray:
        """Per-feature terms whose row sums are the score (all but isolation forest)."""
        method = self.method
        if method.startswith("pca"):
            t2, q = self._pca_terms(Z)
            if method == "pca_t2":
                return t2
            if method == "pca_q":
                return q
            return t2 / self.t2_mean_ + q / self.q_mean_
        if method == "mahalanobis":
            return ((Z - self.location_) @ self.precision_sqrt_) ** 2
        return self._symbolic_terms(Z, units)

    def _symbolic_terms(self, Z: np.ndarray, units: Any) -> np.ndarray:
        n, p = Z.shape
        w, m = int(self.window), int(self.n_symbols)
        out = np.full((n, p), np.nan)
        for rows in _runs(units, n):
            if rows.size < w:
                continue
            for j in range(p):
                counts = np.zeros((rows.size + 1, m))
                counts[
                    np.arange(1, rows.size + 1), symbolize(Z[rows, j], self.boundaries_[j])
                ] = 1
                cum = np.cumsum(counts, axis=0)
                probs = (cum[w:] - cum[:-w]) / w
                out[rows[w - 1 :], j] = np.sum((probs - self.p0_[j]) ** 2, axis=1)
        return out

    def _score_z(self, Z: np.ndarray, units: Any) -> np.ndarray:
        if self.method == "isolation_forest":
            return -self.forest_.score_samples(Z)
        if self.method == "mahalanobis":
            d = Z - self.location_
            return np.einsum("ij,jk,ik->i", d, self.precision_, d)
        return self._terms(Z, units).sum(axis=1)

    # ------------------------------------------------------------------ answers
    def score(self, X: ArrayLike, units: ArrayLike | None = None) -> np.ndarray:
        """Anomaly score of each row (higher = less like the healthy rows).

        Parameters
        ----------
        X : array_like or DataFrame, shape (n_rows, n_features)
            Rows to judge; a DataFrame's columns are matched by name (extra columns
            are ignored).
        units : array_like or str, optional
            Unit of each row (or a column of ``X``); only ``"symbolic"`` uses it, its
            windows never spanning two units. Rows in time order within each unit.

        Returns
        -------
        ndarray, shape (n_rows,)
            ``T²``, ``Q``, their combination, the squared Mahalanobis distance, the
            isolation forest's ``-score_samples`` or the symbolic measure (NaN for the
            first ``window - 1`` rows of each unit).

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> X = np.random.default_rng(2).normal(size=(500, 2))
        >>> m = HealthModel(method="pca_t2", n_components=2).fit(X)
        >>> s = m.score([[0.0, 0.0], [5.0, 5.0]])
        >>> bool(s[0] < m.threshold_ < s[1])
        True
        """
        Z, units = self._prepare(X, units)
        return self._score_z(Z, units)

    def health_index(self, X: ArrayLike, units: ArrayLike | None = None) -> np.ndarray:
        """Health index of each row in [0, 1]: 1 healthy, 0.5 at the threshold.

        ``hi = 2 ** -(max(0, s - m) / (threshold - m))`` with ``s`` the score and ``m``
        the median score of the healthy calibration rows: 1 for a row at least as
        typical as the median healthy row, 0.5 at the alarm threshold, 0.25 as far
        beyond it again, tending to 0.

        Parameters
        ----------
        X, units
            As in :meth:`score`.

        Returns
        -------
        ndarray, shape (n_rows,)

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> X = np.random.default_rng(3).normal(size=(500, 2))
        >>> m = HealthModel(method="mahalanobis").fit(X)
        >>> m.health_index([[0.0, 0.0], [9.0, -9.0]]).round(2).tolist()
        [1.0, 0.0]
        """
        return health_index_map(
            self.score(X, units), self.calibration_median_, self.threshold_
        )

    def alarm_state(self, X: ArrayLike, units: ArrayLike | None = None) -> np.ndarray:
        """Alarm of each row, with persistence and hysteresis.

        The alarm rises at the row that completes ``persistence`` consecutive rows
        above the threshold and clears after ``clear_after`` consecutive rows at or
        below it (never, by default), separately for each unit
        (:func:`~pdmkit.models.diagnosis.persistent_alarm`). Rows without a score
        (the symbolic measure's first rows) count as below the threshold.

        Parameters
        ----------
        X : array_like or DataFrame
            Rows in time order within each unit.
        units : array_like or str, optional
            Unit of each row (or a column of ``X``).

        Returns
        -------
        ndarray of bool, shape (n_rows,)

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> X = np.random.default_rng(4).normal(size=(500, 2))
        >>> m = HealthModel(method="pca_t2", persistence=2).fit(X)
        >>> rows = [[0, 0], [8, 8], [0, 0], [8, 8], [8, 8], [0, 0]]
        >>> m.alarm_state(rows).astype(int).tolist()
        [0, 0, 0, 0, 1, 1]
        """
        s = self.score(X, units)
        units = _column(X, units, "units")
        with np.errstate(invalid="ignore"):
            exceed = np.nan_to_num(s, nan=-np.inf) > self.threshold_
        return persistent_alarm(exceed, self.persistence, self.clear_after, units)

    def contributions(self, X: ArrayLike, units: ArrayLike | None = None) -> pd.DataFrame:
        """Each feature's share of each row's score.

        - PCA, Mahalanobis: the complete decomposition of the quadratic form (Alcala &
          Qin, J. Process Control 21, 2011): ``T²``'s term of feature ``j`` is
          ``((M^1/2 z)_j)²`` with ``M = P^T diag(1/lambda) P``, ``Q``'s is the squared
          residual ``(z - P^T P z)_j²``, Mahalanobis's ``((S^1/2 (z - mu))_j)²``;
          all are >= 0 and each row sums to the score exactly;
        - symbolic: each feature's squared distance of symbol probabilities (sums to
          the score);
        - isolation forest: how much the score drops when feature ``j`` alone is set
          to its healthy median (does not sum to the score; may be negative).

        Parameters
        ----------
        X, units
            As in :meth:`score`.

        Returns
        -------
        DataFrame, shape (n_rows, n_features)
            Columns named as the features (their positions when fitted on an array),
            index that of ``X`` when it is a DataFrame.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> rng = np.random.default_rng(5)
        >>> X = pd.DataFrame(rng.normal(size=(500, 3)), columns=["temp", "rms", "kurt"])
        >>> m = HealthModel(method="mahalanobis").fit(X)
        >>> c = m.contributions(pd.DataFrame({"temp": [0.0], "rms": [7.0], "kurt": [0.0]}))
        >>> c.idxmax(axis=1).tolist()
        ['rms']
        """
        Z, units = self._prepare(X, units)
        if self.method == "isolation_forest":
            base = -self.forest_.score_samples(Z)
            terms = np.empty_like(Z)
            for j in range(Z.shape[1]):
                reset = Z.copy()
                reset[:, j] = self.feature_median_[j]
                terms[:, j] = base + self.forest_.score_samples(reset)
        else:
            terms = self._terms(Z, units)
        names = getattr(self, "feature_names_in_", None)
        cols = list(names) if names is not None else list(range(Z.shape[1]))
        index = X.index if isinstance(X, pd.DataFrame) else None
        return pd.DataFrame(terms, columns=cols, index=index)

    def assess(self, X: ArrayLike, units: ArrayLike | None = None) -> pd.DataFrame:
        """Score, health index, exceedance and alarm of each row, as one table.

        Parameters
        ----------
        X, units
            As in :meth:`alarm_state`.

        Returns
        -------
        DataFrame
            Columns ``score``, ``health_index``, ``above_threshold``, ``alarm``; the
            index of ``X`` when it is a DataFrame.

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> X = np.random.default_rng(6).normal(size=(500, 2))
        >>> m = HealthModel(method="pca_t2", persistence=1).fit(X)
        >>> m.assess([[0.0, 0.0], [9.0, 9.0]])[["above_threshold", "alarm"]].values.tolist()
        [[False, False], [True, True]]
        """
        s = self.score(X, units)
        with np.errstate(invalid="ignore"):
            above = np.nan_to_num(s, nan=-np.inf) > self.threshold_
        u = _column(X, units, "units")
        return pd.DataFrame(
            {
                "score": s,
                "health_index": health_index_map(
                    s, self.calibration_median_, self.threshold_
                ),
                "above_threshold": above,
                "alarm": persistent_alarm(above, self.persistence, self.clear_after, u),
            },
            index=X.index if isinstance(X, pd.DataFrame) else None,
        )

    def first_alarm(
        self, X: ArrayLike, time: ArrayLike, units: ArrayLike | None = None
    ) -> pd.Series:
        """Time of each unit's first alarm (None where it never alarms).

        Rows are sorted by unit and ``time`` first (stable), so they may come in any
        order.

        Parameters
        ----------
        X : array_like or DataFrame
        time : array_like or str
            Time of each row (numbers or datetimes), or a column of ``X``.
        units : array_like or str, optional
            Unit of each row, or a column of ``X``; default one unit, labelled 0.

        Returns
        -------
        pandas.Series
            Index the units (in order of first appearance), values the first alarm
            times or None; name ``"first_alarm"``.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.models.diagnosis import HealthModel
        >>> rng = np.random.default_rng(7)
        >>> healthy = pd.DataFrame(rng.normal(size=(500, 2)), columns=["f0", "f1"])
        >>> m = HealthModel(method="pca_t2", persistence=2).fit(healthy)
        >>> log = pd.DataFrame(0.1 * rng.normal(size=(20, 2)), columns=["f0", "f1"])
        >>> log.loc[12:, "f0"] += 8.0                        # unit "b" fails at t = 2
        >>> log["unit"] = ["a"] * 10 + ["b"] * 10
        >>> log["t"] = list(range(10)) * 2
        >>> m.first_alarm(log, time="t", units="unit").to_dict()
        {'a': None, 'b': 3}
        """
        self._check_fitted()
        t = pd.Series(np.asarray(_column(X, time, "time")))
        units = _column(X, units, "units")
        n = len(X) if isinstance(X, pd.DataFrame) else np.asarray(X).shape[0]
        if t.size != n:
            raise DataError(f"time has {t.size} values; X has {n} rows.")
        u = np.zeros(n, dtype=int) if units is None else np.asarray(units)
        if u.shape != (n,):
            raise DataError(f"units must have one label per row ({n}); got {u.shape}.")
        labels = pd.unique(pd.Series(u))
        rank = pd.Series(np.arange(labels.size), index=labels)
        order = np.lexsort((t.to_numpy(), rank.loc[u].to_numpy()))
        Xs = X.iloc[order] if isinstance(X, pd.DataFrame) else np.asarray(X)[order]
        alarm = self.alarm_state(Xs, u[order])
        out = {}
        for lab in labels:
            hit = np.flatnonzero((u[order] == lab) & alarm)
            first = t.iloc[order[hit[0]]] if hit.size else None
            out[lab] = first.item() if isinstance(first, np.generic) else first
        return pd.Series(out, name="first_alarm", dtype=object)
