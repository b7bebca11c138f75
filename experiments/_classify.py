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
from sklearn.model_selection import TimeSeriesSplit
from sklearn.pipeline import Pipeline

from pdmkit._progress import progress as bar
from pdmkit.errors import DataError
from pdmkit.experiments._classify_result import (
    ClassificationResult,
    _feature_matrix,
    _plain,
    _show,
)
from pdmkit.experiments._classify_splits import SPLITS, cv_folds, plan_split

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
SELECTIONS = ("fisher", "kruskal", "anova", "bhattacharyya", "pca", None)

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
    selection: str | None = "fisher",
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
    selection : str or None, default "fisher"
        ``"fisher"``, ``"kruskal"``, ``"anova"``, ``"bhattacharyya"``: a ranking
        (:func:`pdmkit.features.rank_features`); :class:`~pdmkit.features.SelectTopRanked`
        keeps the ``top_k`` best-ranked indicators. ``"pca"``: the first ``top_k``
        principal components; ``None``: all indicators. The Fisher ratio is the
        default because Kruskal-Wallis H saturates once classes separate: the
        indicators kept among the tied ones are then an accident of their order (on
        CWRU, trained on the 0.007" faults, that choice put 0 of 59 IR_021 frames
        in the inner-race class; the Fisher ratio's choice, 59 of 59).
    max_correlation : float or None, default 0.95
        With a ranking: skip an indicator correlated above this with
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
    if selection not in ("pca", None):
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
    groups: np.ndarray | None = None,
    notes: list[str] | None = None,
) -> np.ndarray:
    """Accuracy on each fold of a cross-validation split.

    The split is a shuffled stratified k-fold one; with ``groups``, a grouped one
    (:func:`~pdmkit.experiments._classify_splits.cv_folds`: a group never on both sides
    of a fold); with ``in_time``, forward-chaining folds over rows in time order
    (``TimeSeriesSplit``: each fold trains on the rows before the ones it tests). A
    fold whose training rows hold a single class is skipped, with a note.

    Each fold is ``clone(pipe).fit`` and the accuracy of its predictions, as
    ``cross_val_score(..., scoring="accuracy")`` computes it, with a progress bar
    (``progress``; default only on a terminal).
    """
    if in_time:
        splits = list(TimeSeriesSplit(n_splits=n_splits).split(X, y))
    else:
        splits = cv_folds(X, y, n_splits, random_state, groups)
    scores, skipped = [], 0
    for train, test in bar(splits, desc="cv folds", total=len(splits), enable=progress):
        if len(np.unique(y[train])) < 2:
            skipped += 1
            continue
        model = clone(pipe).fit(X[train], y[train])
        scores.append(accuracy_score(y[test], model.predict(X[test])))
    if skipped and notes is not None:
        notes.append(
            f"{skipped} of {len(splits)} cross-validation folds skipped: their "
            "training members hold a single class"
        )
    return np.asarray(scores, dtype=float)


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
    selection: str | None = "fisher",
    test_size: float = 0.25,
    cv: int | None = 5,
    random_state: int | None = 0,
    split: str = "auto",
    order: str | None = None,
    group: str | None = None,
    gap: int = 1,
    test_where: str | None = None,
    test: pd.DataFrame | None = None,
    progress: bool | None = None,
) -> ClassificationResult:
    """Train a fault classifier on a feature table and score it on held-out members.

    Frames of one recording, repeats of one setting, cycles of one unit are one
    *group* (the column ``group``; a framed ensemble's ``source_member`` by default)
    and stay on one side of every split: the held-out part holds whole groups, class
    by class (``split="group"``, the default when there are groups). A class recorded
    in a single group cannot be held out whole; its members are split in time
    (earliest train, latest test, ``gap`` members dropped between), and a note says
    so. Without groups each member is its own recording and the split is random,
    stratified by class. ``split="random"`` splits members at random even when they
    share groups: what that measures (recognising recordings already seen) is the
    first note and the JSON's ``split.measures``. See
    :mod:`pdmkit.experiments._classify_splits`.

    The pipeline of :func:`make_classifier` (scaling, ranking and selection, model)
    is cross-validated on the training part (grouped folds when there are groups),
    then fitted on the whole training part and scored on the test part: scaling and
    selection only ever see training members.

    ``test_where`` (a query on the table's columns, e.g. ``"size == 21"``) or
    ``test`` (another feature table) choose the test members instead: a transfer
    test to another fault size, load, session or machine.

    With ``split="time"`` the members are ordered by the column ``order`` (numbers or
    timestamps; default: the table's row order) and the earliest ``1 - test_size``
    train, the latest ``test_size`` test; the cross-validation then runs forward in
    time (``TimeSeriesSplit(cv)``).

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
        Fraction of members (of each class's groups) held out, in (0, 1).
    cv : int or None, default 5
        Folds of the cross-validation on the training part; lowered (with a note)
        when the smallest class has fewer training members; ``None`` skips it.
    random_state : int or None, default 0
        Seed of the split, the folds and the randomised models.
    split : {"auto", "group", "random", "stratified", "time"}, default "auto"
        ``"auto"``: ``"group"`` when the members have groups, else ``"random"``;
        ``"stratified"`` is ``"random"`` (stratified by class).
    order : str, optional
        With ``split="time"``: the column ordering the members in time.
    group : str, optional
        The column naming each member's recording / session / unit (default
        ``source_member`` when present).
    gap : int, default 1
        Members dropped between the training and test block of a class recorded
        once (at least the frames that overlap, when frames overlap).
    test_where : str, optional
        A :meth:`pandas.DataFrame.eval` expression selecting the test members.
    test : pandas.DataFrame, optional
        A second feature table to test on (the same feature columns, by name).
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
    >>> res.accuracy, res.n_train, res.n_test, res.split
    (1.0, 67, 23, 'random')

    Frames of recordings: whole recordings held out, class by class:

    >>> table["source_member"] = [f"{c}_{i // 10}" for c, i in zip(y, range(90))]
    >>> res = classify(table, "fault", top_k=2, selection="anova")
    >>> res.split_info["kind"], res.split_info["groups_on_both_sides"], res.n_test
    ('group', 0, 30)

    Trained on the earlier members, tested on the later ones:

    >>> table["hour"] = rng.permutation(90)
    >>> res = classify(table, "fault", top_k=2, split="time", order="hour")
    >>> res.split, res.n_train, res.n_test, res.notes[0][:40]
    ('time', 67, 23, "time split by 'hour': trained on the 67 ")
    """
    notes: list[str] = []
    if order is not None and split != "time":
        raise DataError("order= orders the members for split='time'; pass that too")
    if test is not None and test_where is not None:
        raise DataError("give test= (another table) or test_where= (a query), not both")
    y = _check_table(table, label)
    features = _check_features(table, label, features)
    test_mask = None
    if test is not None:
        table, test_mask = _with_test_table(table, test, label, features)
        y = table[label].astype(object)
    X = _feature_matrix(table, features)
    pipe = make_classifier(
        model, top_k=top_k, selection=selection, random_state=random_state
    )
    y_all = _label_values(y, notes)
    plan = plan_split(
        table,
        y,
        y_all,
        split=split,
        group=group,
        order=order,
        test_size=test_size,
        gap=gap,
        test_where=test_where,
        test_mask=test_mask,
        cv=cv,
        random_state=random_state,
        notes=notes,
    )
    train_pos, test_pos = plan.train_pos, plan.test_pos
    cvk = {"random_state": random_state, "progress": progress}
    if len(set(y.iloc[train_pos])) < 2:
        raise DataError(
            f"the training members hold only class {_show(set(y.iloc[train_pos]))}; a "
            "classifier needs two classes to learn from"
        )
    y_train, y_test = y_all[train_pos], y_all[test_pos]
    scores = _training_cv(pipe, X, y, y_all, plan, cv, len(features), top_k, notes, **cvk)
    cv_mean, cv_std = (
        (float(scores.mean()), float(scores.std())) if len(scores) else (math.nan,) * 2
    )
    pipe.fit(X[train_pos], y_train)
    y_pred = pipe.predict(X[test_pos])
    labels = _sorted_labels(y_all)
    cm, recall, precision = _test_scores(y_test, y_pred, labels, notes)
    by = plan.info.get("by") if plan.info["kind"] != "time" else None
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
        train_members=table.index[train_pos],
        y_true=y_test,
        y_pred=np.asarray(y_pred),
        notes=notes,
        split=plan.info["kind"],
        order=order,
        split_info=plan.info,
        test_groups=(
            None if by is None else table[by].iloc[test_pos].astype(str).to_numpy()
        ),
    )


