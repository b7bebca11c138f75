"""Fault classification on synthetic feature tables with known separability."""

from __future__ import annotations

import json

import matplotlib
import numpy as np
import pandas as pd
import pytest
from scipy import stats
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.decomposition import PCA
from sklearn.ensemble import BaggingClassifier
from sklearn.feature_selection import SelectKBest
from sklearn.metrics import recall_score
from sklearn.model_selection import StratifiedKFold, cross_val_score, train_test_split
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.tree import DecisionTreeClassifier

import pdmkit.features
from pdmkit.errors import DataError
from pdmkit.experiments._classify import (
    MODELS,
    classify,
    compare_models,
    make_classifier,
)

matplotlib.use("Agg")


class _StandInSelectTopRanked(BaseEstimator, TransformerMixin):
    """Kruskal/ANOVA top-k selector, used only while pdmkit.features lacks the real one."""

    def __init__(self, k=5, method="kruskal"):
        self.k = k
        self.method = method

    def fit(self, X, y):
        X = np.asarray(X, dtype=float)
        y = np.asarray(y)
        groups = [X[y == c] for c in np.unique(y)]
        test = stats.kruskal if self.method == "kruskal" else stats.f_oneway
        self.scores_ = np.array(
            [test(*[g[:, j] for g in groups]).statistic for j in range(X.shape[1])]
        )
        order = np.argsort(-self.scores_, kind="stable")
        self.selected_ = np.sort(order[: self.k])  # column order: the caller must rank
        self.n_features_in_ = X.shape[1]
        return self

    def transform(self, X):
        return np.asarray(X, dtype=float)[:, self.selected_]


@pytest.fixture(autouse=True)
def _selector(monkeypatch):
    if not hasattr(pdmkit.features, "SelectTopRanked"):
        monkeypatch.setattr(
            pdmkit.features, "SelectTopRanked", _StandInSelectTopRanked, raising=False
        )


def _kruskal_scores(X, y):
    groups = [X[y == c] for c in np.unique(y)]
    h = np.array(
        [stats.kruskal(*[g[:, j] for g in groups]).statistic for j in range(X.shape[1])]
    )
    return h, np.zeros_like(h)


def _table(rng, n_per_class=40, n_features=20, informative=(7, 13), shift=6.0, classes=3):
    """Classes 'c0'.. : class i>0 shifts informative feature i-1 by ``shift`` sigma."""
    labels = np.repeat([f"c{i}" for i in range(classes)], n_per_class)
    X = rng.normal(size=(len(labels), n_features))
    for i, col in enumerate(informative):
        X[:, col] += shift * (labels == f"c{i + 1}")
    cols = [f"S{j % 2}/stats/F{j:02d}" for j in range(n_features)]
    table = pd.DataFrame(X, columns=cols, index=[f"m{i}" for i in range(len(labels))])
    table["fault"] = labels
    table["load"] = "0hp"  # a condition column beside the features
    return table, [cols[j] for j in informative]


def test_informative_features_are_selected_and_classified(rng):
    table, informative = _table(rng)
    res = classify(table, "fault", model="knn", top_k=5, selection="kruskal")
    assert set(informative) <= set(res.features)
    assert len(res.features) == 5
    # the two shifted features carry the largest Kruskal-Wallis H on the training part
    assert set(res.features[:2]) == set(informative)
    assert res.accuracy >= 0.95
    assert res.cv_accuracy >= 0.95
    assert res.input_features == [c for c in table.columns if "/" in c]


def test_selected_features_are_in_rank_order(rng):
    table, informative = _table(rng, shift=4.0)
    # make feature F07 the strongest by a large margin: shift it for two classes
    table[informative[0]] += 10.0 * (table["fault"] == "c2")
    res = classify(table, "fault", top_k=3, selection="kruskal")
    train = table.drop(index=res.test_members)
    h = {
        c: stats.kruskal(*[g[c].to_numpy() for _, g in train.groupby("fault")]).statistic
        for c in res.features
    }
    assert list(res.features) == sorted(h, key=h.get, reverse=True)


def test_pure_noise_is_near_chance(rng):
    labels = np.repeat(["a", "b", "c", "d"], 100)
    X = rng.normal(size=(len(labels), 12))
    table = pd.DataFrame(X, columns=[f"N/stats/F{j}" for j in range(12)]).assign(y=labels)
    res = classify(table, "y", model="knn", top_k=4, test_size=0.5, random_state=3)
    lo, hi = stats.binom.interval(0.9999, res.n_test, 0.25)
    assert lo / res.n_test <= res.accuracy <= hi / res.n_test
    n_cv = res.n_train  # every training member is scored once across the folds
    lo, hi = stats.binom.interval(0.9999, n_cv, 0.25)
    assert lo / n_cv <= res.cv_accuracy <= hi / n_cv


