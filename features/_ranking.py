"""Ranking and selecting condition indicators.

Two kinds of ranking, as in MATLAB's Diagnostic Feature Designer:

- **Separating classes** (``labels`` given), higher is better: Kruskal-Wallis H
  (rank-based one-way ANOVA, robust to outliers and skew), the one-way ANOVA F
  statistic, Fisher's discriminant ratio, the one-vs-rest ROC AUC or the Bhattacharyya
  distance (defined in :mod:`pdmkit.features._separability`). H depends on ranks only:
  once the classes no longer overlap it sits at its ceiling, the same for every such
  feature (noted as ``classes fully separated``), and so does the AUC at 1 for two
  classes. Fisher and Bhattacharyya keep growing with the gap between the classes
  relative to their spread: rank well-separated classes with them.
  :func:`pdmkit.features.ranking_stability` repeats a ranking on cross-validation folds.
- **Prognostic quality** (a long run-to-failure table with ``unit`` and ``time``
  columns), as J. Coble and J. W. Hines define them (*Identifying optimal prognostic
  parameters from data: a genetic algorithms approach*, Annual Conference of the PHM
  Society, 2009) and MATLAB's Predictive Maintenance Toolbox computes them, all in
  ``[0, 1]``, higher is better:

  - ``monotonicity``: ``mean_j |#(dx > 0) - #(dx < 0)| / (n_j - 1)`` over units ``j``
    (``dx`` the successive differences of the unit's path, ``n_j`` its length);
  - ``trendability``: ``min_{j != k} |corr(x_j, x_k)|``, the paths resampled (linear
    interpolation over the fraction of life) to the length of the shortest one;
  - ``prognosability``: ``exp(-std_j(x_j(end)) / mean_j |x_j(start) - x_j(end)|)``
    (``std`` with ``n - 1``; undefined, NaN, for a single unit).

Features that cannot be scored (constant, all NaN, too few groups) get a NaN score, are
ranked last and carry a note saying why.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
import scipy.stats
from numpy.typing import ArrayLike
from sklearn.feature_selection import f_classif

from pdmkit._checks import parse_timestamps
from pdmkit.errors import DataError
from pdmkit.features._separability import (
    SEPARABILITY,
    class_ranges,
    fully_separated,
    separation_scores,
)

__all__ = ["CLASS_METHODS", "METHODS", "FeatureRanking", "rank_features"]

#: the methods :class:`SelectTopRanked` takes (its own scores: H and F)
_SUPERVISED = ("kruskal", "anova")
#: the methods that rank by class labels
CLASS_METHODS = (*_SUPERVISED, *SEPARABILITY)
METHODS = (*CLASS_METHODS, "monotonicity", "trendability", "prognosability")
_AXIS_LABELS = {
    "kruskal": "Kruskal-Wallis H",
    "anova": "ANOVA F",
    "fisher": "Fisher ratio (between / within-class variance)",
    "auc": "ROC AUC one-vs-rest, max(AUC, 1 - AUC)",
    "bhattacharyya": "Bhattacharyya distance (mean over class pairs)",
    "monotonicity": "Monotonicity",
    "trendability": "Trendability",
    "prognosability": "Prognosability",
}


# --------------------------------------------------------------------------- result
class FeatureRanking:
    """Features ranked by a score (higher is better), with p-values and notes.

    Parameters
    ----------
    scores : mapping or pandas.Series
        Feature name -> score; NaN for features that could not be scored.
    method : str
        How the scores were computed (one of :data:`METHODS`).
    p_values : mapping or pandas.Series, optional
        Feature name -> p-value (Kruskal-Wallis and ANOVA).
    notes : mapping, optional
        Feature name -> why it could not be scored, or what was left out.

    Attributes
    ----------
    scores : pandas.Series
        Scores in rank order (best first, NaN last).
    p_values : pandas.Series or None
        p-values in the same order.
    notes : dict
        Feature -> note, for the features that have one.
    method : str

    Examples
    --------
    >>> from pdmkit.features import FeatureRanking
    >>> r = FeatureRanking({"a": 1.0, "b": 3.0, "c": float("nan")}, method="kruskal",
    ...                    notes={"c": "constant feature"})
    >>> r.top(2), r.features
    (['b', 'a'], ['b', 'a', 'c'])
    >>> r.to_pandas()[["feature", "score", "rank"]]
      feature  score  rank
    0       b    3.0     1
    1       a    1.0     2
    2       c    NaN     3
    >>> r.notes
    {'c': 'constant feature'}
    """

    def __init__(self, scores, *, method: str, p_values=None, notes=None) -> None:
        scores = pd.Series(scores, dtype=float)
        scores.index = scores.index.map(str)
        values = scores.to_numpy()
        # best first; NaN last; ties keep the input order
        order = np.lexsort(
            (np.arange(len(values)), -np.nan_to_num(values, nan=0.0), np.isnan(values))
        )
        self.scores = scores.iloc[order]
        self.method = method
        self.p_values = (
            None
            if p_values is None
            else pd.Series(p_values, dtype=float)
            .rename(index=str)
            .reindex(self.scores.index)
        )
        self.notes = {str(k): str(v) for k, v in (notes or {}).items() if v}

    @property
    def features(self) -> list[str]:
        """All features, best first (unscored ones last).

        Examples
        --------
        >>> from pdmkit.features import FeatureRanking
        >>> FeatureRanking({"x": 0.1, "y": 0.9}, method="monotonicity").features
        ['y', 'x']
        """
        return [str(f) for f in self.scores.index]

    def __len__(self) -> int:
        return len(self.scores)

    def __repr__(self) -> str:
        best = ", ".join(f"{f}={s:.4g}" for f, s in self.scores.head(3).items())
        return f"FeatureRanking(method={self.method!r}, {len(self)} features; best: {best})"

    def top(self, k: int = 5) -> list[str]:
        """The ``k`` best-ranked features that have a score (fewer if fewer do).

        Examples
        --------
        >>> from pdmkit.features import FeatureRanking
        >>> FeatureRanking({"x": 2.0, "y": float("nan")}, method="anova").top(5)
        ['x']
        """
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 0:
            raise DataError(f"k must be a non-negative integer, got {k!r}")
        scored = self.scores[self.scores.notna()]
        return [str(f) for f in scored.index[: int(k)]]

    def to_pandas(self) -> pd.DataFrame:
        """Table with ``feature, score, rank, method, p_value, note``, best first.

        ``p_value`` is NaN for the methods without one; ``note`` is empty unless the
        feature was left out or partly left out.

        Examples
        --------
        >>> from pdmkit.features import FeatureRanking
        >>> r = FeatureRanking({"x": 2.0}, method="anova", p_values={"x": 0.01})
        >>> r.to_pandas().drop(columns="note")
          feature  score  rank method  p_value
        0       x    2.0     1  anova     0.01
        """
        n = len(self.scores)
        p = (
            np.full(n, np.nan)
            if self.p_values is None
            else self.p_values.to_numpy(dtype=float)
        )
        return pd.DataFrame(
            {
                "feature": self.features,
                "score": self.scores.to_numpy(),
                "rank": np.arange(1, n + 1),
                "method": self.method,
                "p_value": p,
                "note": [self.notes.get(f, "") for f in self.features],
            }
        )

    def plot(self, ax=None, k: int = 20):
        """Horizontal bar chart of the ``k`` best scores (best at the top).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw; a new figure when omitted.
        k : int, default 20
            How many features to show.

        Returns
        -------
        matplotlib.axes.Axes

        Examples
        --------
        >>> from pdmkit.features import FeatureRanking
        >>> ax = FeatureRanking({"x": 2.0, "y": 1.0}, method="kruskal").plot()
        >>> [t.get_text() for t in ax.get_yticklabels()]
        ['y', 'x']
        """
        import matplotlib.pyplot as plt

        names = self.top(k)
        values = self.scores.loc[names].to_numpy(dtype=float)
        if ax is None:
            height = 1.0 + 0.3 * max(len(names), 1)
            _, ax = plt.subplots(figsize=(7, height))
        finite = values[np.isfinite(values)]
        cap = finite.max() * 1.1 if finite.size and finite.max() > 0 else 1.0
        shown = np.where(np.isinf(values), cap, values)
        y = np.arange(len(names))  # best at the top
        ax.barh(y, shown[::-1], color="C0")
        for yi, v in zip(y, values[::-1], strict=True):
            if np.isinf(v):
                ax.text(cap, yi, " inf", va="center")
        ax.set_yticks(y, labels=names[::-1])
        ax.set_xlabel(_AXIS_LABELS.get(self.method, self.method))
        ax.set_title(f"Feature ranking ({self.method})")
        return ax


# --------------------------------------------------------------------------- scores
def _group_codes(labels: np.ndarray) -> tuple[np.ndarray, int]:
    codes, uniques = pd.factorize(pd.Series(labels), use_na_sentinel=True)
    return codes, len(uniques)


def _one_way_block(X: np.ndarray, codes: np.ndarray, method: str):
    """Scores of fully-finite columns ``X`` (N x p) for group codes (vectorised).

    Kruskal-Wallis H is :func:`scipy.stats.kruskal`, ANOVA F is
    :func:`sklearn.feature_selection.f_classif`, the others come from
    :func:`~pdmkit.features._separability.separation_scores`; this adds what a ranking
    needs around them: constant columns score NaN with a note, an F with no spread
    within groups is infinite with p = 0, an H of fully-separated classes is noted.
    """
    n, p = X.shape
    present = np.unique(codes)
    codes = np.searchsorted(present, codes)
    k = len(present)
    scores = np.full(p, np.nan)
    pvals = np.full(p, np.nan)
    notes = np.full(p, "", dtype=object)
    if k < 2:
        notes[:] = f"needs at least 2 groups with data, found {k}"
        return scores, pvals, notes
    constant = np.ptp(X, axis=0) == 0 if n else np.ones(p, dtype=bool)
    if method in ("anova", "fisher") and n - k < 1:
        notes[~constant] = "every group has a single value: no within-group spread"
        notes[constant] = "constant feature"
        return scores, pvals, notes
    with np.errstate(divide="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # constant columns: NaN and a note below
        if method in SEPARABILITY:
            scores, pvals, notes = separation_scores(X, codes, k, method)
        else:
            scores, pvals, notes = _h_or_f(X, codes, k, method)
    scores = np.asarray(scores, dtype=float)
    pvals = np.asarray(pvals, dtype=float)
    notes[constant] = "constant feature"
    scores[constant] = np.nan
    pvals[constant] = np.nan
    return scores, pvals, notes


def _h_or_f(X: np.ndarray, codes: np.ndarray, k: int, method: str):
    """Kruskal-Wallis H (with the tie correction) or ANOVA F, p-values and notes."""
    notes = np.full(X.shape[1], "", dtype=object)
    if method == "kruskal":
        groups = [X[codes == g] for g in range(k)]
        scores, pvals = scipy.stats.kruskal(*groups, axis=0)
        notes[fully_separated(*class_ranges(X, codes, k))] = (
            "classes fully separated: H at its ceiling, the same for every such "
            "feature; method='fisher' or 'bhattacharyya' tells them apart"
        )
        return np.asarray(scores, dtype=float), np.asarray(pvals, dtype=float), notes
    scores, pvals = f_classif(X, codes)
    scores = np.asarray(scores, dtype=float)
    pvals = np.asarray(pvals, dtype=float)
    perfect = np.isinf(scores)
    pvals[perfect] = 0.0
    notes[perfect] = "no spread within groups (F is infinite)"
    return scores, pvals, notes


def _one_way(X: np.ndarray, codes: np.ndarray, method: str):
    """A class-separation score per column; NaN samples of a column are left out."""
    p = X.shape[1]
    keep_rows = codes >= 0
    X, codes = X[keep_rows], codes[keep_rows]
    finite = np.isfinite(X)
    full = finite.all(axis=0)
    scores = np.full(p, np.nan)
    pvals = np.full(p, np.nan)
    notes = np.full(p, "", dtype=object)
    cols = np.flatnonzero(full)
    if cols.size:
        scores[cols], pvals[cols], notes[cols] = _one_way_block(X[:, cols], codes, method)
    for j in np.flatnonzero(~full):
        ok = finite[:, j]
        if not ok.any():
            notes[j] = "all values are NaN or inf"
            continue
        s, pv, nt = _one_way_block(X[ok, j : j + 1], codes[ok], method)
        scores[j], pvals[j] = s[0], pv[0]
        left_out = f"{int((~ok).sum())} NaN/inf value(s) left out"
        notes[j] = f"{nt[0]}; {left_out}" if nt[0] else left_out
    return scores, pvals, notes


def _time_values(table: pd.DataFrame, time) -> pd.Series:
    """The time column as numbers: seconds since the earliest stamp for timestamps.

    Numbers stay as they are; datetimes, and text that reads as timestamps
    (``2004-02-12 10:32:39``), become seconds since the earliest one. Text that is
    neither is a DataError naming the column and the first such cell.
    """
    column = table[time]
    if pd.api.types.is_bool_dtype(column):
        raise DataError(f"time column {time!r} holds true/false values, not times")
    if pd.api.types.is_numeric_dtype(column):
        return column.astype(float)

    stamps = parse_timestamps(column)
    bad = stamps.isna() & column.notna()
    if bad.any():
        first = column[bad].iloc[0]
        raise DataError(
            f"time column {time!r} holds {str(first)!r}, neither a number nor a "
            "timestamp; name the column that orders the rows with time="
        )
    if getattr(stamps.dt, "tz", None) is not None:
        stamps = stamps.dt.tz_convert("UTC")
    return (stamps - stamps.min()).dt.total_seconds()


def _unit_paths(
    table: pd.DataFrame, cols: list, unit, time
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per unit (in order of appearance): (life fraction in [0, 1], values n_j x p)."""
    frame = table
    if time is not None:
        frame = table.assign(**{str(time): _time_values(table, time)})
    if unit is None:
        groups = [(None, frame)]
    else:
        groups = list(frame.groupby(unit, sort=False, dropna=True))
    paths = []
    for _, part in groups:
        if time is not None:
            part = part.sort_values(str(time), kind="stable")
            t = part[str(time)].to_numpy(dtype=float)
        else:
            t = np.arange(len(part), dtype=float)
        span = t[-1] - t[0] if len(t) else 0.0
        life = (t - t[0]) / span if span > 0 else np.linspace(0.0, 1.0, len(t))
        paths.append((life, part[cols].to_numpy(dtype=float)))
    return paths


