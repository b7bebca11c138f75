"""How stable a class-separation ranking is across cross-validation folds.

A ranking computed once on all rows hides how much it owes to the particular rows:
:func:`ranking_stability` ranks the features again on the training part of each fold
(:class:`sklearn.model_selection.StratifiedKFold`, or
:class:`~sklearn.model_selection.StratifiedGroupKFold` when ``groups`` say which rows
belong together, e.g. the frames of one recording) and reports per feature its mean rank
across the folds, the spread of that rank and how often it is among the ``k`` best, and
for the whole ranking the mean Spearman and Kendall correlation between the folds'
rankings.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd
import scipy.stats
from numpy.typing import ArrayLike

from pdmkit.errors import DataError
from pdmkit.features._ranking import (
    _AXIS_LABELS,
    CLASS_METHODS,
    _feature_columns,
    _labels,
    rank_features,
)

__all__ = ["RankingStability", "ranking_stability"]


class RankingStability:
    """A class-separation ranking repeated on cross-validation folds.

    Parameters
    ----------
    scores : pandas.DataFrame
        Feature (rows) x fold (columns): the score on each fold's training rows.
    method : str
        The ranking method (one of :data:`pdmkit.features.CLASS_METHODS`).
    k : int
        The size of the "top k" counted in :meth:`to_pandas`.
    splitter : str, optional
        How the folds were drawn (for the record).

    Attributes
    ----------
    scores : pandas.DataFrame
        As given.
    ranks : pandas.DataFrame
        Rank of each feature in each fold, 1 = best; ties share their mean rank,
        unscored (NaN) features come last.
    spearman, kendall : float
        Mean Spearman rho and Kendall tau-b between the rank vectors of all pairs of
        folds (NaN when no pair has spread); 1 = the same order in every fold.
    n_splits : int
        The number of folds (columns of ``scores``).
    method, k, splitter

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.features import RankingStability
    >>> scores = pd.DataFrame({"fold1": [3.0, 2.0, 1.0], "fold2": [3.0, 1.0, 2.0]},
    ...                       index=["a", "b", "c"])
    >>> s = RankingStability(scores, method="fisher", k=1)
    >>> s.to_pandas()[["feature", "mean_rank", "rank_std", "in_top_k"]]
      feature  mean_rank  rank_std  in_top_k
    0       a        1.0       0.0       1.0
    1       b        2.5       0.5       0.0
    2       c        2.5       0.5       0.0
    >>> round(s.spearman, 2)
    0.5
    """

    def __init__(
        self, scores: pd.DataFrame, *, method: str, k: int, splitter: str = ""
    ) -> None:
        self.scores = pd.DataFrame(scores, dtype=float)
        self.scores.index = self.scores.index.map(str)
        self.method = method
        self.k = int(k)
        self.splitter = splitter
        self.n_splits = self.scores.shape[1]
        values = self.scores.to_numpy()
        # best = 1; NaN (unscored) behind every score
        worst_first = np.where(np.isnan(values), -np.inf, values)
        ranks = scipy.stats.rankdata(-worst_first, axis=0)
        top = scipy.stats.rankdata(-worst_first, axis=0, method="min") <= self.k
        self.ranks = pd.DataFrame(
            ranks, index=self.scores.index, columns=self.scores.columns
        )
        self._in_top = (top & ~np.isnan(values)).mean(axis=1)
        self.spearman, self.kendall = _mean_correlations(ranks)

    @property
    def features(self) -> list[str]:
        """The features, most stably best first (by mean rank, then mean score).

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.features import RankingStability
        >>> RankingStability(pd.DataFrame({"f1": [1.0, 2.0]}, index=["x", "y"]),
        ...                  method="auc", k=1).features
        ['y', 'x']
        """
        return self.to_pandas()["feature"].tolist()

    def __len__(self) -> int:
        return len(self.scores)

    def __repr__(self) -> str:
        return (
            f"RankingStability(method={self.method!r}, {self.scores.shape[1]} folds, "
            f"{len(self)} features; mean Spearman {self.spearman:.3f})"
        )

    def to_pandas(self) -> pd.DataFrame:
        """Table ``feature, mean_rank, rank_std, in_top_k, mean_score, score_std``.

        ``mean_rank`` and ``rank_std`` (``ddof = 0``) are over the folds (1 = best);
        ``in_top_k`` is the share of folds (0 to 1) in which the feature is among the
        ``k`` best (features tied at the border all count); ``mean_score`` and
        ``score_std`` (``ddof = 0``) are those of the scores over the folds that scored
        the feature (``score_std`` is NaN for infinite scores). Best mean rank first.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.features import RankingStability
        >>> s = RankingStability(pd.DataFrame({"f1": [1.0, 2.0], "f2": [1.0, 4.0]},
        ...                                   index=["x", "y"]), method="fisher", k=1)
        >>> s.to_pandas()
          feature  mean_rank  rank_std  in_top_k  mean_score  score_std
        0       y        1.0       0.0       1.0         3.0        1.0
        1       x        2.0       0.0       0.0         1.0        0.0
        """
        values = self.scores.to_numpy()
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN or infinite rows
            mean_score = np.nanmean(values, axis=1)
            score_std = np.nanstd(values, axis=1)
        table = pd.DataFrame(
            {
                "feature": self.scores.index,
                "mean_rank": self.ranks.mean(axis=1).to_numpy(),
                "rank_std": self.ranks.std(axis=1, ddof=0).to_numpy(),
                "in_top_k": np.asarray(self._in_top, dtype=float),
                "mean_score": mean_score,
                "score_std": score_std,
            }
        )
        table = table.sort_values(
            ["mean_rank", "mean_score"], ascending=[True, False], kind="stable"
        )
        return table.reset_index(drop=True)

    def plot(self, ax=None, k: int = 20):
        """Mean rank across the folds with its spread, for the ``k`` best features.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw; a new figure when omitted.
        k : int, default 20
            How many features to show (best mean rank at the top).

        Returns
        -------
        matplotlib.axes.Axes

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.features import RankingStability
        >>> s = RankingStability(pd.DataFrame({"f1": [1.0, 2.0]}, index=["x", "y"]),
        ...                      method="fisher", k=1)
        >>> [t.get_text() for t in s.plot().get_yticklabels()]
        ['x', 'y']
        """
        import matplotlib.pyplot as plt

        table = self.to_pandas().head(k).iloc[::-1]  # best at the top
        if ax is None:
            _, ax = plt.subplots(figsize=(7, 1.0 + 0.3 * max(len(table), 1)))
        y = np.arange(len(table))
        ax.errorbar(
            table["mean_rank"], y, xerr=table["rank_std"], fmt="o", color="C0", capsize=3
        )
        ax.set_yticks(y, labels=table["feature"].tolist())
        ax.set_xlabel("rank across the folds (1 = best; bar: one standard deviation)")
        ax.set_title(
            f"Ranking stability: {_AXIS_LABELS.get(self.method, self.method)}, "
            f"{self.scores.shape[1]} folds, mean Spearman {self.spearman:.2f}"
        )
        return ax


def _mean_correlations(ranks: np.ndarray) -> tuple[float, float]:
    """Mean Spearman rho and Kendall tau-b over all pairs of columns of ``ranks``."""
    rho, tau = [], []
    for i, j in combinations(range(ranks.shape[1]), 2):
        a, b = ranks[:, i], ranks[:, j]
        if np.ptp(a) == 0 or np.ptp(b) == 0:
            continue  # no order to compare
        rho.append(scipy.stats.spearmanr(a, b).statistic)
        tau.append(scipy.stats.kendalltau(a, b).statistic)
    if not rho:
        return float("nan"), float("nan")
    return float(np.mean(rho)), float(np.mean(tau))


def _groups(table: pd.DataFrame, groups: Any) -> tuple[np.ndarray, str | None]:
    """The group of each row: a column name, an aligned Series or one value per row."""
    if isinstance(groups, str):
        if groups not in table.columns:
            raise DataError(
                f"groups={groups!r} is not a column of the table; columns without '/': "
                f"{[c for c in table.columns if '/' not in str(c)]}"
            )
        return table[groups].to_numpy(), groups
    if isinstance(groups, pd.Series) and set(table.index) <= set(groups.index):
        name = groups.name if groups.name in table.columns else None
        return groups.reindex(table.index).to_numpy(), name
    values = np.asarray(groups)
    if values.ndim != 1 or len(values) != len(table):
        raise DataError(
            f"groups has {values.shape} entries; expected one per table row ({len(table)})"
        )
    return values, None


def _folds(y: np.ndarray, groups: np.ndarray | None, n_splits: int, random_state):
    """The training indices of each fold, and the splitter's description."""
    from sklearn.model_selection import StratifiedGroupKFold, StratifiedKFold

    smallest = int(pd.Series(y).value_counts().min())
    if groups is None:
        if smallest < n_splits:
            raise DataError(
                f"the smallest class has {smallest} row(s), fewer than n_splits="
                f"{n_splits}; lower n_splits"
            )
        cv = StratifiedKFold(n_splits, shuffle=True, random_state=random_state)
        split = cv.split(np.zeros(len(y)), y)
    else:
        n_groups = pd.Series(groups).nunique()
        if n_groups < n_splits:
            raise DataError(
                f"groups hold {n_groups} distinct group(s), fewer than n_splits="
                f"{n_splits}; lower n_splits (a group never spans two folds)"
            )
        cv = StratifiedGroupKFold(n_splits, shuffle=True, random_state=random_state)
        split = cv.split(np.zeros(len(y)), y, groups)
    return [train for train, _ in split], f"{type(cv).__name__}({n_splits})"