def test_confusion_matrix_is_consistent(rng):
    table, _ = _table(rng, shift=1.0)  # overlapping classes: some errors
    res = classify(table, "fault", model="svm", top_k=4, selection="anova", random_state=5)
    cm = res.confusion
    assert cm.shape == (3, 3)
    assert res.labels == ["c0", "c1", "c2"]
    assert cm.sum() == res.n_test
    assert np.trace(cm) / res.n_test == pytest.approx(res.accuracy)
    # rows are the true classes of the held-out members, taken from the table itself
    truth = table.loc[res.test_members, "fault"]
    assert list(cm.sum(axis=1)) == [int((truth == c).sum()) for c in res.labels]
    # columns are the predictions: check recall against sklearn on the same predictions
    expected = recall_score(res.y_true, res.y_pred, labels=res.labels, average=None)
    assert [res.recall[c] for c in res.labels] == pytest.approx(expected)
    assert res.n_train + res.n_test == len(table)
    assert res.n_test == int(np.ceil(0.25 * len(table)))
    assert list(res.to_pandas()["n_test"]) == list(cm.sum(axis=1))
    # predictions of the fitted pipeline reproduce the held-out predictions
    assert list(res.predict(table.loc[res.test_members])) == list(res.y_pred)


def test_cv_matches_hand_built_pipeline(rng):
    table, _ = _table(rng, shift=1.5)
    cols = [c for c in table.columns if "/" in c]
    X, y = table[cols].to_numpy(), table["fault"].to_numpy()
    seed = 7
    Xtr, Xte, ytr, yte = train_test_split(
        X, y, test_size=0.25, stratify=y, random_state=seed
    )
    folds = StratifiedKFold(n_splits=5, shuffle=True, random_state=seed)
    hand = {
        ("knn", "pca"): Pipeline(
            [
                ("s", StandardScaler()),
                ("p", PCA(n_components=3, random_state=seed)),
                ("m", KNeighborsClassifier(n_neighbors=5, weights="distance")),
            ]
        ),
        ("bagged_trees", None): Pipeline(
            [
                ("s", StandardScaler()),
                (
                    "m",
                    BaggingClassifier(
                        estimator=DecisionTreeClassifier(),
                        n_estimators=30,
                        random_state=seed,
                    ),
                ),
            ]
        ),
        ("knn", "kruskal"): Pipeline(
            [
                ("s", StandardScaler()),
                ("k", SelectKBest(_kruskal_scores, k=3)),
                ("m", KNeighborsClassifier(n_neighbors=5, weights="distance")),
            ]
        ),
    }
    for (model, selection), pipe in hand.items():
        scores = cross_val_score(pipe, Xtr, ytr, cv=folds, scoring="accuracy")
        res = classify(
            table, "fault", model=model, selection=selection, top_k=3, random_state=seed
        )
        assert res.cv_accuracy == pytest.approx(scores.mean(), abs=1e-12), (
            model,
            selection,
        )
        assert res.cv_accuracy_std == pytest.approx(scores.std(), abs=1e-12)
        assert res.accuracy == pytest.approx(pipe.fit(Xtr, ytr).score(Xte, yte), abs=1e-12)


def test_pca_selection_reports_components(rng):
    table, _ = _table(rng)
    res = classify(table, "fault", model="lda", selection="pca", top_k=4)
    assert res.features == ["PC1", "PC2", "PC3", "PC4"]
    res = classify(table, "fault", model="lda", selection=None)
    assert res.features == res.input_features


def test_summary_is_plain_json(rng):
    table, informative = _table(rng)
    table["fault"] = table["fault"].map(
        {"c0": 0, "c1": 11, "c2": 12}
    )  # numeric fault codes
    s = classify(table, "fault", top_k=2).summary()
    assert {
        "accuracy",
        "model",
        "features",
        "labels",
        "confusion",
        "n_train",
        "n_test",
    } <= set(s)
    assert {"cv_accuracy", "cv_accuracy_std", "recall"} <= set(s)
    assert s["labels"] == [0, 11, 12]
    assert set(s["features"]) == set(informative)
    assert sum(map(sum, s["confusion"])) == s["n_test"]
    json.dumps(s, allow_nan=False)