def _moving_mean(x: np.ndarray, window: int) -> np.ndarray:
    """Centred moving mean of each column over ``window`` rows (MATLAB's ``movmean``).

    NaN values are left out; the window shrinks at the ends.
    """
    return (
        pd.DataFrame(x)
        .rolling(window, center=True, min_periods=1)
        .mean()
        .to_numpy(dtype=float)
    )


def _monotonicity(paths) -> tuple[np.ndarray, np.ndarray]:
    p = paths[0][1].shape[1]
    total = np.zeros(p)
    used = np.zeros(p)
    for _, x in paths:
        for j in range(p):
            v = x[:, j]
            v = v[np.isfinite(v)]
            if len(v) < 2:
                continue
            d = np.diff(v)
            total[j] += abs(int((d > 0).sum()) - int((d < 0).sum())) / (len(v) - 1)
            used[j] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / used, used


def _monotonicity_fast(paths) -> tuple[np.ndarray, np.ndarray]:
    """Monotonicity for NaN-free paths, vectorised over features."""
    p = paths[0][1].shape[1]
    total = np.zeros(p)
    used = 0
    for _, x in paths:
        if len(x) < 2:
            continue
        d = np.diff(x, axis=0)
        total += np.abs((d > 0).sum(0) - (d < 0).sum(0)) / (len(x) - 1)
        used += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / used, np.full(p, used)


