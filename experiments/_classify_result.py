"""The result of a classification run, and the feature-matrix checks it shares with it.

:class:`ClassificationResult` holds the scores, the per-class table and the confusion
matrix plot of :func:`classify`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from sklearn.pipeline import Pipeline

from pdmkit._outputs import to_jsonable
from pdmkit.errors import DataError

__all__ = ["ClassificationResult"]


# --------------------------------------------------------------------------- helpers
def _show(items: Sequence[Any], limit: int = 8) -> str:
    """Return a short printable list: the first ``limit`` items and how many more."""
    items = list(items)
    head = ", ".join(repr(_plain(i)) for i in items[:limit])
    more = f" and {len(items) - limit} more" if len(items) > limit else ""
    return f"[{head}]{more}"


def _plain(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


def _sorted_plain(values) -> list:
    """Class labels as plain Python values, sorted (by their text when types mix)."""
    values = [_plain(v) for v in values]
    try:
        return sorted(values)
    except TypeError:
        return sorted(values, key=str)


def _feature_matrix(table: pd.DataFrame, features: list) -> np.ndarray:
    """Return the float matrix; DataError naming members and columns when not finite."""
    X = table[features].to_numpy(dtype=float)
    bad = ~np.isfinite(X)
    if not bad.any():
        return X
    rows = np.flatnonzero(bad.any(axis=1))
    cols = np.flatnonzero(bad.any(axis=0))
    hint = (
        "Drop those members, drop those columns, or fix the feature extraction; "
        "classifiers need finite features."
    )
    # a signal whose features are all NaN for a member: that member lacks the signal
    signals: dict[str, list[int]] = {}
    for j, name in enumerate(features):
        if str(name).count("/") >= 2:
            signals.setdefault(str(name).split("/")[0], []).append(j)
    absent = sorted(
        s for s, js in signals.items() if np.isnan(X[np.ix_(rows, js)]).all(axis=1).any()
    )
    if absent:
        hint = (
            f"Signal(s) {_show(absent)} are missing altogether for some of these members "
            "(all their features NaN): leave those signals out (features= without their "
            "columns, or compare_sensors to score each sensor on the members that have "
            "it), or drop those members. Otherwise fix the feature extraction; "
            "classifiers need finite features."
        )
    raise DataError(
        f"features are NaN or infinite for {len(rows)} member(s) "
        f"{_show(table.index[rows])} in column(s) "
        f"{_show([features[c] for c in cols])}. {hint}"
    )


# --------------------------------------------------------------------------- result
@dataclass(repr=False)
class ClassificationResult:
    """A trained fault classifier and its scores on held-out members.

    Attributes
    ----------
    model : str
        Model name (``"knn"``, ...) or the estimator's class name.
    label : str
        The condition column that was predicted.
    labels : list
        Class labels in sorted order (rows and columns of ``confusion``).
    features : list of str
        What the selector kept, best first (``"PC1"``, ... for PCA).
    input_features : list of str
        The feature columns the pipeline was given (and :meth:`predict` needs).
    accuracy : float
        Fraction of held-out members classified correctly.
    recall, precision : dict
        Per class, on the held-out members (precision NaN when never predicted).
    confusion : numpy.ndarray
        Held-out counts, rows the true class, columns the predicted class.
    n_train, n_test : int
        Members used for training and for the held-out test.
    cv_accuracy, cv_accuracy_std : float
        Mean and standard deviation of the accuracy over the stratified folds of the
        training part (NaN when cross-validation was skipped).
    cv_scores : numpy.ndarray
        Accuracy of each fold.
    pipeline : sklearn.pipeline.Pipeline
        Fitted on the training part.
    test_members : pandas.Index
        Member ids of the held-out part; ``y_true`` / ``y_pred`` align with it.
    train_members : pandas.Index
        Member ids the pipeline was fitted on (members dropped as a gap are in
        neither).
    notes : list of str
        What was adjusted on the way (fewer folds, smaller ``top_k``, ...).
    split : str
        The kind of split made: ``"group"``, ``"random"``, ``"time"``, ``"where"``
        or ``"table"`` (see :func:`classify`).
    split_info : dict
        What the JSON's ``split`` holds: ``kind``, ``by``, group counts, ``measures``.
    test_groups : numpy.ndarray or None
        The group (recording) of each held-out member, when members have groups.
    order : str or None
        The column that ordered the members of a time split (None: their order).

    Examples
    --------
    >>> from pdmkit.experiments import classify
    >>> import numpy as np, pandas as pd
    >>> rng = np.random.default_rng(0)
    >>> y = np.repeat(["healthy", "worn"], 20)
    >>> table = pd.DataFrame({"v/stats/RMS": rng.normal(size=40) + 4 * (y == "worn"),
    ...                       "v/stats/Mean": rng.normal(size=40), "state": y})
    >>> res = classify(table, "state", model="lda", selection=None, cv=4)
    >>> res.accuracy, res.n_test, res.labels
    (1.0, 10, ['healthy', 'worn'])
    >>> res.confusion.tolist()
    [[5, 0], [0, 5]]
    """

    model: str
    label: str
    labels: list
    features: list[str]
    input_features: list[str]
    accuracy: float
    recall: dict
    precision: dict
    confusion: np.ndarray
    n_train: int
    n_test: int
    cv_accuracy: float
    cv_accuracy_std: float
    cv_scores: np.ndarray
    pipeline: Pipeline
    selection: str | None = None
    top_k: int | None = None
    test_members: pd.Index = field(default_factory=lambda: pd.Index([]))
    train_members: pd.Index = field(default_factory=lambda: pd.Index([]))
    y_true: np.ndarray = field(default_factory=lambda: np.array([], dtype=object))
    y_pred: np.ndarray = field(default_factory=lambda: np.array([], dtype=object))
    notes: list[str] = field(default_factory=list)
    split: str = "random"
    order: str | None = None
    split_info: dict = field(default_factory=dict)
    test_groups: np.ndarray | None = None

    def __repr__(self) -> str:
        cv = (
            f", cv_accuracy={self.cv_accuracy:.4f}±{self.cv_accuracy_std:.4f}"
            if math.isfinite(self.cv_accuracy)
            else ""
        )
        return (
            f"ClassificationResult(model={self.model!r}, accuracy={self.accuracy:.4f}{cv}, "
            f"n_train={self.n_train}, n_test={self.n_test}, features={self.features})"
        )

    def to_pandas(self) -> pd.DataFrame:
        """Per-class table on the held-out members.

        Returns
        -------
        pandas.DataFrame
            Index: class label; columns ``n_test`` (members of that class held out),
            ``correct``, ``recall``, ``precision``, ``predicted`` (members predicted as
            that class).

        Examples
        --------
        >>> from pdmkit.experiments import classify
        >>> import numpy as np, pandas as pd
        >>> y = np.repeat(["a", "b"], 8)
        >>> t = pd.DataFrame({"s/F": np.r_[np.zeros(8), np.ones(8)] + np.arange(16) / 100,
        ...                   "c": y})
        >>> classify(t, "c", selection=None, model="lda", cv=None).to_pandas()["recall"]
        c
        a    1.0
        b    1.0
        Name: recall, dtype: float64
        """
        cm = self.confusion
        frame = pd.DataFrame(
            {
                "n_test": cm.sum(axis=1),
                "correct": np.diag(cm),
                "recall": [self.recall[c] for c in self.labels],
                "precision": [self.precision[c] for c in self.labels],
                "predicted": cm.sum(axis=0),
            },
            index=pd.Index(self.labels, name=self.label),
        )
        return frame

    def confusion_to_pandas(self) -> pd.DataFrame:
        """The confusion matrix as a labelled table (rows true, columns predicted).

        Examples
        --------
        >>> from pdmkit.experiments import classify
        >>> import numpy as np, pandas as pd
        >>> t = pd.DataFrame({"s/F": np.arange(8.0), "c": list("aaaabbbb")})
        >>> res = classify(t, "c", selection=None, model="lda", cv=None)
        >>> cm = res.confusion_to_pandas()
        >>> int(cm.loc["a", "a"]), int(cm.loc["a", "b"]), cm.index.name, cm.columns.name
        (1, 0, 'true', 'predicted')
        """
        return pd.DataFrame(
            self.confusion,
            index=pd.Index(self.labels, name="true"),
            columns=pd.Index(self.labels, name="predicted"),
        )

    def summary(self) -> dict:
        """Plain-JSON summary (NaN written as ``None``).

        Returns
        -------
        dict
            Keys ``accuracy``, ``model``, ``features``, ``labels``, ``confusion``
            (rows true, columns predicted), ``n_train``, ``n_test``, ``cv_accuracy``,
            ``cv_accuracy_std``, ``cv_folds``, ``recall`` (class -> recall),
            ``label``, ``selection``, ``top_k``, ``n_input_features``, ``split``
            (:attr:`split_info`: ``kind``, ``by``, ``measures``, ...), ``order``
            (the time column of a time split), ``groups`` (per held-out group: its
            class, members, accuracy and most predicted class; absent without
            groups), ``notes`` (a time split's first note says where it fell).

        Examples
        --------
        >>> from pdmkit.experiments import classify
        >>> import json, numpy as np, pandas as pd
        >>> t = pd.DataFrame({"s/F": np.arange(8.0), "c": list("aaaabbbb")})
        >>> s = classify(t, "c", selection=None, model="lda", cv=None).summary()
        >>> s["accuracy"], s["confusion"], s["cv_accuracy"]
        (1.0, [[1, 0], [0, 1]], None)
        >>> _ = json.dumps(s)
        """
        return to_jsonable(
            {
                "model": self.model,
                "label": self.label,
                "accuracy": float(self.accuracy),
                "cv_accuracy": float(self.cv_accuracy),
                "cv_accuracy_std": float(self.cv_accuracy_std),
                "cv_folds": len(self.cv_scores),
                "n_train": int(self.n_train),
                "n_test": int(self.n_test),
                "selection": self.selection,
                "top_k": self.top_k,
                "features": list(self.features),
                "n_input_features": len(self.input_features),
                "labels": [_plain(c) for c in self.labels],
                "confusion": self.confusion.tolist(),
                "recall": {str(_plain(c)): float(self.recall[c]) for c in self.labels},
                "split": dict(self.split_info) or {"kind": self.split},
                "order": self.order,
                **(
                    {"groups": self.group_scores().to_dict("records")}
                    if self.test_groups is not None
                    else {}
                ),
                "notes": list(self.notes),
            }
        )

    def group_scores(self) -> pd.DataFrame:
        """Accuracy per held-out group (recording): the breakdown behind the number.

        Returns
        -------
        pandas.DataFrame
            One row per held-out group: ``group``, ``true`` (its class; the most
            common one when it holds several), ``members``, ``accuracy``,
            ``predicted`` (the class most of its members were given); worst first.

        Examples
        --------
        >>> from pdmkit.experiments import classify
        >>> import numpy as np, pandas as pd
        >>> y = np.repeat(["a", "b"], 20)
        >>> t = pd.DataFrame({"s/F": np.r_[np.arange(20.0), 30 + np.arange(20.0)],
        ...                   "c": y, "rec": [f"{c}{i // 5}" for i, c in enumerate(y)]})
        >>> res = classify(t, "c", selection=None, model="lda", cv=None, group="rec")
        >>> res.group_scores()[["group", "members", "accuracy"]].values.tolist()
        [['a3', 5, 1.0], ['b6', 5, 1.0]]
        """
        if self.test_groups is None:
            raise ValueError("the members had no groups; see classify(group=...)")
        df = pd.DataFrame(
            {
                "group": self.test_groups,
                "true": [_plain(v) for v in self.y_true],
                "predicted": [_plain(v) for v in self.y_pred],
            }
        )
        rows = []
        for g, part in df.groupby("group", sort=True):
            rows.append(
                {
                    "group": str(g),
                    "true": part["true"].mode().iloc[0],
                    "members": len(part),
                    "accuracy": float((part["true"] == part["predicted"]).mean()),
                    "predicted": part["predicted"].mode().iloc[0],
                }
            )
        out = pd.DataFrame(
            rows, columns=["group", "true", "members", "accuracy", "predicted"]
        )
        return out.sort_values(["accuracy", "group"], kind="stable").reset_index(drop=True)

    def predict(self, table: pd.DataFrame) -> pd.Series:
        """Predict the class of each member of a feature table.

        Parameters
        ----------
        table : pandas.DataFrame
            Must hold the columns in :attr:`input_features`, finite.

        Returns
        -------
        pandas.Series
            Predicted labels, indexed like ``table``.

        Examples
        --------
        >>> from pdmkit.experiments import classify
        >>> import numpy as np, pandas as pd
        >>> t = pd.DataFrame({"s/F": np.arange(8.0), "c": list("aaaabbbb")})
        >>> res = classify(t, "c", selection=None, model="lda", cv=None)
        >>> res.predict(pd.DataFrame({"s/F": [0.5, 7.5]}, index=["m1", "m2"])).tolist()
        ['a', 'b']
        """
        missing = [f for f in self.input_features if f not in table.columns]
        if missing:
            raise DataError(
                f"the table lacks feature columns {_show(missing)} that this classifier "
                "was trained on; extract the same indicators first"
            )
        X = _feature_matrix(table, list(self.input_features))
        return pd.Series(self.pipeline.predict(X), index=table.index, name=self.label)

    def plot(self, ax: Any = None, *, normalize: bool = False, cmap: str = "Blues") -> Any:
        """Draw the confusion matrix as a heatmap with the counts written in.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; a new figure when omitted.
        normalize : bool, default False
            Colour by the fraction of each true class (recall per row); the cells still
            show the counts.
        cmap : str, default "Blues"

        Returns
        -------
        matplotlib.axes.Axes

        Examples
        --------
        >>> from pdmkit.experiments import classify
        >>> import matplotlib
        >>> matplotlib.use("Agg")
        >>> import numpy as np, pandas as pd
        >>> t = pd.DataFrame({"s/F": np.arange(8.0), "c": list("aaaabbbb")})
        >>> ax = classify(t, "c", selection=None, model="lda", cv=None).plot()
        >>> ax.get_xlabel(), ax.get_ylabel()
        ('predicted class', 'true class')
        """
        import matplotlib.pyplot as plt

        cm = np.asarray(self.confusion)
        n = len(self.labels)
        if ax is None:
            size = max(3.5, 0.6 * n + 2.0)
            _, ax = plt.subplots(figsize=(size + 0.8, size))
        rows = cm.sum(axis=1, keepdims=True)
        shade = (
            np.divide(cm, rows, out=np.zeros(cm.shape), where=rows > 0) if normalize else cm
        )
        image = ax.imshow(shade, cmap=cmap, vmin=0, interpolation="nearest")
        ax.figure.colorbar(
            image,
            ax=ax,
            fraction=0.046,
            pad=0.04,
            label="fraction of true class" if normalize else "members",
        )
        top = float(shade.max()) if shade.size else 0.0
        for i in range(n):
            for j in range(n):
                colour = "white" if top > 0 and shade[i, j] > 0.5 * top else "black"
                ax.text(j, i, str(int(cm[i, j])), ha="center", va="center", color=colour)
        names = [str(c) for c in self.labels]
        # tilted when the names would run into each other (a cell is about 9 letters)
        tilt = n > 3 or max(map(len, names), default=0) > 9
        ax.set_xticks(
            range(n), names, rotation=45 if tilt else 0, ha="right" if tilt else "center"
        )
        ax.set_yticks(range(n), names)
        ax.set_xlabel("predicted class")
        ax.set_ylabel("true class")
        ax.set_title(
            f"{self.model}: accuracy {self.accuracy:.1%} on {self.n_test} held-out members"
        )
        return ax