def _training_cv(pipe, X, y, y_all, plan, cv, n_features, top_k, notes, **kwargs):
    """Cross-validation scores on the training part (``pipe`` sized to its folds)."""
    train_pos = plan.train_pos
    in_time = plan.info["kind"] == "time"
    if in_time:
        folds = _forward_folds(len(train_pos), cv)
        smallest_fit = len(train_pos) // (folds + 1) + len(train_pos) % (folds + 1)
    else:
        folds = _cv_folds(y.iloc[train_pos], cv, notes, "training part")
        smallest_fit = _smallest_fit_size(y.iloc[train_pos], folds)
    _fit_to_size(pipe, n_features, smallest_fit, notes, top_k)
    if not folds:
        return np.array([])
    return _cv_scores(
        pipe,
        X[train_pos],
        y_all[train_pos],
        folds,
        kwargs["random_state"],
        progress=kwargs["progress"],
        in_time=in_time,
        groups=plan.cv_groups,
        notes=notes,
    )


def _with_test_table(
    table: pd.DataFrame, test: pd.DataFrame, label: str, features: list
) -> tuple[pd.DataFrame, np.ndarray]:
    """``table`` with ``test``'s rows appended (features by name), and their mask."""
    if not isinstance(test, pd.DataFrame):
        raise DataError(f"test must be a feature table (DataFrame); got {type(test)}")
    missing = [f for f in features if f not in test.columns]
    if missing:
        raise DataError(
            f"the test table lacks feature columns {_show(missing)} of the training "
            "table; extract the same indicators for both"
        )
    if label not in test.columns or test[label].isna().any():
        raise DataError(
            f"the test table needs the label column {label!r} on every member, to be "
            "scored against"
        )
    conditions = [c for c in table.columns if c not in features and c in test.columns]
    test = test[list(features) + conditions]
    if test.index.isin(table.index).any():  # member ids unique over both tables
        test = test.set_axis([f"test:{m}" for m in test.index], axis=0)
    mask = np.r_[np.zeros(len(table), dtype=bool), np.ones(len(test), dtype=bool)]
    return pd.concat([table, test]), mask


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