def _trendability(paths) -> np.ndarray:
    p = paths[0][1].shape[1]
    scores = np.full(p, np.nan)
    for j in range(p):
        series = []
        for life, x in paths:
            ok = np.isfinite(x[:, j])
            if ok.sum() >= 2:
                series.append((life[ok], x[ok, j]))
        if len(series) < 2:
            continue
        length = min(len(v) for _, v in series)
        grid = np.linspace(0.0, 1.0, length)
        resampled = np.stack([np.interp(grid, t, v) for t, v in series])
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = np.corrcoef(resampled)
        off = ~np.eye(len(series), dtype=bool)
        values = np.abs(corr[off])
        values = values[np.isfinite(values)]
        if values.size:
            scores[j] = values.min()
    return scores


def _prognosability(paths) -> np.ndarray:
    p = paths[0][1].shape[1]
    scores = np.full(p, np.nan)
    for j in range(p):
        starts, ends = [], []
        for _, x in paths:
            v = x[:, j]
            v = v[np.isfinite(v)]
            if len(v):
                starts.append(v[0])
                ends.append(v[-1])
        if not ends:
            continue
        ends_a = np.asarray(ends)
        spread = ends_a.std(ddof=1) if len(ends_a) > 1 else 0.0
        change = np.mean(np.abs(np.asarray(starts) - ends_a))
        with np.errstate(invalid="ignore", divide="ignore"):
            scores[j] = np.exp(-spread / change)
    return scores