def test_cv_is_reduced_for_small_classes(rng):
    table, _ = _table(rng, n_per_class=4)  # 3 training members per class
    res = classify(table, "fault", top_k=2, cv=5)
    assert len(res.cv_scores) == 3
    assert any("cv lowered from 5 to 3" in n for n in res.notes)
    # 2 training members per class: 2 folds of 3 members, fewer than 5 neighbours
    table, _ = _table(rng, n_per_class=3)
    res = classify(table, "fault", top_k=2, cv=5)
    assert len(res.cv_scores) == 2
    assert any("n_neighbors lowered from 5 to 3" in n for n in res.notes)


def test_top_k_larger_than_features(rng):
    table, _ = _table(rng, n_features=3, informative=(0, 1))
    res = classify(table, "fault", top_k=10)
    assert sorted(res.features) == sorted(res.input_features)
    assert any("top_k=10 exceeds the 3 features" in n for n in res.notes)


def test_single_member_class_is_named(rng):
    table, _ = _table(rng)
    table.iloc[0, table.columns.get_loc("fault")] = "cracked"
    with pytest.raises(DataError, match=r"'cracked' has 1 member"):
        classify(table, "fault")


def test_missing_label_column(rng):
    table, _ = _table(rng)
    with pytest.raises(
        DataError, match=r"label column 'fualt' is not in the feature table"
    ):
        classify(table, "fualt")


def test_single_class(rng):
    table, _ = _table(rng)
    table["fault"] = "ok"
    with pytest.raises(DataError, match="single class"):
        classify(table, "fault")


def test_nan_features_name_members_and_columns(rng):
    table, _ = _table(rng)
    table.loc["m5", "S1/stats/F03"] = np.nan
    table.loc["m17", "S0/stats/F00"] = np.inf
    with pytest.raises(DataError) as info:
        classify(table, "fault")
    message = str(info.value)
    assert "'m5'" in message and "'m17'" in message
    assert "S1/stats/F03" in message and "S0/stats/F00" in message


def test_missing_labels_name_members(rng):
    table, _ = _table(rng)
    table.loc["m3", "fault"] = None
    with pytest.raises(DataError, match="'m3'"):
        classify(table, "fault")


def test_too_few_members_for_the_split(rng):
    table, _ = _table(rng, n_per_class=2)
    with pytest.raises(DataError, match="test_size"):
        classify(table, "fault", test_size=0.2)


def test_bad_parameters(rng):
    table, _ = _table(rng)
    with pytest.raises(ValueError, match="'knn', 'bagged_trees', 'svm', 'random_forest'"):
        make_classifier("tree")
    with pytest.raises(ValueError, match="selection"):
        make_classifier("knn", selection="mutual_info")
    with pytest.raises(ValueError, match="top_k"):
        make_classifier("knn", top_k=0)
    with pytest.raises(ValueError, match="test_size"):
        classify(table, "fault", test_size=1.5)
    with pytest.raises(DataError, match="not in the table"):
        classify(table, "fault", features=["S0/stats/nope"])
    with pytest.raises(DataError, match="numeric"):
        classify(table, "fault", features=["load"])


def test_make_classifier_steps():
    for model in MODELS:
        pipe = make_classifier(model, top_k=3, selection="pca")
        assert [n for n, _ in pipe.steps] == ["scale", "select", "model"]
        assert pipe.named_steps["select"].n_components == 3
    assert [n for n, _ in make_classifier("lda", selection=None).steps] == [
        "scale",
        "model",
    ]


def test_compare_models(rng):
    table, _ = _table(rng)
    df = compare_models(table, "fault", models=("knn", "lda", "svm"), top_k=3)
    assert df["model"].tolist() == ["knn", "lda", "svm"]
    assert (df["accuracy"] >= 0.95).all()
    assert (df["n_test"] == 30).all()
    with pytest.raises(TypeError):
        compare_models(table, "fault", model="knn")


def test_plot_shows_counts(rng):
    import matplotlib.pyplot as plt

    table, _ = _table(rng, shift=1.0)
    res = classify(table, "fault", top_k=3)
    ax = res.plot()
    texts = [t.get_text() for t in ax.texts]
    assert texts == [str(v) for v in res.confusion.ravel()]
    assert [t.get_text() for t in ax.get_xticklabels()] == res.labels
    plt.close(ax.figure)