def _check_int(value: Any, name: str, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
        raise DataError(f"{name} must be an integer of at least {least}, got {value!r}")
    return int(value)


def ranking_stability(
    table: pd.DataFrame,
    labels: pd.Series | ArrayLike | str,
    *,
    method: str = "fisher",
    features: Sequence[str] | None = None,
    groups: pd.Series | ArrayLike | str | None = None,
    n_splits: int = 5,
    k: int = 10,
    random_state: int | None = 0,
) -> RankingStability:
    """Rank the features on the training rows of each fold and compare the rankings.

    Parameters
    ----------
    table : pandas.DataFrame
        Feature table, one row per member, as for :func:`rank_features`.
    labels : str or array_like
        The class of each row: a column name, a Series (aligned on the index) or one
        value per row. Rows with a missing label are left out.
    method : str, default "fisher"
        A class method of :func:`rank_features` (:data:`CLASS_METHODS`). Fisher's ratio
        by default: Kruskal-Wallis H ties every feature that separates the classes in a
        fold, which makes the ranks of those features arbitrary ties.
    features : sequence of str, optional
        Columns to rank (default: as :func:`rank_features` chooses them, without the
        label and group columns).
    groups : str or array_like, optional
        Rows that belong together (the frames of one recording): a column name, a
        Series or one value per row. They stay on one side of every split
        (:class:`~sklearn.model_selection.StratifiedGroupKFold`); without them the rows
        are split by :class:`~sklearn.model_selection.StratifiedKFold`.
    n_splits : int, default 5
        Number of folds (at least 2); each ranking uses the other ``n_splits - 1``.
    k : int, default 10
        Size of the "top k" whose membership is counted.
    random_state : int or None, default 0
        Seed of the shuffled split.

    Returns
    -------
    RankingStability
        Per-fold scores and ranks; ``to_pandas()`` gives the mean rank, its spread and
        the share of folds in the top ``k`` per feature, ``spearman`` and ``kendall``
        the agreement between the folds.

    Raises
    ------
    pdmkit.errors.DataError
        Unknown method, a class smaller than ``n_splits`` (or fewer groups than
        ``n_splits``), a training fold with a single class, bad columns.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.features import ranking_stability
    >>> rng = np.random.default_rng(0)
    >>> y = np.repeat(["ok", "worn"], 40)
    >>> table = pd.DataFrame({"vib/stats/RMS": rng.normal(size=80) + 3 * (y == "worn"),
    ...                       "vib/stats/Mean": rng.normal(size=80),
    ...                       "vib/stats/Skewness": rng.normal(size=80), "label": y})
    >>> s = ranking_stability(table, "label", n_splits=4, k=1)
    >>> s.to_pandas()[["feature", "mean_rank", "in_top_k"]].head(1)
             feature  mean_rank  in_top_k
    0  vib/stats/RMS        1.0       1.0
    >>> round(s.spearman, 2)  # the two noise features swap places between folds
    0.67

    Frames of one recording kept together:

    >>> table["recording"] = np.repeat(np.arange(8), 10)
    >>> ranking_stability(table, "label", groups="recording", n_splits=4).splitter
    'StratifiedGroupKFold(4)'
    """
    if method not in CLASS_METHODS:
        raise DataError(f"method must be one of {list(CLASS_METHODS)}, got {method!r}")
    n_splits = _check_int(n_splits, "n_splits", 2)
    k = _check_int(k, "k", 1)
    if not isinstance(table, pd.DataFrame):
        raise DataError(f"table must be a pandas DataFrame, got {type(table).__name__}")
    y, label_col = _labels(table, labels)
    g, group_col = (None, None) if groups is None else _groups(table, groups)
    cols = _feature_columns(table, features, {label_col, group_col} - {None})
    keep = ~pd.isna(y) if g is None else ~(pd.isna(y) | pd.isna(g))
    rows, y = table[cols][keep], y[keep]
    g = None if g is None else g[keep]
    if pd.Series(y).nunique() < 2:
        raise DataError("labels hold fewer than two classes; nothing to separate")
    trains, splitter = _folds(y, g, n_splits, random_state)
    scores = {}
    for i, train in enumerate(trains, start=1):
        if pd.Series(y[train]).nunique() < 2:
            raise DataError(
                f"fold {i} trains on a single class (the groups hold one class each); "
                "use fewer folds or groups that mix the classes"
            )
        ranking = rank_features(rows.iloc[train], y[train], method=method, features=cols)
        scores[f"fold{i}"] = ranking.scores.reindex([str(c) for c in cols])
    return RankingStability(pd.DataFrame(scores), method=method, k=k, splitter=splitter)
