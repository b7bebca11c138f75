"""Keeping the top-ranked indicators inside a scikit-learn pipeline."""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator
from sklearn.feature_selection import SelectorMixin
from sklearn.utils.validation import check_is_fitted

from pdmkit.errors import DataError
from pdmkit.features._ranking import (
    CLASS_METHODS,
    FeatureRanking,
    _group_codes,
    _one_way,
)

__all__ = ["SelectTopRanked"]


# --------------------------------------------------------------------------- sklearn
def _validate(estimator, X, y):
    """scikit-learn's input validation (``validate_data`` from 1.6 on)."""
    try:
        from sklearn.utils.validation import validate_data
    except ImportError:  # pragma: no cover - scikit-learn < 1.6
        if y is None:
            raise DataError(
                f"{type(estimator).__name__} requires y to be passed, "
                "but the target y is None"
            ) from None
        return estimator._validate_data(X, y)
    return validate_data(estimator, X, y)


def _least_redundant(X: np.ndarray, ranked: list[int], k: int, limit: float) -> list[int]:
    """Walk the ranking, keeping columns not correlated above ``limit`` with kept ones.

    When fewer than ``k`` columns pass, the best skipped ones fill the remaining places.
    """
    std = X.std(axis=0)
    z = np.divide(X - X.mean(axis=0), std, out=np.zeros_like(X), where=std > 0)
    kept: list[int] = []
    skipped: list[int] = []
    for j in ranked:
        if len(kept) == k:
            break
        if kept and np.max(np.abs(z[:, kept].T @ z[:, j])) / len(X) > limit:
            skipped.append(j)
        else:
            kept.append(j)
    return kept + skipped[: k - len(kept)]


class SelectTopRanked(SelectorMixin, BaseEstimator):
    """Keep the ``k`` columns that best separate the classes (scikit-learn selector).

    Ranks the columns of ``X`` against the class labels ``y`` with Kruskal-Wallis H or
    one-way ANOVA F (as :func:`rank_features`) and keeps the ``k`` best; columns that
    cannot be scored (constant) rank last. Use it in a Pipeline before a classifier.

    Parameters
    ----------
    k : int, default 5
        Number of columns to keep (all of them when ``X`` has fewer).
    method : {"kruskal", "anova", "fisher", "auc", "bhattacharyya"}, default "kruskal"
        Ranking statistic (see :func:`rank_features`). Kruskal-Wallis H and ROC AUC
        saturate once classes separate, and the ``k`` kept among the tied columns are
        then an accident of their order; ``"fisher"`` keeps telling them apart.
    max_correlation : float or None, default None
        Skip a column whose absolute Pearson correlation with an already kept,
        better-ranked column exceeds this value (e.g. 0.95). Rank statistics saturate
        when classes separate perfectly, so Std, RMS and total power tie at the top;
        without this filter the ``k`` kept columns can carry one piece of information
        ``k`` times. ``None`` keeps the plain top ``k``.

    Attributes
    ----------
    ranking_ : FeatureRanking
        The full ranking (names from ``feature_names_in_``, else ``x0, x1, ...``).
    scores_ : ndarray of shape (n_features_in_,)
        Score of each input column (NaN where undefined).
    pvalues_ : ndarray of shape (n_features_in_,)
        Its p-value.
    selected_ : ndarray of int
        Indices of the kept columns, ascending (the order ``transform`` returns them in).
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        Only when ``X`` had string column names.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn.neighbors import KNeighborsClassifier
    >>> from pdmkit.features import SelectTopRanked
    >>> rng = np.random.default_rng(0)
    >>> y = np.repeat([0, 1], 40)
    >>> X = rng.normal(size=(80, 6))
    >>> X[:, 4] += 3 * y
    >>> sel = SelectTopRanked(k=1).fit(X, y)
    >>> sel.selected_, sel.get_feature_names_out()
    (array([4]), array(['x4'], dtype=object))
    >>> pipe = make_pipeline(SelectTopRanked(k=2), KNeighborsClassifier()).fit(X, y)
    >>> pipe.score(X, y) > 0.9
    True
    """

    def __init__(
        self, k: int = 5, method: str = "kruskal", max_correlation: float | None = None
    ) -> None:
        self.k = k
        self.method = method
        self.max_correlation = max_correlation

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        return tags

    def _more_tags(self):  # scikit-learn < 1.6
        return {"requires_y": True}

    def fit(self, X, y):
        """Rank the columns of ``X`` against the labels ``y``; keep the best ``k``.

        Parameters
        ----------
        X : array_like of shape (n_samples, n_features)
        y : array_like of shape (n_samples,)
            Class labels.

        Returns
        -------
        self

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.features import SelectTopRanked
        >>> X = np.array([[0.0, 1.0], [0.1, 5.0], [1.0, 1.1], [1.1, 5.2]])
        >>> SelectTopRanked(k=1, method="anova").fit(X, [0, 0, 1, 1]).selected_
        array([0])
        """
        k = self.k
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
            raise DataError(f"k must be a positive integer, got {k!r}")
        limit = self.max_correlation
        if limit is not None and not (isinstance(limit, int | float) and 0 < limit <= 1):
            raise DataError(f"max_correlation must be in (0, 1] or None, got {limit!r}")
        if self.method not in CLASS_METHODS:
            raise DataError(
                f"method must be one of {list(CLASS_METHODS)} for SelectTopRanked, got "
                f"{self.method!r} (the prognostic metrics need units and time: use "
                "rank_features)"
            )
        X, y = _validate(self, X, y)
        X = np.asarray(X, dtype=float)
        codes, n_classes = _group_codes(np.asarray(y))
        if n_classes < 2:
            raise DataError(
                f"y has {n_classes} class; SelectTopRanked needs at least two classes "
                "to rank the features"
            )
        scores, pvals, notes = _one_way(X, codes, self.method)
        names = (
            [str(c) for c in self.feature_names_in_]
            if hasattr(self, "feature_names_in_")
            else [f"x{i}" for i in range(X.shape[1])]
        )
        self.scores_ = scores
        self.pvalues_ = pvals
        self.ranking_ = FeatureRanking(
            pd.Series(scores, index=names),
            method=self.method,
            p_values=pd.Series(pvals, index=names),
            notes=dict(zip(names, notes, strict=True)),
        )
        position = {name: i for i, name in enumerate(names)}
        ranked = [position[f] for f in self.ranking_.features]
        if limit is None:
            best = ranked[: min(int(k), X.shape[1])]
        else:
            best = _least_redundant(X, ranked, int(k), float(limit))
        self.selected_ = np.sort(np.asarray(best, dtype=np.intp))
        return self

    def _get_support_mask(self):
        check_is_fitted(self, "selected_")
        mask = np.zeros(self.n_features_in_, dtype=bool)
        mask[self.selected_] = True
        return mask