# --------------------------------------------------------------------------- public
def _feature_columns(table: pd.DataFrame, features, exclude: set) -> list:
    if features is not None:
        features = [features] if isinstance(features, str) else list(features)
        missing = [f for f in features if f not in table.columns]
        if missing:
            raise DataError(
                f"features {missing} are not columns of the table; it has "
                f"{len(table.columns)} columns, e.g. {list(table.columns[:5])}"
            )
        bad = [f for f in features if not pd.api.types.is_numeric_dtype(table[f])]
        if bad:
            raise DataError(f"features {bad} are not numeric; rank numeric indicators only")
        return features
    numeric = [
        c
        for c in table.columns
        if c not in exclude
        and pd.api.types.is_numeric_dtype(table[c])
        and not pd.api.types.is_bool_dtype(table[c])
    ]
    slashed = [c for c in numeric if "/" in str(c)]
    chosen = slashed or numeric
    if not chosen:
        raise DataError(
            "the table has no numeric feature columns to rank; pass features=[...] to "
            f"name them (columns: {list(table.columns[:10])})"
        )
    return chosen


def _labels(table: pd.DataFrame, labels) -> tuple[np.ndarray, str | None]:
    if labels is None:
        raise DataError(
            "labels are needed for a class-separation ranking: pass the name of the "
            "condition column holding the class, or one label per row"
        )
    if isinstance(labels, str):
        if labels not in table.columns:
            raise DataError(
                f"labels={labels!r} is not a column of the table; columns without '/': "
                f"{[c for c in table.columns if '/' not in str(c)]}"
            )
        return table[labels].to_numpy(), labels
    if isinstance(labels, pd.Series) and labels.index.equals(table.index):
        return labels.to_numpy(), labels.name if labels.name in table.columns else None
    if isinstance(labels, pd.Series) and set(table.index) <= set(labels.index):
        if labels.index.has_duplicates:
            raise DataError(
                "labels has a repeated index; it cannot be aligned to the table"
            )
        aligned = labels.reindex(table.index)
        return aligned.to_numpy(), labels.name if labels.name in table.columns else None
    values = np.asarray(labels)
    if values.ndim != 1 or len(values) != len(table):
        raise DataError(
            f"labels has {values.shape} entries; expected one per table row ({len(table)})"
        )
    return values, None


