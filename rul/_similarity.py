"""Similarity models: RUL from the training units whose paths look most like this one.

All three keep a library built from run-to-failure training units. A unit's history is
compared with each training unit, which yields a distance and the remaining life that
training unit had at the matched point; the RUL distribution is that of the ``k``
nearest units' remaining lives (median as the estimate, empirical quantiles as the
interval).

- :class:`ResidualSimilarityModel` fits a polynomial to each training unit's path and
  scores the residuals of the history against it (MATLAB's ``residualSimilarityModel``
  fits ARMA or polynomial models the same way).
- :class:`PairwiseSimilarityModel` compares the history with the raw training paths:
  Euclidean, absolute or correlation distance, or dynamic time warping.
- :class:`HashSimilarityModel` reduces windows of the paths to a few summary features
  (mean, slope, spread, ...) and searches a k-d tree, which scales to large fleets.

Alignment: MATLAB's models compare a history with the start of each training path
(``align="start"``), which assumes every unit starts equally healthy. With
``align="best"`` (the default) the history's most recent part slides along each
training path and is placed where it fits best, so units that start with different
initial wear, as the C-MAPSS engines do, are matched at their actual state (the
trajectory-similarity approach of Wang et al., PHM 2008). Samples are taken as evenly
spaced for the matching; remaining lives use the training units' time values.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError
from pdmkit.rul._base import (
    TrajectoryMixin,
    Unit,
    as_columns,
    check_level,
    check_max_rul,
    check_positive_int,
    check_table,
    failed_column,
    keep_init_args,
    require_failures,
    resolve_keys,
)

if TYPE_CHECKING:
    from typing import Self

_DISTANCES = ("euclidean", "absolute", "correlation", "dtw")


def _sliding_ss(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``sum_i ||x_i - f_{tau+i}||^2`` for every offset ``tau`` (f: (T, p), x: (m, p))."""
    m = len(x)
    total = np.zeros(len(f) - m + 1)
    for c in range(x.shape[1]):
        fc, xc = f[:, c], x[:, c]
        sq = np.concatenate([[0.0], np.cumsum(fc * fc)])
        total += (xc @ xc) - 2.0 * np.correlate(fc, xc, "valid") + (sq[m:] - sq[:-m])
    return np.maximum(total, 0.0)


