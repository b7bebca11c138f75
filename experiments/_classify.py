"""Fault classification from a feature table: selector + model pipelines and their scores.

The workflow follows the seed thesis (sections 2.3.4–2.3.5 and 7.3): rank the condition
indicators (Kruskal-Wallis or one-way ANOVA) or project them with PCA, keep the first
``top_k``, train a classifier (kNN, bagged trees, SVM, ...), and judge it by its
accuracy and confusion matrix on members it has not seen, with cross-validation on the
training part.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, clone
from sklearn.metrics import accuracy_score, confusion_matrix
from sklearn.model_selection import StratifiedKFold, TimeSeriesSplit, train_test_split
from sklearn.pipeline import Pipeline

from pdmkit._checks import parse_timestamps
from pdmkit._progress import progress as bar
from pdmkit.errors import DataError
from pdmkit.experiments._classify_result import (
    ClassificationResult,
    _feature_matrix,
    _plain,
    _show,
)

__all__ = [
    "MODELS",
    "SELECTIONS",
    "SPLITS",
    "ClassificationResult",
    "classify",
    "compare_models",
    "make_classifier",
]

#: Model names accepted by :func:`make_classifier`.
MODELS = ("knn", "bagged_trees", "svm", "random_forest", "lda")
#: Feature-selection methods accepted by :func:`make_classifier` (and ``None``).
SELECTIONS = ("kruskal", "anova", "pca", None)

_KNN_NEIGHBORS = 5


def _sorted_labels(values: Any) -> list:
    unique = list(pd.unique(np.asarray(values, dtype=object)))
    try:
        return sorted(unique)
    except TypeError:
        return sorted(unique, key=str)


def _label_values(y: pd.Series, notes: list[str]) -> np.ndarray:
    """Labels as an array scikit-learn takes as classes (strings when it would not)."""
    from sklearn.utils.multiclass import type_of_target

    values = pd.Series(y.tolist()).to_numpy()  # infer int / float / object per value
    if type_of_target(values) in ("binary", "multiclass"):
        return values
    notes.append(
        f"labels of {y.name!r} are not class-like for scikit-learn "
        f"({type_of_target(values)}); they were compared as strings"
    )
    return np.array([str(v) for v in values], dtype=object)


def _feature_columns(table: pd.DataFrame) -> list[str]:
    """The numeric (not boolean) columns whose name contains '/'."""
    return [
        c
        for c in table.columns
        if "/" in str(c)
        and pd.api.types.is_numeric_dtype(table[c])
        and not pd.api.types.is_bool_dtype(table[c])
    ]


def _check_table(table: Any, label: str) -> pd.Series:
    """Validate the label column; return it (object dtype) indexed by member."""
    if not isinstance(table, pd.DataFrame):
        raise DataError(
            f"the feature table must be a pandas DataFrame (one row per member); "
            f"got {type(table).__name__}"
        )
    if label not in table.columns:
        conditions = [c for c in table.columns if "/" not in str(c)]
        raise DataError(
            f"label column {label!r} is not in the feature table; condition columns "
            f"found: {conditions}. Pass label= one of them."
        )
    if table.index.has_duplicates:
        dup = table.index[table.index.duplicated()].unique()
        raise DataError(
            f"member ids (the table index) must be unique; duplicated: {_show(dup)}. "
            "Reset or rebuild the index."
        )
    y = table[label].astype(object)
    missing = y.isna()
    if missing.any():
        raise DataError(
            f"label {label!r} is missing for members {_show(table.index[missing])}; "
            "fill the label or drop those members"
        )
    counts = y.value_counts()
    if len(counts) < 2:
        raise DataError(
            f"label {label!r} has a single class {_show(counts.index)} "
            f"({len(y)} members); a classifier needs at least 2 classes"
        )
    small = counts[counts < 2]
    if len(small):
        desc = ", ".join(f"{_plain(c)!r} has {n} member" for c, n in small.items())
        raise DataError(
            f"label {label!r}: every class needs at least 2 members to be split into "
            f"training and test parts, but {desc}. Add members of that class, merge it "
            "into another class, or drop it."
        )
    return y


def _check_features(
    table: pd.DataFrame, label: str, features: Sequence[str] | None
) -> list:
    if features is None:
        features = [c for c in _feature_columns(table) if c != label]
        if not features:
            raise DataError(
                "no feature columns found: expected numeric columns named "
                "'<signal>/<group>/<Feature>' or '<group>/<Feature>'; columns found: "
                f"{_show(table.columns)}. Pass features= explicitly."
            )
        return features
    if isinstance(features, str):
        features = [features]
    features = list(dict.fromkeys(features))
    if not features:
        raise DataError("features= is empty; name at least one feature column")
    missing = [f for f in features if f not in table.columns]
    if missing:
        raise DataError(
            f"feature columns {_show(missing)} are not in the table; available feature "
            f"columns: {_show(_feature_columns(table))}"
        )
    if label in features:
        raise DataError(f"the label column {label!r} cannot also be a feature")
    bad = [
        f
        for f in features
        if not pd.api.types.is_numeric_dtype(table[f])
        or pd.api.types.is_bool_dtype(table[f])
    ]
    if bad:
        raise DataError(
            f"feature columns must be numeric; {_show(bad)} are "
            f"{_show([str(table[b].dtype) for b in bad])}"
        )
    return features


def make_classifier(
    model: str | BaseEstimator = "knn",
    *,
    top_k: int = 5,
    selection: str | None = "kruskal",
    max_correlation: float | None = 0.95,
    random_state: int | None = 0,
) -> Pipeline:
    """Build a fault-classifier pipeline: scaler -> feature selector -> model.

    Parameters
    ----------
    model : {"knn", "bagged_trees", "svm", "random_forest", "lda"} or estimator
        ``"knn"``: :class:`~sklearn.neighbors.KNeighborsClassifier` with 5 neighbours
        weighted by distance; ``"bagged_trees"``: 30 bagged decision trees (MATLAB's
        "Bagged Trees" preset, used in the seed's table 7.2); ``"svm"``: RBF-kernel
        :class:`~sklearn.svm.SVC`; ``"random_forest"``: 200 trees; ``"lda"``: linear
        discriminant analysis. An unfitted scikit-learn classifier is used as given
        (cloned).
    top_k : int, default 5
        Number of indicators (or principal components) the selector keeps.
    selection : {"kruskal", "anova", "pca", None}, default "kruskal"
        ``"kruskal"`` / ``"anova"``: :class:`pdmkit.features.SelectTopRanked` keeps
        the ``top_k`` best-ranked indicators; ``"pca"``: the first ``top_k``
        principal components; ``None``: all indicators.
    max_correlation : float or None, default 0.95
        With ``"kruskal"`` / ``"anova"``: skip an indicator correlated above this with
        a better-ranked kept one (Std, RMS and total power carry the same information
        and tie at the top when classes separate well); ``None`` keeps the plain top
        ``top_k``.
    random_state : int or None, default 0
        Seed of the randomised models (bagging, forest, PCA solver).

    Returns
    -------
    sklearn.pipeline.Pipeline
        Steps ``"scale"``, ``"select"`` (absent when ``selection=None``), ``"model"``.

    Examples
    --------
    >>> pipe = make_classifier("bagged_trees", top_k=3, selection="pca")
    >>> [name for name, _ in pipe.steps]
    ['scale', 'select', 'model']
    >>> pipe.named_steps["model"].n_estimators
    30
    >>> make_classifier("tree")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: unknown model 'tree'; choose one of 'knn', 'bagged_trees', 'svm', ...
    """
    from sklearn.preprocessing import StandardScaler

    if isinstance(top_k, bool) or not isinstance(top_k, int | np.integer) or top_k < 1:
        raise ValueError(f"top_k must be a positive integer; got {top_k!r}")
    if selection not in SELECTIONS:
        raise ValueError(
            f"unknown selection {selection!r}; choose one of "
            f"{', '.join(repr(s) for s in SELECTIONS)}"
        )
    estimator = _make_estimator(model, random_state)
    steps: list[tuple[str, Any]] = [("scale", StandardScaler())]
    if selection in ("kruskal", "anova"):
        from pdmkit.features import SelectTopRanked

        selector = SelectTopRanked(
            k=int(top_k), method=selection, max_correlation=max_correlation
        )
        steps.append(("select", selector))
    elif selection == "pca":
        from sklearn.decomposition import PCA

        steps.append(("select", PCA(n_components=int(top_k), random_state=random_state)))
    steps.append(("model", estimator))
    return Pipeline(steps)


def _make_estimator(model: str | BaseEstimator, random_state: int | None) -> BaseEstimator:
    if not isinstance(model, str):
        if hasattr(model, "fit") and hasattr(model, "predict"):
            return clone(model)
        raise ValueError(
            f"model must be one of {', '.join(repr(m) for m in MODELS)} or a scikit-learn "
            f"classifier; got {type(model).__name__}"
        )
    if model == "knn":
        from sklearn.neighbors import KNeighborsClassifier

        return KNeighborsClassifier(n_neighbors=_KNN_NEIGHBORS, weights="distance")
    if model == "bagged_trees":
        from sklearn.ensemble import BaggingClassifier
        from sklearn.tree import DecisionTreeClassifier

        return BaggingClassifier(
            estimator=DecisionTreeClassifier(), n_estimators=30, random_state=random_state
        )
    if model == "svm":
        from sklearn.svm import SVC

        return SVC(kernel="rbf", gamma="scale", C=1.0)
    if model == "random_forest":
        from sklearn.ensemble import RandomForestClassifier

        return RandomForestClassifier(n_estimators=200, random_state=random_state)
    if model == "lda":
        from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

        return LinearDiscriminantAnalysis()
    raise ValueError(
        f"unknown model {model!r}; choose one of {', '.join(repr(m) for m in MODELS)}, "
        "or pass a scikit-learn classifier"
    )


def _model_name(model: str | BaseEstimator) -> str:
    return model if isinstance(model, str) else type(model).__name__


def _fit_to_size(
    pipe: Pipeline, n_features: int, n_fit: int, notes: list[str], top_k: int
) -> Pipeline:
    """Shrink top_k / n_neighbors when the data are too small for them; note it."""
    select = pipe.named_steps.get("select")
    if select is not None:
        from sklearn.decomposition import PCA

        if isinstance(select, PCA):
            k = min(top_k, n_features, n_fit)
            if k < top_k:
                notes.append(
                    f"top_k lowered from {top_k} to {k}: PCA cannot keep more components "
                    f"than features ({n_features}) or fitted members ({n_fit})"
                )
                pipe.set_params(select__n_components=k)
        elif top_k > n_features:
            notes.append(f"top_k={top_k} exceeds the {n_features} features; all are kept")
            pipe.set_params(select__k=n_features)
    model = pipe.named_steps["model"]
    n_neighbors = getattr(model, "n_neighbors", None)
    if isinstance(n_neighbors, int) and n_neighbors > n_fit:
        notes.append(
            f"n_neighbors lowered from {n_neighbors} to {n_fit}: only {n_fit} members "
            "in the smallest training fold"
        )
        pipe.set_params(model__n_neighbors=n_fit)
    return pipe


def _cv_folds(y: pd.Series, cv: int | None, notes: list[str], where: str) -> int:
    """Number of stratified folds actually usable (0: no cross-validation)."""
    if cv is None or cv == 0:
        return 0
    if isinstance(cv, bool) or not isinstance(cv, int | np.integer) or cv < 2:
        raise ValueError(f"cv must be an integer >= 2, or None to skip; got {cv!r}")
    counts = y.value_counts()
    smallest = int(counts.min())
    if smallest < cv:
        cls = _plain(counts.idxmin())
        if smallest < 2:
            notes.append(
                f"no cross-validation: class {cls!r} has a single member in the {where}"
            )
            return 0
        notes.append(
            f"cv lowered from {cv} to {smallest} folds: class {cls!r} has only "
            f"{smallest} members in the {where}"
        )
        return smallest
    return int(cv)


def _smallest_fit_size(y: pd.Series, folds: int) -> int:
    """A lower bound on the members any stratified training fold holds."""
    if not folds:
        return len(y)
    held = sum(math.ceil(n / folds) for n in y.value_counts())
    return max(1, len(y) - held)


def _cv_scores(
    pipe: Pipeline,
    X: np.ndarray,
    y: np.ndarray,
    n_splits: int,
    random_state: int | None,
    *,
    progress: bool | None = None,
    in_time: bool = False,
    notes: list[str] | None = None,
) -> np.ndarray:
    """Accuracy on each fold of a cross-validation split.

    The split is a shuffled stratified k-fold one, or (``in_time``) forward-chaining folds
    over rows in time order (``TimeSeriesSplit``: each fold trains on the rows before the
    ones it tests). A forward fold whose training rows hold a single class is skipped, with
    a note.

    Each fold is ``clone(pipe).fit`` and the accuracy of its predictions, as
    ``cross_val_score(..., scoring="accuracy")`` computes it, with a progress bar
    (``progress``; default only on a terminal).
    """
    if in_time:
        folds = TimeSeriesSplit(n_splits=n_splits)
    else:
        folds = StratifiedKFold(n_splits=n_splits, shuffle=True, random_state=random_state)
    scores, skipped = [], 0
    for train, test in bar(
        folds.split(X, y), desc="cv folds", total=n_splits, enable=progress
    ):
        if in_time and len(np.unique(y[train])) < 2:
            skipped += 1
            continue
        model = clone(pipe).fit(X[train], y[train])
        scores.append(accuracy_score(y[test], model.predict(X[test])))
    if skipped and notes is not None:
        notes.append(
            f"{skipped} of {n_splits} forward cross-validation folds skipped: their "
            "earlier members hold a single class"
        )
    return np.asarray(scores, dtype=float)


#: How the members are split into a training and a test part (:func:`classify`).
SPLITS = ("stratified", "time")


def _order_key(table: pd.DataFrame, order: str | None) -> tuple[np.ndarray, Any]:
    """Sort key of the members in time (numbers, or seconds for timestamps).

    Returned with a function that shows one member's time for messages.
    """
    if order is None:
        return np.arange(len(table), dtype=float), lambda i: f"member {table.index[i]!r}"
    if order not in table.columns:
        conditions = [str(c) for c in table.columns if "/" not in str(c)]
        raise DataError(
            f"order column {order!r} is not in the feature table; condition columns "
            f"found: {conditions}. Pass order= the column that orders members in time"
        )
    column = table[order]
    if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
        key = column.to_numpy(dtype=float)
    else:
        stamps = parse_timestamps(column)
        if stamps.isna().any():
            bad = column[stamps.isna()].iloc[0]
            raise DataError(
                f"order column {order!r} holds {str(bad)!r}, neither a number nor a "
                "timestamp; a time split orders members by numbers or timestamps"
            )
        key = (stamps - stamps.min()).dt.total_seconds().to_numpy(dtype=float)
    if not np.isfinite(key).all():
        bad = table.index[~np.isfinite(key)]
        raise DataError(
            f"order column {order!r} is missing for members {_show(bad)}; every member "
            "needs its time for a time split"
        )
    return key, lambda i: f"{order}={_plain(column.iloc[i])!r}"


def _time_split(
    table: pd.DataFrame,
    y: pd.Series,
    order: str | None,
    test_size: float,
    notes: list[str],
) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the earlier (training) and later (test) members."""
    key, shown = _order_key(table, order)
    ranked = np.argsort(key, kind="stable")
    n = len(ranked)
    n_test = math.ceil(test_size * n)
    train_pos, test_pos = ranked[: n - n_test], ranked[n - n_test :]
    if len(train_pos) == 0:
        raise DataError(
            f"{n} members split in time with test_size={test_size} leave no training "
            "member; lower test_size"
        )
    by = f"by {order!r}" if order is not None else "in the order given"
    notes.append(
        f"time split {by}: trained on the {len(train_pos)} earliest members (up to "
        f"{shown(train_pos[-1])}), tested on the {len(test_pos)} latest (from "
        f"{shown(test_pos[0])})"
    )
    if key[train_pos[-1]] == key[test_pos[0]]:
        notes.append(
            f"members on both sides of the split share the time {shown(test_pos[0])}"
        )
    seen = set(y.iloc[train_pos])
    if len(seen) < 2:
        raise DataError(
            f"the {len(train_pos)} earliest members ({by}) hold only class "
            f"{_show(seen)}; a classifier needs two classes to learn from. Lower "
            "test_size (--test-size) or use the stratified split"
        )
    unseen = _sort_labels(set(y.iloc[test_pos]) - seen)
    if unseen:
        notes.append(
            f"class(es) {_show(unseen)} appear only among the later (test) members: "
            "the classifier never saw them and cannot predict them"
        )
    return train_pos, test_pos


def _sort_labels(values: set) -> list:
    values = [_plain(v) for v in values]
    try:
        return sorted(values)
    except TypeError:
        return sorted(values, key=str)


def _selected_names(pipe: Pipeline, features: list) -> list[str]:
    """Names of what the fitted selector keeps, best first."""
    select = pipe.named_steps.get("select")
    if select is None:
        return [str(f) for f in features]
    if hasattr(select, "components_") and not hasattr(select, "selected_"):
        return [f"PC{i + 1}" for i in range(select.components_.shape[0])]
    idx = np.asarray(select.selected_, dtype=int)
    scores = getattr(select, "scores_", None)
    if scores is not None and np.shape(scores) == (len(features),):
        # order by score, best first (stable: ties keep column order)
        s = np.nan_to_num(np.asarray(scores, dtype=float)[idx], nan=-np.inf)
        idx = idx[np.argsort(-s, kind="stable")]
    return [str(features[i]) for i in idx]


# --------------------------------------------------------------------------- workflow
def classify(
    table: pd.DataFrame,
    label: str,
    *,
    features: Sequence[str] | None = None,
    model: str | BaseEstimator = "knn",
    top_k: int = 5,
    selection: str | None = "kruskal",
    test_size: float = 0.25,
    cv: int | None = 5,
    random_state: int | None = 0,
    split: str = "stratified",
    order: str | None = None,
    progress: bool | None = None,
) -> ClassificationResult:
    """Train a fault classifier on a feature table and score it on held-out members.

    The members are split once, stratified by class, into a training part and a
    held-out test part (``train_test_split(..., stratify=y, test_size=test_size,
    random_state=random_state)``). The pipeline of :func:`make_classifier` is
    cross-validated on the training part (``StratifiedKFold(cv, shuffle=True,
    random_state=random_state)``), then fitted on the whole training part and scored
    on the test part. Feature selection is part of the pipeline, so it only ever
    sees training members.

    With ``split="time"`` the members are ordered by the column ``order`` (numbers or
    timestamps; default: the table's row order) and the earliest ``1 - test_size``
    train, the latest ``test_size`` test: the score of a classifier that meets the
    future, as deployed, where a random split lets neighbours in time (which share
    the machine's state and drift) sit on both sides. The cross-validation then runs
    forward in time (``TimeSeriesSplit(cv)`` on the training part). The notes say
    where the split fell and name the classes seen only after it.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per member (index: member ids); feature columns and the label column.
    label : str
        Condition column holding the class (fault code, string, category).
    features : sequence of str, optional
        Feature columns to use; default: every numeric column whose name contains
        ``"/"``.
    model, top_k, selection
        See :func:`make_classifier`. ``top_k`` is lowered (with a note) when there
        are fewer features.
    test_size : float, default 0.25
        Fraction of members held out, in (0, 1).
    cv : int or None, default 5
        Folds of the cross-validation on the training part; lowered (with a note)
        when the smallest class has fewer training members; ``None`` skips it.
    random_state : int or None, default 0
        Seed of the split, the folds and the randomised models.
    split : {"stratified", "time"}, default "stratified"
        A random split stratified by class, or a time-ordered one (see above).
    order : str, optional
        With ``split="time"``: the column ordering the members in time.
    progress : bool, optional
        A progress bar over the cross-validation folds; default only when stderr is
        a terminal.

    Returns
    -------
    ClassificationResult

    Raises
    ------
    DataError
        The label column is missing or has NaN; fewer than 2 classes; a class with
        a single member; NaN or infinite features (the message names the members and
        columns); too few members for the requested split.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> rng = np.random.default_rng(1)
    >>> y = np.repeat(["normal", "inner", "outer"], 30)
    >>> X = rng.normal(size=(90, 6))
    >>> X[:, 2] += 5 * (y == "inner")
    >>> X[:, 4] += 5 * (y == "outer")
    >>> cols = [f"DE/stats/F{i}" for i in range(6)]
    >>> table = pd.DataFrame(X, columns=cols).assign(fault=y)
    >>> res = classify(table, "fault", model="knn", top_k=2, selection="anova")
    >>> sorted(res.features)
    ['DE/stats/F2', 'DE/stats/F4']
    >>> res.accuracy, res.n_train, res.n_test
    (1.0, 67, 23)

    Trained on the earlier members, tested on the later ones:

    >>> table["hour"] = rng.permutation(90)
    >>> res = classify(table, "fault", top_k=2, split="time", order="hour")
    >>> res.split, res.n_train, res.n_test, res.notes[0][:40]
    ('time', 67, 23, "time split by 'hour': trained on the 67 ")
    """
    notes: list[str] = []
    if split not in SPLITS:
        raise DataError(f"split must be one of {list(SPLITS)}; got {split!r}")
    if order is not None and split != "time":
        raise DataError("order= orders the members for split='time'; pass that too")
    y = _check_table(table, label)
    features = _check_features(table, label, features)
    X = _feature_matrix(table, features)
    _check_test_size(y, test_size, split)
    pipe = make_classifier(
        model, top_k=top_k, selection=selection, random_state=random_state
    )
    y_all = _label_values(y, notes)
    train_pos, test_pos, folds, smallest_fit = _split_members(
        table, y, y_all, split, order, test_size, cv, random_state, notes
    )
    y_train, y_test = y_all[train_pos], y_all[test_pos]
    _fit_to_size(pipe, len(features), smallest_fit, notes, top_k)
    if folds:
        scores = _cv_scores(
            pipe,
            X[train_pos],
            y_train,
            folds,
            random_state,
            progress=progress,
            in_time=split == "time",
            notes=notes,
        )
    else:
        scores = np.array([])
    if len(scores):
        cv_mean, cv_std = float(scores.mean()), float(scores.std())
    else:
        cv_mean, cv_std = math.nan, math.nan
    pipe.fit(X[train_pos], y_train)
    y_pred = pipe.predict(X[test_pos])
    labels = _sorted_labels(y_all)
    cm, recall, precision = _test_scores(y_test, y_pred, labels, notes)
    return ClassificationResult(
        model=_model_name(model),
        label=label,
        labels=labels,
        features=_selected_names(pipe, features),
        input_features=[str(f) for f in features],
        accuracy=float(np.trace(cm) / cm.sum()),
        recall=recall,
        precision=precision,
        confusion=cm,
        n_train=len(train_pos),
        n_test=len(test_pos),
        cv_accuracy=cv_mean,
        cv_accuracy_std=cv_std,
        cv_scores=np.asarray(scores, dtype=float),
        pipeline=pipe,
        selection=selection,
        top_k=top_k,
        test_members=table.index[test_pos],
        y_true=y_test,
        y_pred=np.asarray(y_pred),
        notes=notes,
        split=split,
        order=order,
    )


def _check_test_size(y: pd.Series, test_size: float, split: str) -> None:
    """``test_size`` is a fraction, and a stratified split leaves every class both parts."""
    if not isinstance(test_size, float | np.floating) or not 0.0 < test_size < 1.0:
        raise ValueError(f"test_size must be a float in (0, 1); got {test_size!r}")
    n = len(y)
    n_classes = y.nunique()
    n_test = math.ceil(test_size * n)
    n_train = n - n_test
    if split == "stratified" and (n_test < n_classes or n_train < n_classes):
        raise DataError(
            f"{n} members split with test_size={test_size} give {n_train} training and "
            f"{n_test} test members, but each part needs at least one member of each of "
            f"the {n_classes} classes; change test_size or add members"
        )


def _split_members(table, y, y_all, split, order, test_size, cv, random_state, notes):
    """(training positions, test positions, CV folds, smallest training fold)."""
    if split == "time":
        train_pos, test_pos = _time_split(table, y, order, test_size, notes)
        folds = _forward_folds(len(train_pos), cv)
        smallest_fit = len(train_pos) // (folds + 1) + len(train_pos) % (folds + 1)
    else:
        train_pos, test_pos = train_test_split(
            np.arange(len(y)),
            test_size=test_size,
            stratify=y_all,
            random_state=random_state,
        )
        folds = _cv_folds(y.iloc[train_pos], cv, notes, "training part")
        smallest_fit = _smallest_fit_size(y.iloc[train_pos], folds)
    return train_pos, test_pos, folds, smallest_fit


def _test_scores(y_test, y_pred, labels: list, notes: list[str]):
    """(confusion matrix, recall per class, precision per class) on the test part."""
    cm = confusion_matrix(y_test, y_pred, labels=labels)
    predicted = cm.sum(axis=0)
    support = cm.sum(axis=1)
    recall = {
        c: (cm[i, i] / support[i] if support[i] else math.nan) for i, c in enumerate(labels)
    }
    absent = [c for i, c in enumerate(labels) if not support[i]]
    if absent:  # a time split can leave a class out of the later members
        notes.append(
            f"class(es) {_show(absent)} have no member in the test part: their recall "
            "is undefined (NaN)"
        )
    precision = {
        c: (cm[i, i] / predicted[i] if predicted[i] else math.nan)
        for i, c in enumerate(labels)
    }
    return (
        cm,
        {c: float(v) for c, v in recall.items()},
        {c: float(v) for c, v in precision.items()},
    )


def _forward_folds(n_train: int, cv: int | None) -> int:
    """Forward-chaining folds of a time split (0: none); each needs rows to train on."""
    if cv is None or cv == 0:
        return 0
    if isinstance(cv, bool) or not isinstance(cv, int | np.integer) or cv < 2:
        raise ValueError(f"cv must be an integer >= 2, or None to skip; got {cv!r}")
    return int(min(cv, n_train - 1)) if n_train > 2 else 0


def compare_models(
    table: pd.DataFrame,
    label: str,
    models: Sequence[str | BaseEstimator] = MODELS,
    **kwargs: Any,
) -> pd.DataFrame:
    """Score several models on the same split and folds.

    Parameters
    ----------
    table, label
        As for :func:`classify`.
    models : sequence, default all of :data:`MODELS`
        Model names (or scikit-learn classifiers).
    **kwargs
        Passed to :func:`classify` (``features``, ``top_k``, ``selection``,
        ``test_size``, ``cv``, ``random_state``).

    Returns
    -------
    pandas.DataFrame
        One row per model: ``model``, ``accuracy`` (held-out), ``cv_accuracy``,
        ``cv_accuracy_std``, ``n_train``, ``n_test``, ``features`` (selected, joined
        with ``"; "``), ``note``; in the order given.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> rng = np.random.default_rng(2)
    >>> y = np.repeat(["ok", "fault"], 25)
    >>> table = pd.DataFrame({"p/stats/Mean": rng.normal(size=50) + 6 * (y == "fault"),
    ...                       "p/stats/Std": rng.normal(size=50), "state": y})
    >>> df = compare_models(table, "state", models=("knn", "lda"), top_k=1)
    >>> df[["model", "accuracy"]].to_dict("records")
    [{'model': 'knn', 'accuracy': 1.0}, {'model': 'lda', 'accuracy': 1.0}]
    """
    if "model" in kwargs:
        raise TypeError("compare_models takes models=(...), not model=")
    if isinstance(models, str):
        models = (models,)
    if not models:
        raise ValueError("models is empty; name at least one model")
    rows: list[dict[Hashable, Any]] = []
    for model in models:
        res = classify(table, label, model=model, **kwargs)
        rows.append(
            {
                "model": res.model,
                "accuracy": res.accuracy,
                "cv_accuracy": res.cv_accuracy,
                "cv_accuracy_std": res.cv_accuracy_std,
                "n_train": res.n_train,
                "n_test": res.n_test,
                "features": "; ".join(res.features),
                "note": "; ".join(res.notes),
            }
        )
    return pd.DataFrame(rows)