def _lifetime_column(table: pd.DataFrame, given, candidates: Sequence[str], what: str):
    if given is not None:
        if given not in table.columns:
            raise DataError(
                f"{what}={given!r} is not a column of the table; columns: "
                f"{[c for c in table.columns if '/' not in str(c)]}"
            )
        return given
    return next((c for c in candidates if c in table.columns), None)


def rank_features(
    table: pd.DataFrame,
    labels: pd.Series | ArrayLike | None = None,
    *,
    method: str = "kruskal",
    features: Sequence[str] | None = None,
    unit: str | None = None,
    time: str | None = None,
    window: int | None = None,
) -> FeatureRanking:
    """Rank condition indicators by how well they separate classes or track degradation.

    Parameters
    ----------
    table : pandas.DataFrame
        Feature table (one row per member, or per unit and time for the prognostic
        methods). By default the numeric columns named ``.../...`` are the features (all
        numeric columns when none is), without the label, unit and time columns.
    labels : str or array_like, optional
        The class of each row, for the class methods (:data:`CLASS_METHODS`): a column
        name, a Series (aligned on the index) or one value per row. Rows with a missing
        label are left out.
    method : str, default "kruskal"
        By class labels: ``"kruskal"`` (Kruskal-Wallis H), ``"anova"`` (one-way ANOVA
        F), ``"fisher"`` (Fisher's discriminant ratio, between- over within-class sum
        of squares; p-value of the F test), ``"auc"`` (one-vs-rest ROC AUC,
        ``max(AUC, 1 - AUC)`` averaged over the classes) or ``"bhattacharyya"``
        (Gaussian Bhattacharyya distance averaged over class pairs). H saturates once
        the classes separate (every such feature at the same ceiling, with a note), the
        AUC at 1 for two classes; ``"fisher"`` and ``"bhattacharyya"`` do not: use
        them for well-separated classes. The default stays ``"kruskal"`` (robust to
        outliers where classes overlap). Or the prognostic metrics of MATLAB's
        Predictive Maintenance Toolbox, ``"monotonicity"``, ``"trendability"``,
        ``"prognosability"`` (see the module notes).
    features : sequence of str, optional
        Columns to rank, overriding the default choice.
    unit : str, optional
        Column telling the run-to-failure units apart; default ``"unit"`` when present,
        else all rows form one unit.
    time : str, optional
        Column ordering each unit's rows; default ``"time"`` or ``"cycle"`` when present,
        else row order. Numbers, or timestamps (datetimes or text such as
        ``2004-02-12 10:32:39``, read as seconds since the earliest).
    window : int, optional
        Prognostic methods: smooth each unit's path with a centred moving mean of
        ``window`` rows first (shrinking at the ends, as MATLAB's ``movmean`` and the
        ``WindowSize`` option of its ``monotonicity`` do). Snapshot indicators are
        noisy: a rising trend under noise has a monotonicity near 0 unless smoothed.
        Default: no smoothing.

    Returns
    -------
    FeatureRanking
        Scores best first; unscorable features (constant, all NaN) last with a note.

    Raises
    ------
    pdmkit.errors.DataError
        Missing labels, fewer than two classes, unknown columns, no numeric features.
    ValueError
        Unknown method.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.features import rank_features
    >>> rng = np.random.default_rng(0)
    >>> y = np.repeat(["ok", "fault"], 50)
    >>> table = pd.DataFrame({"vib/stats/RMS": rng.normal(size=100) + (y == "fault"),
    ...                       "vib/stats/Mean": rng.normal(size=100), "label": y})
    >>> rank_features(table, "label").top(1)
    ['vib/stats/RMS']

    Classes that do not overlap: H is the same for both features, Fisher's ratio grows
    with the gap between the classes over their spread:

    >>> far = pd.DataFrame({"near": np.r_[0:10, 20:30], "far": np.r_[0:10, 90:100],
    ...                     "label": np.repeat([0, 1], 10)})
    >>> rank_features(far, "label").scores.round(2).tolist()
    [14.29, 14.29]
    >>> rank_features(far, "label", method="fisher").scores.round(1).to_dict()
    {'far': 245.5, 'near': 12.1}

    Prognostic metrics from a run-to-failure table:

    >>> life = pd.DataFrame({"unit": np.repeat([1, 2], 20),
    ...                      "time": np.tile(np.arange(20), 2)})
    >>> life["wear"] = life["time"] ** 2 + rng.normal(0, 1, 40)
    >>> round(float(rank_features(life, method="trendability").scores["wear"]), 2)
    1.0
    """
    if method not in METHODS:
        raise DataError(f"method must be one of {list(METHODS)}, got {method!r}")
    if not isinstance(table, pd.DataFrame):
        raise DataError(
            f"table must be a pandas DataFrame of features, got {type(table).__name__}; "
            "wrap an array with pd.DataFrame(x, columns=names)"
        )
    if len(table) == 0:
        raise DataError("the table has 0 rows; nothing to rank")

    if method in CLASS_METHODS:
        return _rank_by_class(table, labels, method, features)
    if labels is not None:
        raise DataError(
            f"method={method!r} ranks run-to-failure paths and takes no labels; pass "
            f"unit= and time= columns (or use a class method, one of {CLASS_METHODS})"
        )
    return _rank_by_lifetime(table, method, features, unit, time, window)


