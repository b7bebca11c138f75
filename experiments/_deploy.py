"""A fault classifier to deploy: the fitted pipeline, its inputs by name, its recipe.

``pdmkit classify`` writes one to ``OUT/model.pdmkit`` (:func:`pdmkit.save_model`:
nothing in the file runs code when loaded); ``pdmkit predict`` loads it, computes the
same indicators from new recordings with the recipe it holds, and scores them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.experiments._classify_result import _feature_matrix, _plain, _show

__all__ = ["OOD_FLAG", "FaultClassifier", "vote_by_group"]

#: An out-of-distribution score above this flags a member: farther from every training
#: member (in the classifier's own scaled, selected indicators) than twice the 99th
#: percentile of the training members' distances to their nearest neighbour.
OOD_FLAG = 2.0
#: Training rows kept as the out-of-distribution reference (a random subset beyond).
MAX_REFERENCE_ROWS = 2000


class FaultClassifier:
    """A trained fault classifier that scores new members by feature *name*.

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        Fitted on the training members (scaling, selection, model).
    feature_names : sequence of str
        The indicator columns the pipeline takes, in its order; a table is matched
        to them by name, never by position.
    label : str
        The condition the classifier predicts.
    recipe : dict, optional
        How the indicators were computed from recordings (signals, groups, options,
        rate, framing), so ``pdmkit predict`` computes the same from new files; empty
        for a classifier trained on a feature table.
    evaluation : dict, optional
        How it was judged (the split and the held-out accuracy), kept for the record.

    Attributes
    ----------
    classes_ : list
        The classes, in the order of :meth:`predict_proba`'s columns.
    reference_ : numpy.ndarray
        Training members in the pipeline's space before the model (at most
        :data:`MAX_REFERENCE_ROWS`): the out-of-distribution reference.
    reference_scale_ : float
        99th percentile of their leave-one-out nearest-neighbour distances.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.experiments import classify
    >>> rng = np.random.default_rng(0)
    >>> y = np.repeat(["ok", "worn"], 40)
    >>> table = pd.DataFrame({"v/stats/RMS": rng.normal(size=80) + 4 * (y == "worn"),
    ...                       "v/stats/Mean": rng.normal(size=80), "state": y})
    >>> res = classify(table, "state", selection=None, model="lda")
    >>> clf = FaultClassifier.from_result(res, table)
    >>> new = pd.DataFrame({"v/stats/Mean": [0.0, 0.1, 0.0],
    ...                     "v/stats/RMS": [0.0, 4.2, 60.0]})
    >>> out = clf.predict_table(new)
    >>> out["predicted"].tolist(), out["out_of_distribution"].tolist()
    (['ok', 'worn', 'worn'], [False, False, True])
    """

    def __init__(
        self,
        pipeline: Any = None,
        feature_names: Sequence[str] = (),
        label: str = "label",
        recipe: Mapping[str, Any] | None = None,
        evaluation: Mapping[str, Any] | None = None,
    ) -> None:
        self.pipeline = pipeline
        self.feature_names = list(feature_names)
        self.label = label
        self.recipe = dict(recipe or {})
        self.evaluation = dict(evaluation or {})

    @classmethod
    def from_result(
        cls,
        result: Any,
        table: pd.DataFrame,
        recipe: Mapping[str, Any] | None = None,
        random_state: int = 0,
    ) -> FaultClassifier:
        """The deployable form of a :class:`ClassificationResult` and its table.

        The out-of-distribution reference is taken from ``table``'s training members
        (``result.train_members``).
        """
        summary = result.summary()
        evaluation = {
            k: summary.get(k) for k in ("split", "accuracy", "cv_accuracy", "n_train")
        }
        clf = cls(result.pipeline, result.input_features, result.label, recipe, evaluation)
        train = table.loc[result.train_members]
        clf._fit_reference(_feature_matrix(train, clf.feature_names), random_state)
        return clf

    def _fit_reference(self, X: np.ndarray, random_state: int) -> None:
        from scipy.spatial import cKDTree

        self.classes_ = [_plain(c) for c in self.pipeline.classes_]
        Z = self._embed(X)
        if len(Z) > MAX_REFERENCE_ROWS:
            rng = np.random.default_rng(random_state)
            Z = Z[np.sort(rng.choice(len(Z), MAX_REFERENCE_ROWS, replace=False))]
        self.reference_ = Z
        d, _ = cKDTree(Z).query(Z, k=min(2, len(Z)))
        nearest = d[:, -1] if d.ndim == 2 else d
        scale = float(np.quantile(nearest, 0.99)) if len(nearest) else 0.0
        self.reference_scale_ = scale if scale > 0 else 1.0

    def _embed(self, X: np.ndarray) -> np.ndarray:
        """``X`` through the pipeline's steps before the model."""
        return np.asarray(self.pipeline[:-1].transform(X), dtype=float)

    def _matrix(self, table: pd.DataFrame) -> np.ndarray:
        """The feature columns by name; a missing one is a one-line error."""
        if not isinstance(table, pd.DataFrame):
            raise DataError(f"expected a feature table (DataFrame); got {type(table)}")
        missing = [f for f in self.feature_names if f not in table.columns]
        if missing:
            raise DataError(
                f"the table lacks {len(missing)} of the {len(self.feature_names)} "
                f"indicator columns this classifier was trained on: {_show(missing)}; "
                "compute them with the same signals, groups and options (pdmkit "
                "predict --members does so from the model's recipe)"
            )
        return _feature_matrix(table, self.feature_names)

    def predict(self, table: pd.DataFrame) -> pd.Series:
        """The predicted class of each member (columns matched by name).

        Examples
        --------
        See :class:`FaultClassifier`.
        """
        y = self.pipeline.predict(self._matrix(table))
        return pd.Series([_plain(v) for v in y], index=table.index, name=self.label)

    def predict_proba(self, table: pd.DataFrame) -> pd.DataFrame:
        """Class probabilities, one column per class of :attr:`classes_`.

        Examples
        --------
        See :class:`FaultClassifier`.
        """
        P = self.pipeline.predict_proba(self._matrix(table))
        return pd.DataFrame(P, index=table.index, columns=self.classes_)

    def ood_score(self, table: pd.DataFrame) -> np.ndarray:
        """Distance to the nearest training member over :attr:`reference_scale_`.

        About 1 or less for members like the training ones; above :data:`OOD_FLAG`
        the prediction is extrapolation (a fault, load or machine not trained on).

        Examples
        --------
        See :class:`FaultClassifier`.
        """
        from scipy.spatial import cKDTree

        Z = self._embed(self._matrix(table))
        d, _ = cKDTree(self.reference_).query(Z, k=1)
        return np.asarray(d, dtype=float) / self.reference_scale_

    def predict_table(self, table: pd.DataFrame) -> pd.DataFrame:
        """Per member: the class, its probabilities and the out-of-distribution score.

        Columns ``predicted``, ``p_<class>`` (one per class), ``ood_score`` and
        ``out_of_distribution`` (above :data:`OOD_FLAG`).

        Examples
        --------
        See :class:`FaultClassifier`.
        """
        X = self._matrix(table)
        out = pd.DataFrame(index=table.index)
        out["predicted"] = [_plain(v) for v in self.pipeline.predict(X)]
        if hasattr(self.pipeline, "predict_proba"):
            P = self.pipeline.predict_proba(X)
            for j, c in enumerate(self.classes_):
                out[f"p_{c}"] = P[:, j]
        out["ood_score"] = self.ood_score(table)
        out["out_of_distribution"] = out["ood_score"] > OOD_FLAG
        return out