def _sliding_abs(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    m = len(x)
    win = np.lib.stride_tricks.sliding_window_view(f, m, axis=0)  # (T-m+1, p, m)
    return np.abs(win - x.T[None]).sum(axis=(1, 2))


def _sliding_corr(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``1 - Pearson r`` between x and each window of f, averaged over columns."""
    m = len(x)
    out = np.zeros(len(f) - m + 1)
    for c in range(x.shape[1]):
        fc, xc = f[:, c], x[:, c]
        xc = xc - xc.mean()
        sx = np.sqrt(xc @ xc)
        s1 = np.concatenate([[0.0], np.cumsum(fc)])
        s2 = np.concatenate([[0.0], np.cumsum(fc * fc)])
        wsum = s1[m:] - s1[:-m]
        wvar = np.maximum((s2[m:] - s2[:-m]) - wsum**2 / m, 0.0)
        cross = np.correlate(fc, xc, "valid")
        with np.errstate(divide="ignore", invalid="ignore"):
            r = cross / (sx * np.sqrt(wvar))
        out += 1.0 - np.where(np.isfinite(r), r, 0.0)
    return out / x.shape[1]


class _SimilarityBase(TrajectoryMixin, BaseEstimator, abc.ABC):
    """The library, the fit-time checks and the k-nearest prediction of the three models.

    Each model's own ``__init__`` lists its parameters (scikit-learn's ``get_params``
    reads them there).
    """

    def _split_columns(self) -> list[str]:
        return list(self._columns)

    def _validate_extra(self):  # subclass hook
        pass

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Build the library from run-to-failure training units.

        Parameters
        ----------
        table : pandas.DataFrame
            Long table (``unit``, ``time``, indicator columns); every unit must have
            run to failure at its last row.

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            Censored training units (``failed`` False), an indicator constant over the
            whole training table, missing columns or NaN values.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import PairwiseSimilarityModel
        >>> t = np.arange(10.0)
        >>> train = pd.DataFrame({"unit": np.repeat([1, 2], 10), "time": np.tile(t, 2),
        ...                       "hi": np.r_[t / 10, t / 5]})
        >>> PairwiseSimilarityModel(k=1).fit(train).n_units_
        2
        """
        table = check_table(table)
        self._keys = resolve_keys(table, self.unit, self.time)
        self._failed = failed_column(table, self.failed)
        self._columns = as_columns(self.indicator)
        if not self._columns:
            raise ValueError("indicator must name at least one column")
        check_positive_int(self.k, "k")
        check_level(self.level)
        check_max_rul(self.max_rul)
        self._validate_extra()
        units = self._split(table, "training table")
        require_failures(units, type(self).__name__)
        x = np.concatenate([u.x for u in units])
        flat = [c for c, v in zip(self._columns, np.ptp(x, axis=0), strict=True) if v == 0]
        if flat:
            raise DataError(
                f"indicator {flat} is constant over the whole training table; a constant "
                "indicator makes every training unit equally similar - pick an indicator "
                "that changes with wear"
            )
        self._build(units)
        self.train_units_ = [u.name for u in units]
        self.train_lives_ = np.array([u.t[-1] - u.t[0] for u in units])
        self.n_units_ = len(units)
        return self

    def _build(self, units):
        self._library = units

    @abc.abstractmethod
    def _match(self, u: Unit):
        """Return (distances, remaining lives) against every training unit."""

    def _predict_units(self, units):
        level = check_level(self.level)
        k = min(int(self.k), self.n_units_)
        q = [(1 - level) / 2, 0.5, (1 + level) / 2]
        est, lo, hi, near, dist = [], [], [], [], []
        for u in units:
            d, rul = self._match(u)
            order = np.argsort(d, kind="stable")[:k]
            r = rul[order]
            lo_, est_, hi_ = np.quantile(r, q)
            est.append(est_)
            lo.append(lo_)
            hi.append(hi_)
            near.append(tuple(self.train_units_[i] for i in order))
            dist.append(float(np.mean(d[order])))
        return self._prediction(
            [u.name for u in units],
            [float(u.t[-1]) for u in units],
            est,
            lo,
            hi,
            level=level,
            extra={"nearest": near, "distance": np.asarray(dist)},
        )


# --------------------------------------------------------------------------- residual
class ResidualSimilarityModel(_SimilarityBase):
    """Residual similarity: a polynomial per training unit, residuals of the history.

    Each training unit's path (each indicator column) is fitted by a polynomial of
    ``degree`` in time. A history is scored against every fitted path by the root mean
    square of its residuals, at the alignment that fits best (``align="best"``) or
    from the start (``align="start"``); the ``k`` units with the smallest residuals
    give the RUL distribution (see the module notes).

    Parameters
    ----------
    indicator : str or sequence of str, default "hi"
        Indicator column(s); several columns should share a scale.
    degree : int, default 3
        Polynomial degree of the per-unit models.
    k : int, default 10
        Nearest units kept (capped at the number of training units).
    align : {"best", "start"}, default "best"
    level : float, default 0.9
        Confidence level of the intervals (empirical quantiles of the neighbours'
        remaining lives).
    max_rul : float, optional
        Cap on the estimates and intervals (e.g. 125 cycles for C-MAPSS).
    unit, time, failed : str
        Key columns.

    Attributes
    ----------
    coefs_ : list of numpy.ndarray
        Per training unit, polynomial coefficients (``np.polynomial.Polynomial`` in the
        unit's own scaled time domain) per indicator column.
    train_units_ : list
    train_lives_ : numpy.ndarray
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import ResidualSimilarityModel
    >>> rows = []
    >>> for u, life in enumerate([60, 80, 100, 120, 140]):
    ...     t = np.arange(life, dtype=float)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t, "hi": (t / life) ** 2}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> model = ResidualSimilarityModel(k=1, degree=2).fit(train)
    >>> t = np.arange(50, dtype=float)
    >>> test = pd.DataFrame({"unit": "x", "time": t, "hi": (t / 100) ** 2})
    >>> model.predict(test).estimate.tolist()        # like unit 2: 100 - 1 - 49
    [50.0]
    """

    def __init__(
        self,
        indicator: str | Sequence[str] = "hi",
        *,
        degree: int = 3,
        k: int = 10,
        align: str = "best",
        level: float = 0.9,
        max_rul: float | None = None,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def _validate_extra(self):
        check_positive_int(self.degree, "degree", 0)
        if self.align not in ("best", "start"):
            raise ValueError(f"align must be 'best' or 'start', got {self.align!r}")

    def _build(self, units):
        curves, coefs = [], []
        for u in units:
            cols, cc = [], []
            deg = min(int(self.degree), len(u) - 1)
            for c in range(u.x.shape[1]):
                poly = np.polynomial.Polynomial.fit(u.t, u.x[:, c], deg)
                cols.append(poly(u.t))
                cc.append(poly.coef)
            curves.append(np.column_stack(cols))
            coefs.append(cc)
        self._curves = curves
        self._times = [u.t for u in units]
        self.coefs_ = coefs

    def _match(self, u):
        n = len(u)
        d = np.empty(len(self._curves))
        rul = np.empty(len(self._curves))
        for j, (f, tj) in enumerate(zip(self._curves, self._times, strict=True)):
            T = len(f)
            m = min(n, T)
            if self.align == "start":
                x = u.x[:m]
                d[j] = np.sum((x - f[:m]) ** 2)
                end = n - 1 if n <= T else T - 1
            else:
                x = u.x[n - m :]
                ss = _sliding_ss(f, x)
                tau = int(np.argmin(ss))
                d[j] = ss[tau]
                end = tau + m - 1
            d[j] = np.sqrt(d[j] / (m * x.shape[1]))
            rul[j] = tj[-1] - tj[end]
        return d, rul


# --------------------------------------------------------------------------- pairwise
def _dtw_subsequence(x: np.ndarray, paths: list[np.ndarray], open_begin: bool):
    """Subsequence DTW of x (n, p) against each path; (cost / n, end index) per path.

    Vectorised over the paths; within a row the recursion
    ``D[i, j] = c[i, j] + min(D[i-1, j], D[i-1, j-1], D[i, j-1])`` is solved as a prefix
    minimum: ``D[i, j] = C_j + min_{k <= j} (A_k - C_k)`` with ``A_k = c[i, k] +
    min(D[i-1, k], D[i-1, k-1])`` and ``C`` the running sum of ``c[i, :]``.
    """
    lengths = np.array([len(p) for p in paths])
    T = lengths.max()
    pad = 1e30
    stacked = np.full((len(paths), T, x.shape[1]), np.nan)
    for j, p in enumerate(paths):
        stacked[j, : len(p)] = p
    valid = np.arange(T)[None, :] < lengths[:, None]

    def cost(row):
        c = np.abs(stacked - row[None, None, :]).sum(axis=2)
        return np.where(valid, c, pad)

    c = cost(x[0])
    D = c.copy() if open_begin else np.cumsum(c, axis=1)
    for i in range(1, len(x)):
        c = cost(x[i])
        diag = np.concatenate([np.full((len(paths), 1), np.inf), D[:, :-1]], axis=1)
        A = c + np.minimum(D, diag)
        C = np.cumsum(c, axis=1)
        D = C + np.minimum.accumulate(A - C, axis=1)
    D = np.where(valid, D, np.inf)
    end = np.argmin(D, axis=1)
    return D[np.arange(len(paths)), end] / len(x), end


class PairwiseSimilarityModel(_SimilarityBase):
    """Pairwise similarity: the history against the raw training paths.

    Parameters
    ----------
    indicator : str or sequence of str, default "hi"
        Indicator column(s) (smooth them first; see :func:`smooth_indicators`).
    distance : {"euclidean", "absolute", "correlation", "dtw"}, default "euclidean"
        Root mean square or mean absolute difference, ``1 - Pearson r``, or dynamic
        time warping (absolute-difference cost, normalised by the history's length;
        the history may match any stretch of the training path - open begin and end -
        with ``align="best"``, or must start at its start with ``align="start"``).
    k : int, default 10
    align : {"best", "start"}, default "best"
    window : int, optional
        Compare only the last ``window`` samples of a history (default all; DTW costs
        grow with the history's length).
    level, max_rul, unit, time, failed
        As for :class:`ResidualSimilarityModel`.

    Attributes
    ----------
    train_units_, train_lives_, n_units_
        As for :class:`ResidualSimilarityModel`.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import PairwiseSimilarityModel
    >>> rows = []
    >>> for u, life in enumerate([60, 80, 100, 120, 140]):
    ...     t = np.arange(life, dtype=float)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t, "hi": (t / life) ** 2}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> t = np.arange(50, dtype=float)
    >>> test = pd.DataFrame({"unit": "x", "time": t, "hi": (t / 100) ** 2})
    >>> PairwiseSimilarityModel(k=1, distance="dtw").fit(train).predict(test).estimate
    array([50.])
    """

    def __init__(
        self,
        indicator: str | Sequence[str] = "hi",
        *,
        distance: str = "euclidean",
        k: int = 10,
        align: str = "best",
        window: int | None = None,
        level: float = 0.9,
        max_rul: float | None = None,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def _validate_extra(self):
        if self.distance not in _DISTANCES:
            raise ValueError(
                f"distance must be one of {list(_DISTANCES)}, got {self.distance!r}"
            )
        if self.align not in ("best", "start"):
            raise ValueError(f"align must be 'best' or 'start', got {self.align!r}")
        if self.window is not None:
            check_positive_int(self.window, "window", 2)

    def _match(self, u):
        x_all = u.x if self.window is None else u.x[-int(self.window) :]
        lib = self._library
        if self.distance == "dtw":
            paths = [v.x for v in lib]
            d, end = _dtw_subsequence(x_all, paths, open_begin=self.align == "best")
            rul = np.array([v.t[-1] - v.t[e] for v, e in zip(lib, end, strict=True)])
            return d, rul
        n = len(x_all)
        d = np.empty(len(lib))
        rul = np.empty(len(lib))
        for j, v in enumerate(lib):
            T = len(v)
            m = min(n, T)
            if self.align == "start":
                # the compared samples at their own age in the training unit's life
                start = len(u) - n
                if start >= T:  # older than this training unit ever got
                    d[j], rul[j] = np.inf, 0.0
                    continue
                stop = min(len(u), T)
                d[j] = self._distance(v.x[start:stop], x_all[: stop - start])[0]
                end = stop - 1
            else:
                x = x_all[n - m :]
                scores = self._distance(v.x, x)
                tau = int(np.argmin(scores))
                d[j] = scores[tau]
                end = tau + m - 1
            rul[j] = v.t[-1] - v.t[end]
        return d, rul

    def _distance(self, f, x):
        m, p = x.shape
        if self.distance == "euclidean":
            return np.sqrt(_sliding_ss(f, x) / (m * p))
        if self.distance == "absolute":
            return _sliding_abs(f, x) / (m * p)
        if m < 3:
            return np.sqrt(_sliding_ss(f, x) / (m * p))  # correlation undefined
        return _sliding_corr(f, x)


# --------------------------------------------------------------------------- hash
_HASH_FEATURES = ("mean", "std", "slope", "min", "max", "last", "age")


class HashSimilarityModel(_SimilarityBase):
    """Hash similarity: nearest neighbours among summary features of path windows.

    Every window of ``window`` samples of every training unit is reduced to a few
    summary features per indicator column (its "hash"); a history is reduced the same
    way (its last ``window`` samples), and the ``k`` training units holding the nearest
    hashes (standardised Euclidean distance, k-d tree search, at most one window per
    unit) give the RUL distribution. MATLAB's ``hashSimilarityModel`` hashes whole
    paths; hashing windows makes the remaining life at the matched window known.

    Parameters
    ----------
    indicator : str or sequence of str, default "hi"
    window : int, default 20
        Samples per window.
    features : sequence of str, default ("mean", "std", "slope", "last")
        Taken from ``"mean", "std", "slope", "min", "max", "last"`` and ``"age"`` (time
        since the unit's first sample; useful when units start new).
    stride : int, default 1
        Step between the training windows.
    pad : {"error", "edge"}, default "error"
        A history shorter than ``window`` raises a DataError, or is padded at its start
        with its first value.
    k, level, max_rul, unit, time, failed
        As for :class:`ResidualSimilarityModel`.

    Attributes
    ----------
    hashes_ : pandas.DataFrame
        The library: one row per training window (``unit``, ``rul`` and the features).
    train_units_, train_lives_, n_units_

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import HashSimilarityModel
    >>> rows = []
    >>> for u, life in enumerate([60, 80, 100, 120, 140]):
    ...     t = np.arange(life, dtype=float)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t, "hi": (t / life) ** 2}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> t = np.arange(50, dtype=float)
    >>> test = pd.DataFrame({"unit": "x", "time": t, "hi": (t / 100) ** 2})
    >>> HashSimilarityModel(k=1, window=10).fit(train).predict(test).estimate
    array([50.])
    """

    def __init__(
        self,
        indicator: str | Sequence[str] = "hi",
        *,
        window: int = 20,
        features: Sequence[str] = ("mean", "std", "slope", "last"),
        stride: int = 1,
        pad: str = "error",
        k: int = 10,
        level: float = 0.9,
        max_rul: float | None = None,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    @property
    def _min_history(self):
        return int(self.window) if self.pad == "error" else 1

    def _validate_extra(self):
        check_positive_int(self.window, "window", 2)
        check_positive_int(self.stride, "stride")
        feats = as_columns(self.features)
        bad = [f for f in feats if f not in _HASH_FEATURES]
        if bad or not feats:
            raise ValueError(
                f"features must be taken from {list(_HASH_FEATURES)}, got {feats}"
            )
        if self.pad not in ("error", "edge"):
            raise ValueError(f"pad must be 'error' or 'edge', got {self.pad!r}")

    def _hash(self, windows: np.ndarray, age: np.ndarray) -> np.ndarray:
        """windows: (N, w, p) -> (N, n_features * p)."""
        w = windows.shape[1]
        s = np.arange(w) - (w - 1) / 2
        out = []
        for f in as_columns(self.features):
            if f == "mean":
                out.append(windows.mean(axis=1))
            elif f == "std":
                out.append(windows.std(axis=1))
            elif f == "slope":
                out.append(np.einsum("nwp,w->np", windows, s) / (s @ s))
            elif f == "min":
                out.append(windows.min(axis=1))
            elif f == "max":
                out.append(windows.max(axis=1))
            elif f == "last":
                out.append(windows[:, -1])
            else:
                out.append(age[:, None])
        return np.concatenate(out, axis=1)

    def _windows(self, u: Unit, last_only: bool):
        w = int(self.window)
        x, t = u.x, u.t
        if len(u) < w:
            if self.pad == "error":
                raise DataError(
                    f"unit {u.name!r} has {len(u)} samples; "
                    f"HashSimilarityModel(window={w}) "
                    f"needs at least {w} - pass a smaller window or pad='edge'"
                )
            x = np.concatenate([np.repeat(x[:1], w - len(u), axis=0), x])
        if last_only:
            return x[None, -w:], np.array([t[-1] - t[0]]), np.array([len(u) - 1])
        view = np.lib.stride_tricks.sliding_window_view(x, w, axis=0)  # (N, p, w)
        ends = np.arange(w - 1, len(x))[:: int(self.stride)]
        wins = np.transpose(view, (0, 2, 1))[ends - (w - 1)]
        return wins, t[ends] - t[0], ends

    def _build(self, units):
        from sklearn.neighbors import NearestNeighbors

        feats, owner, rul = [], [], []
        for j, u in enumerate(units):
            if len(u) < int(self.window):
                raise DataError(
                    f"training unit {u.name!r} has {len(u)} samples, fewer than "
                    f"window={self.window}; use a smaller window or drop the unit"
                )
            wins, age, ends = self._windows(u, last_only=False)
            feats.append(self._hash(wins, age))
            owner.append(np.full(len(ends), j))
            rul.append(u.t[-1] - u.t[ends])
        H = np.concatenate(feats)
        self._mean = H.mean(axis=0)
        scale = H.std(axis=0)
        self._scale = np.where(scale > 0, scale, 1.0)
        self._owner = np.concatenate(owner)
        self._rul = np.concatenate(rul)
        self._tree = NearestNeighbors().fit((H - self._mean) / self._scale)
        names = [f"{c}/{f}" for f in as_columns(self.features) for c in self._columns]
        self.hashes_ = pd.DataFrame(H, columns=names)
        self.hashes_.insert(0, "rul", self._rul)
        self.hashes_.insert(0, "unit", [units[j].name for j in self._owner])

    def _match(self, u):
        wins, age, _ = self._windows(u, last_only=True)
        h = (self._hash(wins, age) - self._mean) / self._scale
        n_lib = len(self._owner)
        n_units = len(self.train_units_)
        want = min(n_lib, max(50 * int(self.k), 500))
        while True:
            dist, idx = self._tree.kneighbors(h, n_neighbors=want)
            dist, idx = dist[0], idx[0]
            d = np.full(n_units, np.inf)
            rul = np.zeros(n_units)
            seen = set()
            for di, ii in zip(dist, idx, strict=True):
                j = self._owner[ii]
                if j not in seen:
                    seen.add(j)
                    d[j], rul[j] = di, self._rul[ii]
            if len(seen) >= min(int(self.k), n_units) or want == n_lib:
                return d, rul
            want = min(n_lib, want * 4)