def _rank_by_class(
    table: pd.DataFrame, labels: Any, method: str, features: Sequence[str] | None
) -> FeatureRanking:
    """Ranking of the features by how well they separate the classes of ``labels``."""
    label_values, label_col = _labels(table, labels)
    exclude = {label_col} if label_col is not None else set()
    cols = _feature_columns(table, features, exclude)
    codes, k = _group_codes(label_values)
    if k < 2:
        raise DataError(
            f"labels hold {k} distinct class(es); {method} needs at least two classes"
        )
    X = table[cols].to_numpy(dtype=float)
    scores, pvals, notes = _one_way(X, codes, method)
    return FeatureRanking(
        pd.Series(scores, index=cols),
        method=method,
        p_values=pd.Series(pvals, index=cols),
        notes=dict(zip(cols, notes, strict=True)),
    )


def _rank_by_lifetime(
    table: pd.DataFrame,
    method: str,
    features: Sequence[str] | None,
    unit: str | None,
    time: str | None,
    window: int | None,
) -> FeatureRanking:
    """Prognostic ranking of the features on the units' run-to-failure paths."""
    unit_col = _lifetime_column(table, unit, ("unit",), "unit")
    time_col = _lifetime_column(table, time, ("time", "cycle"), "time")
    exclude = {c for c in (unit_col, time_col) if c is not None}
    cols = _feature_columns(table, features, exclude)
    paths = _unit_paths(table, cols, unit_col, time_col)
    if window is not None:
        if (
            isinstance(window, bool)
            or not isinstance(window, int | np.integer)
            or window < 1
        ):
            raise DataError(f"window must be a positive number of rows, got {window!r}")
        paths = [(life, _moving_mean(x, int(window))) for life, x in paths]
    scores, notes = _prognostic_scores(method, paths, cols)
    for c, s in zip(cols, scores, strict=True):
        if np.isnan(s) and c not in notes:
            values = table[c].to_numpy(dtype=float)
            if not np.isfinite(values).any():
                notes[c] = "all values are NaN or inf"
            elif np.nanmax(values) == np.nanmin(values):
                notes[c] = "constant feature"
            else:
                notes[c] = "undefined for these paths"
    return FeatureRanking(pd.Series(scores, index=cols), method=method, notes=notes)


def _prognostic_scores(
    method: str, paths: list, cols: list[str]
) -> tuple[np.ndarray, dict[str, str]]:
    """Monotonicity, trendability or prognosability of each feature, and why not."""
    n_units = len(paths)
    notes = {}
    if method == "monotonicity":
        finite = all(np.isfinite(x).all() for _, x in paths)
        scores, used = (_monotonicity_fast if finite else _monotonicity)(paths)
        for c, u in zip(cols, used, strict=True):
            if u == 0:
                notes[c] = "no unit has two or more values"
    elif method == "trendability":
        scores = _trendability(paths)
        if n_units < 2:
            notes = {c: "trendability needs at least two units" for c in cols}
    else:
        scores = _prognosability(paths)
        if n_units < 2:  # the spread of one failure value says nothing
            scores = np.full(len(cols), np.nan)
            notes = {c: "prognosability needs at least two units" for c in cols}
    return scores, notes
