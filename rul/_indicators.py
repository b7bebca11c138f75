"""Health indicators: regime normalisation, smoothing, selection and fusion.

The road from raw sensors to one prognostic indicator, as MATLAB's similarity-based
RUL example walks it:

1. :class:`RegimeNormalizer` - standardise each sensor within its operating regime
   (clusters of the operating settings), so that a change of regime is not read as
   degradation;
2. :func:`smooth_indicators` - causal smoothing per unit (only the past is used, so
   the same smoothing works online);
3. :func:`prognostic_ranking` - monotonicity, trendability and prognosability of each
   candidate (from :func:`pdmkit.features.rank_features`) and their weighted mean;
4. :class:`HealthIndicator` - fuse the best candidates into one indicator: a linear map
   fitted to the fraction of life used (0 new, 1 failed) or the first principal
   component scaled to the same range.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError
from pdmkit.rul._base import (
    LABEL_COLUMNS,
    as_columns,
    check_columns,
    check_fitted,
    check_positive_int,
    check_table,
    failed_column,
    keep_init_args,
    require_failures,
    resolve_keys,
    split_units,
)

if TYPE_CHECKING:
    from typing import Self

_SMOOTHERS = ("ewm", "moving_average", "moving_median")
_PROGNOSTIC = ("monotonicity", "trendability", "prognosability")


def _candidate_columns(
    table: pd.DataFrame, keys: Sequence[str], exclude: Sequence[str] = ()
) -> list[str]:
    skip = set(keys) | set(LABEL_COLUMNS) | set(exclude)
    return [
        c
        for c in table.columns
        if c not in skip
        and pd.api.types.is_numeric_dtype(table[c])
        and not pd.api.types.is_bool_dtype(table[c])
    ]


# --------------------------------------------------------------------------- smoothing
def smooth_indicators(
    table: pd.DataFrame,
    columns: str | Sequence[str] | None = None,
    *,
    method: str = "ewm",
    span: float = 10,
    unit: str = "unit",
    time: str | None = None,
) -> pd.DataFrame:
    """Smooth indicator columns per unit, causally (each value from the past only).

    Parameters
    ----------
    table : pandas.DataFrame
        Long run-to-failure table.
    columns : str or sequence of str, optional
        Columns to smooth; default every numeric column except the unit, time and label
        columns (``rul``, ``rul_true_final``, ``failed``).
    method : {"ewm", "moving_average", "moving_median"}
        Exponentially weighted mean with the given ``span`` (pandas ``ewm(span=...)``),
        or the mean / median of the last ``span`` samples (fewer at a unit's start).
    span : float, default 10
        Span (``ewm``) or window length in samples (moving average / median).
    unit, time : str
        Columns telling the units apart and ordering their rows (``time`` defaults to
        ``"time"`` or ``"cycle"``).

    Returns
    -------
    pandas.DataFrame
        A copy of ``table`` (same row order) with the columns smoothed.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.rul import smooth_indicators
    >>> t = pd.DataFrame({"unit": [1, 1, 1, 2, 2], "time": [1, 2, 3, 1, 2],
    ...                   "x": [0.0, 3.0, 6.0, 10.0, 20.0]})
    >>> smooth_indicators(t, "x", method="moving_average", span=2)["x"].tolist()
    [0.0, 1.5, 4.5, 10.0, 15.0]
    """
    table = check_table(table)
    unit, time = resolve_keys(table, unit, time)
    if method not in _SMOOTHERS:
        raise ValueError(f"method must be one of {list(_SMOOTHERS)}, got {method!r}")
    if isinstance(span, bool) or not isinstance(span, int | float | np.number) or span < 1:
        raise ValueError(f"span must be a number >= 1, got {span!r}")
    cols = (
        _candidate_columns(table, (unit, time)) if columns is None else as_columns(columns)
    )
    check_columns(table, cols, "columns")
    ordered = table.reset_index(drop=True).sort_values([unit, time], kind="stable")
    grouped = ordered.groupby(unit, sort=False)[cols]
    if method == "ewm":
        smoothed = grouped.transform(lambda s: s.ewm(span=float(span), adjust=True).mean())
    else:
        window = round(float(span))
        how = "mean" if method == "moving_average" else "median"
        smoothed = grouped.transform(
            lambda s: getattr(s.rolling(window, min_periods=1), how)()
        )
    out = table.copy()
    out[cols] = smoothed.sort_index().to_numpy()
    return out


# --------------------------------------------------------------------------- regimes
class RegimeNormalizer(BaseEstimator):
    """Standardise indicators within each operating regime.

    Operating regimes are clusters (k-means) of the operating-setting columns; every
    indicator is then centred and scaled with the mean and standard deviation of its
    regime in the training table. With one regime this is plain standardisation.

    Parameters
    ----------
    settings : sequence of str, optional
        Operating-setting columns to cluster (needed when ``n_regimes > 1``).
    n_regimes : int, default 1
        Number of regimes (k-means clusters of the standardised settings).
    columns : sequence of str, optional
        Columns to normalise; default every numeric column except the unit, time,
        settings and label columns.
    unit, time : str
        Key columns (left untouched).
    random_state : int, default 0
        Seed of k-means.

    Attributes
    ----------
    columns_ : list of str
    mean_, scale_ : pandas.DataFrame
        Per-regime mean and standard deviation (rows: regimes, columns: ``columns_``);
        a column constant within a regime has scale 1 there and normalises to 0.
    constant_ : list of str
        Columns constant within every regime.
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import RegimeNormalizer
    >>> rng = np.random.default_rng(0)
    >>> regime = rng.integers(0, 2, 200)
    >>> t = pd.DataFrame({"unit": np.repeat([1, 2], 100),
    ...                   "time": np.tile(np.arange(100), 2), "load": regime * 10.0,
    ...                   "temp": 300 + 50 * regime + rng.normal(0, 1, 200)})
    >>> z = RegimeNormalizer(settings=["load"], n_regimes=2).fit_transform(t)
    >>> bool(abs(z["temp"].std() - 1) < 0.05)  # the 50 K regime step is gone
    True
    """

    def __init__(
        self,
        settings: Sequence[str] | None = None,
        n_regimes: int = 1,
        columns: Sequence[str] | None = None,
        *,
        unit: str = "unit",
        time: str | None = None,
        random_state: int = 0,
    ) -> None:
        keep_init_args(self, locals())

    def _regimes(self, table: pd.DataFrame) -> np.ndarray:
        if self.n_regimes == 1:
            return np.zeros(len(table), dtype=int)
        check_columns(table, self.settings_, "settings")
        s = table[self.settings_].to_numpy(dtype=float)
        if not np.isfinite(s).all():
            raise DataError("settings columns have NaN or inf values")
        return self.kmeans_.predict((s - self.settings_mean_) / self.settings_scale_)

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Learn the regimes and the per-regime statistics.

        Returns
        -------
        self

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import RegimeNormalizer
        >>> t = pd.DataFrame({"unit": [1, 1, 1], "time": [1, 2, 3], "x": [1.0, 2.0, 3.0]})
        >>> RegimeNormalizer().fit(t).mean_["x"].tolist()
        [2.0]
        """
        table = check_table(table)
        unit, time = resolve_keys(table, self.unit, self.time)
        k = check_positive_int(self.n_regimes, "n_regimes")
        settings = [] if self.settings is None else as_columns(self.settings)
        if k > 1 and not settings:
            raise ValueError(
                f"n_regimes={k} needs the operating-setting columns to cluster: pass "
                "settings=[...]"
            )
        self.settings_ = settings
        cols = (
            _candidate_columns(table, (unit, time), exclude=settings)
            if self.columns is None
            else as_columns(self.columns)
        )
        check_columns(table, cols, "columns")
        if not cols:
            raise DataError("no numeric indicator columns to normalise")
        x = table[cols].to_numpy(dtype=float)
        if not np.isfinite(x).all():
            raise DataError(
                "indicator columns have NaN or inf values; fill or drop them first"
            )
        if k > 1:
            from sklearn.cluster import KMeans

            check_columns(table, settings, "settings")
            s = table[settings].to_numpy(dtype=float)
            self.settings_mean_ = s.mean(axis=0)
            scale = s.std(axis=0)
            self.settings_scale_ = np.where(scale > 0, scale, 1.0)
            self.kmeans_ = KMeans(k, n_init=10, random_state=self.random_state).fit(
                (s - self.settings_mean_) / self.settings_scale_
            )
        self.columns_ = cols
        labels = self._regimes(table)
        means, scales = [], []
        for r in range(k):
            rows = x[labels == r]
            if len(rows) < 2:
                raise DataError(
                    f"regime {r} holds {len(rows)} row(s) of the training table; use fewer "
                    "regimes (n_regimes) or more data"
                )
            means.append(rows.mean(axis=0))
            scales.append(rows.std(axis=0, ddof=1))
        mean = np.array(means)
        scale = np.array(scales)
        flat = scale <= 1e-12 * np.maximum(1.0, np.abs(mean))
        self.constant_ = [c for c, f in zip(cols, flat.all(axis=0), strict=True) if f]
        scale = np.where(flat, 1.0, scale)
        self.mean_ = pd.DataFrame(mean, columns=cols)
        self.scale_ = pd.DataFrame(scale, columns=cols)
        self.mean_.index.name = self.scale_.index.name = "regime"
        self.n_units_ = int(table[unit].nunique())
        return self

    def regimes(self, table: pd.DataFrame) -> np.ndarray:
        """Regime (0 .. n_regimes - 1) of each row.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import RegimeNormalizer
        >>> t = pd.DataFrame({"unit": 1, "time": range(4), "s": [0, 0, 9, 9], "x": 1.0})
        >>> norm = RegimeNormalizer(settings=["s"], n_regimes=2).fit(t)
        >>> len(set(norm.regimes(t)))
        2
        """
        check_fitted(self, "mean_")
        return self._regimes(check_table(table))

    def transform(self, table: pd.DataFrame) -> pd.DataFrame:
        """Return a copy of ``table`` with the columns normalised per regime.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import RegimeNormalizer
        >>> t = pd.DataFrame({"unit": 1, "time": [1, 2, 3], "x": [1.0, 2.0, 3.0]})
        >>> RegimeNormalizer().fit(t).transform(t)["x"].tolist()
        [-1.0, 0.0, 1.0]
        """
        check_fitted(self, "mean_")
        table = check_table(table)
        check_columns(table, self.columns_, "columns")
        labels = self._regimes(table)
        x = table[self.columns_].to_numpy(dtype=float)
        z = (x - self.mean_.to_numpy()[labels]) / self.scale_.to_numpy()[labels]
        out = table.copy()
        out[self.columns_] = z
        return out

    def fit_transform(self, table: pd.DataFrame, y: object = None) -> pd.DataFrame:
        """Fit, then transform the same table.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import RegimeNormalizer
        >>> t = pd.DataFrame({"unit": 1, "time": [1, 2], "x": [1.0, 3.0]})
        >>> RegimeNormalizer().fit_transform(t)["x"].round(4).tolist()
        [-0.7071, 0.7071]
        """
        return self.fit(table).transform(table)


# --------------------------------------------------------------------------- ranking
def prognostic_ranking(
    table: pd.DataFrame,
    features: Sequence[str] | None = None,
    *,
    methods: Sequence[str] = _PROGNOSTIC,
    weights: Sequence[float] | None = None,
    smoothing: float | None = None,
    unit: str = "unit",
    time: str | None = None,
) -> pd.DataFrame:
    """Score candidate indicators by monotonicity, trendability and prognosability.

    Each score comes from :func:`pdmkit.features.rank_features` (all in ``[0, 1]``,
    higher is better); ``score`` is their weighted mean, the criterion MATLAB's RUL
    examples rank by.

    Parameters
    ----------
    table : pandas.DataFrame
        Long run-to-failure table.
    features : sequence of str, optional
        Candidates; default every numeric column but the key and label columns.
    methods : sequence of str, default all three
        Any of ``"monotonicity", "trendability", "prognosability"``.
    weights : sequence of float, optional
        Weight per method (default equal).
    smoothing : float, optional
        If given, an ``ewm`` span to smooth each unit's path before scoring
        (monotonicity of a raw noisy sensor is close to 0 even when it trends).
    unit, time : str
        Key columns.

    Returns
    -------
    pandas.DataFrame
        Indexed by feature, one column per method and ``score``; best first,
        unscorable (constant) features last with ``score`` NaN.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import prognostic_ranking
    >>> rng = np.random.default_rng(0)
    >>> t = pd.DataFrame({"unit": np.repeat([1, 2, 3], 50),
    ...                   "time": np.tile(np.arange(50), 3)})
    >>> t["wear"] = t["time"] ** 1.5 + rng.normal(0, 5, 150)
    >>> t["noise"] = rng.normal(0, 1, 150)
    >>> prognostic_ranking(t, smoothing=5).index.tolist()
    ['wear', 'noise']
    """
    from pdmkit.features import rank_features

    table = check_table(table)
    unit, time = resolve_keys(table, unit, time)
    methods = as_columns(methods)
    bad = [m for m in methods if m not in _PROGNOSTIC]
    if bad or not methods:
        raise ValueError(f"methods must be taken from {list(_PROGNOSTIC)}, got {methods}")
    w = np.ones(len(methods)) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (len(methods),) or (w < 0).any() or w.sum() <= 0:
        raise ValueError(
            f"weights must be {len(methods)} non-negative numbers with a positive sum, "
            f"got {weights}"
        )
    cols = (
        _candidate_columns(table, (unit, time))
        if features is None
        else as_columns(features)
    )
    check_columns(table, cols, "features")
    if not cols:
        raise DataError("no numeric candidate indicators in the table")
    data = table[[unit, time, *cols]]
    if smoothing is not None:
        data = smooth_indicators(data, cols, span=smoothing, unit=unit, time=time)
    scores = {}
    for m in methods:
        ranking = rank_features(data, method=m, features=cols, unit=unit, time=time)
        scores[m] = ranking.scores.reindex(cols)
    frame = pd.DataFrame(scores)
    frame["score"] = frame[methods].to_numpy() @ (w / w.sum())
    frame.index.name = "feature"
    return frame.sort_values("score", ascending=False, na_position="last", kind="stable")


# --------------------------------------------------------------------------- fusion
def _drop_constant(
    cols: list[str], mean: np.ndarray, scale: np.ndarray
) -> tuple[dict[str, str], list[str]]:
    """The constant candidates (-> why dropped) and the others; refuse all constant."""
    flat = ~(scale > 1e-12 * np.maximum(1.0, np.abs(mean)))
    dropped = {
        c: "constant over the training table" for c, f in zip(cols, flat, strict=True) if f
    }
    keep = [c for c, f in zip(cols, flat, strict=True) if not f]
    if not keep:
        raise DataError(
            f"every candidate indicator is constant over the training table ({cols}); "
            "a constant indicator carries no degradation information - pick columns "
            "that change with wear"
        )
    return dropped, keep


def _linear_fusion(units: list, z_units: list[np.ndarray]) -> tuple[float, np.ndarray]:
    """Intercept and weights: least squares of each unit's fraction of life used."""
    z = np.concatenate(z_units)
    life = []
    for u in units:
        span = u.t[-1] - u.t[0]
        life.append((u.t - u.t[0]) / span if span > 0 else np.ones(len(u)))
    target = np.concatenate(life)
    design = np.column_stack([np.ones(len(z)), z])
    beta, *_ = np.linalg.lstsq(design, target, rcond=None)
    return float(beta[0]), beta[1:]


def _pca_fusion(units: list, z_units: list[np.ndarray]) -> tuple[float, np.ndarray]:
    """Intercept and weights: the first principal component, growing from 0 to 1."""
    z = np.concatenate(z_units)
    centred = z - z.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    direction = vt[0]
    raw = [zu @ direction for zu in z_units]
    trend = np.mean(
        [
            np.polyfit(u.t, r, 1)[0] if len(u) > 1 else 0.0
            for u, r in zip(units, raw, strict=True)
        ]
    )
    if trend < 0:
        direction = -direction
        raw = [-r for r in raw]
    start = np.mean([r[0] for r in raw])
    end = np.mean([r[-1] for r in raw])
    if not end > start:
        raise DataError(
            "the first principal component does not change from the units' start "
            "to their end; it cannot serve as a health indicator (try "
            "method='linear')"
        )
    return -start / (end - start), direction / (end - start)


class HealthIndicator(BaseEstimator):
    """Fuse several candidate indicators into one health indicator (HI).

    The HI runs from about 0 for a new unit to about 1 at failure. Candidates are
    standardised (mean 0, standard deviation 1 over the training rows); constant ones
    are dropped; with ``n_features`` the best ones by :func:`prognostic_ranking` are
    kept; then either

    - ``method="linear"``: least squares of the fraction of life used,
      ``(t - t_start) / (t_fail - t_start)`` of each training unit, on the candidates
      (needs run-to-failure training units), or
    - ``method="pca"``: the first principal component, signed to grow with time and
      scaled so that the training units start at 0 and end at 1 on average.

    Parameters
    ----------
    features : sequence of str, optional
        Candidate columns; default every numeric column but the key and label columns
        (``rul``, ``rul_true_final``, ``failed``).
    method : {"linear", "pca"}, default "linear"
    n_features : int, optional
        Keep the best ``n_features`` candidates by ``ranking`` (default all).
    ranking : sequence of str, default all three prognostic metrics
        Methods passed to :func:`prognostic_ranking` (with ``smoothing`` or a span of 10).
    smoothing : float, optional
        ``ewm`` span used to smooth the HI of each unit (causally) in ``transform``.
    output : str, default "hi"
        Name of the column ``transform`` adds.
    unit, time, failed : str
        Key columns (``failed`` optional: False marks censored units).

    Attributes
    ----------
    features_ : list of str
        Candidates after dropping constant ones.
    dropped_ : dict
        Dropped candidate -> why.
    selected_ : list of str
        The candidates fused.
    ranking_ : pandas.DataFrame or None
        The :func:`prognostic_ranking` table (when ``n_features`` is given).
    coef_ : pandas.Series
        HI = ``intercept_ + coef_ @ standardised selected features``.
    intercept_ : float
    mean_, scale_ : pandas.Series
        Standardisation of the selected features.
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import HealthIndicator
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u, life in enumerate([80, 100, 120]):
    ...     t = np.arange(1, life + 1)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t,
    ...         "temp": 300 + 20 * (t / life) ** 2 + rng.normal(0, 1, life),
    ...         "vib": 1 + (t / life) + rng.normal(0, 0.05, life),
    ...         "const": 5.0}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> hi = HealthIndicator(smoothing=5).fit(train)
    >>> hi.selected_, list(hi.dropped_)
    (['temp', 'vib'], ['const'])
    >>> out = hi.transform(train)
    >>> ends = out.groupby("unit")["hi"].last()
    >>> bool(ends.between(0.8, 1.2).all())
    True
    """

    def __init__(
        self,
        features: Sequence[str] | None = None,
        method: str = "linear",
        n_features: int | None = None,
        *,
        ranking: Sequence[str] = _PROGNOSTIC,
        smoothing: float | None = None,
        output: str = "hi",
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Select and fuse the candidates on run-to-failure training units.

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            Every candidate constant; censored training units with ``method="linear"``;
            missing columns; NaN values.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import HealthIndicator
        >>> t = pd.DataFrame({"unit": [1, 1, 1, 2, 2, 2], "time": [1, 2, 3] * 2,
        ...                   "x": [0.0, 1.0, 2.0, 0.0, 2.0, 4.0]})
        >>> HealthIndicator().fit(t).selected_
        ['x']
        """
        table = check_table(table)
        unit, time = resolve_keys(table, self.unit, self.time)
        self._check_options()
        failed = failed_column(table, self.failed)
        cols = (
            _candidate_columns(table, (unit, time, *([failed] if failed else [])))
            if self.features is None
            else as_columns(self.features)
        )
        check_columns(table, cols, "features")
        if not cols:
            raise DataError(
                "the table has no numeric candidate indicators; pass features=[...]"
            )
        units = split_units(table, cols, unit=unit, time=time, failed=failed)
        x = np.concatenate([u.x for u in units])
        mean = x.mean(axis=0)
        scale = x.std(axis=0, ddof=1) if len(x) > 1 else np.zeros(len(cols))
        self.dropped_, keep = _drop_constant(cols, mean, scale)
        self.features_ = keep
        self.ranking_ = None
        selected = self._select_best(table, keep, unit, time)
        pick = [cols.index(c) for c in selected]
        self.mean_ = pd.Series(mean[pick], index=selected)
        self.scale_ = pd.Series(scale[pick], index=selected)
        z_units = [(u.x[:, pick] - mean[pick]) / scale[pick] for u in units]
        if self.method == "linear":
            require_failures(units, "HealthIndicator(method='linear')")
            intercept, coef = _linear_fusion(units, z_units)
        else:
            intercept, coef = _pca_fusion(units, z_units)
        self.coef_ = pd.Series(coef, index=selected)
        self.intercept_ = intercept
        self.selected_ = selected
        self._keys = (unit, time)
        self.n_units_ = len(units)
        return self

    def _check_options(self) -> None:
        """Refuse an unknown method, a bad ``n_features`` or a bad smoothing span."""
        if self.method not in ("linear", "pca"):
            raise ValueError(f"method must be 'linear' or 'pca', got {self.method!r}")
        if self.n_features is not None:
            check_positive_int(self.n_features, "n_features")
        if self.smoothing is not None and (
            isinstance(self.smoothing, bool)
            or not isinstance(self.smoothing, int | float | np.number)
            or self.smoothing < 1
        ):
            raise ValueError(
                f"smoothing must be an ewm span >= 1 or None, got {self.smoothing!r}"
            )

    def _select_best(
        self, table: pd.DataFrame, keep: list[str], unit: str, time: str
    ) -> list[str]:
        """The best ``n_features`` of ``keep`` by prognostic ranking (all without it).

        Sets ``ranking_`` and notes the ones left out in ``dropped_``.
        """
        if self.n_features is None or self.n_features >= len(keep):
            return keep
        self.ranking_ = prognostic_ranking(
            table,
            keep,
            methods=self.ranking,
            smoothing=self.smoothing or 10,
            unit=unit,
            time=time,
        )
        best = self.ranking_.index[self.ranking_["score"].notna()].tolist()
        selected = best[: self.n_features]
        for c in keep:
            if c not in selected:
                self.dropped_[c] = "ranked below the best n_features"
        return selected

    def transform(self, table: pd.DataFrame) -> pd.DataFrame:
        """Return a copy of ``table`` with the health indicator added as ``output``.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import HealthIndicator
        >>> t = pd.DataFrame({"unit": [1, 1, 1], "time": [1, 2, 3], "x": [0.0, 1.0, 2.0]})
        >>> HealthIndicator().fit(t).transform(t)["hi"].round(6).tolist()
        [0.0, 0.5, 1.0]
        """
        check_fitted(self, "coef_")
        table = check_table(table)
        check_columns(table, self.selected_, "features")
        x = table[self.selected_].to_numpy(dtype=float)
        if not np.isfinite(x).all():
            raise DataError(
                "indicator columns have NaN or inf values; fill or drop them first"
            )
        z = (x - self.mean_.to_numpy()) / self.scale_.to_numpy()
        out = table.copy()
        out[self.output] = self.intercept_ + z @ self.coef_.to_numpy()
        if self.smoothing is not None:
            out = smooth_indicators(
                out,
                self.output,
                span=self.smoothing,
                unit=self._keys[0],
                time=self._keys[1],
            )
        return out

    def fit_transform(self, table: pd.DataFrame, y: object = None) -> pd.DataFrame:
        """Fit, then transform the same table.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import HealthIndicator
        >>> t = pd.DataFrame({"unit": [1, 1], "time": [1, 2], "x": [3.0, 5.0]})
        >>> (HealthIndicator().fit_transform(t)["hi"].round(6) + 0.0).tolist()
        [0.0, 1.0]
        """
        return self.fit(table).transform(table)