def vote_by_group(members: pd.DataFrame, groups: pd.Series) -> pd.DataFrame:
    """Per recording: the majority class of its members, its share, the mean probabilities.

    Parameters
    ----------
    members : pandas.DataFrame
        :meth:`FaultClassifier.predict_table` of the members.
    groups : pandas.Series
        Each member's recording (aligned with ``members``).

    Returns
    -------
    pandas.DataFrame
        One row per recording: ``members``, ``predicted`` (majority), ``agreement``
        (share of members voting for it), the mean ``p_<class>``, the largest
        ``ood_score`` and ``out_of_distribution`` (any member flagged).

    Examples
    --------
    >>> m = pd.DataFrame({"predicted": ["a", "a", "b"], "ood_score": [0.5, 0.7, 3.0],
    ...                   "out_of_distribution": [False, False, True]})
    >>> v = vote_by_group(m, pd.Series(["r1", "r1", "r2"]))
    >>> v[["recording", "predicted", "agreement", "out_of_distribution"]].values.tolist()
    [['r1', 'a', 1.0, False], ['r2', 'b', 1.0, True]]
    """
    rows = []
    keyed = members.assign(_g=np.asarray(groups, dtype=object))
    for g, part in keyed.groupby("_g", sort=True):
        counts = part["predicted"].value_counts()
        row = {
            "recording": str(g),
            "members": len(part),
            "predicted": counts.index[0],
            "agreement": float(counts.iloc[0] / len(part)),
        }
        for c in (c for c in part.columns if str(c).startswith("p_")):
            row[c] = float(part[c].mean())
        row["ood_score"] = float(part["ood_score"].max())
        row["out_of_distribution"] = bool(part["out_of_distribution"].any())
        rows.append(row)
    return pd.DataFrame(rows)
