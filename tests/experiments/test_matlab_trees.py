"""MATLAB's classification trees (the seed's "Fine Tree" and "Bagged Trees").

Without missing values a MATLAB tree is scikit-learn's Gini CART: the same splits,
checked against :class:`sklearn.tree.DecisionTreeClassifier`. With them it follows
MATLAB's documented rule (``fitctree``, surrogate splits off): a split is scored on the
observations that have its predictor, an observation missing it stays in the node, and
at prediction it stops there.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from sklearn.ensemble import BaggingClassifier
from sklearn.tree import DecisionTreeClassifier

from pdmkit.experiments._matlab_trees import MatlabBaggedTrees, MatlabTree


@pytest.fixture
def blobs():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(300, 4))
    y = np.where(x[:, 0] + 0.5 * x[:, 2] > 0.2, "b", "a")
    y[x[:, 1] > 1.2] = "c"
    return x, y


def test_top_splits_are_sklearns_gini_cart(blobs):
    x, y = blobs
    for depth, splits in ((1, 1), (2, 3)):  # MATLAB grows level by level
        ours = MatlabTree(max_splits=splits, min_parent=2).fit(x, y)
        ref = DecisionTreeClassifier(max_depth=depth, random_state=0).fit(x, y)
        branch = ours.tree_["feature"] >= 0
        assert branch.sum() == splits
        ref_branch = ref.tree_.feature >= 0
        assert sorted(ours.tree_["feature"][branch]) == sorted(
            ref.tree_.feature[ref_branch]
        )
        np.testing.assert_allclose(
            sorted(ours.tree_["cut"][branch]), sorted(ref.tree_.threshold[ref_branch])
        )
        np.testing.assert_array_equal(ours.predict(x), ref.predict(x))


def test_full_trees_fit_the_training_set_and_agree_with_sklearn(blobs):
    x, y = blobs
    ours = MatlabTree(max_splits=None, min_parent=2).fit(x[:200], y[:200])
    assert np.mean(ours.predict(x[:200]) == y[:200]) == 1.0
    ref = DecisionTreeClassifier(random_state=0).fit(x[:200], y[:200])
    agree = np.mean(ours.predict(x[200:]) == ref.predict(x[200:]))
    assert agree > 0.9  # equal-gain ties may be broken differently deep down


def test_missing_value_stays_in_its_node_at_fit_and_at_predict():
    # x0 separates a from b; the c rows miss x0, so no child of the x0 split holds c
    x = np.array([[0.0], [1.0], [2.0], [10.0], [11.0], [12.0], [np.nan], [np.nan]])
    y = np.array(["a", "a", "a", "b", "b", "b", "c", "c"])
    tree = MatlabTree(max_splits=None, min_parent=2).fit(x, y)
    t = tree.tree_
    assert t["feature"][0] == 0 and 2.0 < t["cut"][0] < 10.0
    np.testing.assert_allclose(t["posterior"][0], [3 / 8, 3 / 8, 2 / 8])
    for child in (t["left"][0], t["right"][0]):
        assert t["posterior"][child][2] == 0.0  # the c rows did not descend
    proba = tree.predict_proba([[1.0], [11.0], [np.nan]])
    np.testing.assert_allclose(proba[2], t["posterior"][0])  # stopped at the root
    assert tree.predict([[1.0], [11.0]]).tolist() == ["a", "b"]


def test_a_predictor_missing_in_many_rows_scores_by_its_present_ones():
    # x0 splits its present rows perfectly but misses half of them; x1 is complete
    # and almost as good: MATLAB's gain weighs x0 by its present rows, so x1 wins
    rng = np.random.default_rng(0)
    y = np.repeat(["a", "b"], 100)
    x0 = np.where(y == "a", 0.0, 1.0)
    x0[::2] = np.nan
    x1 = np.where(y == "a", 0.0, 1.0)
    x1[rng.choice(200, 6, replace=False)] = 0.5  # six rows in the middle
    tree = MatlabTree(max_splits=1, min_parent=2).fit(np.column_stack([x0, x1]), y)
    assert tree.tree_["feature"][0] == 1


def _documented_best_split(x, y):
    """fitctree's node splitting rule, written out: for every predictor and cut,
    dI_U = P(T - T_U) i(t) - P(T_L) i(t_L) - P(T_R) i(t_R), with i the Gini index, i(t)
    over all the node's observations, T_U those missing the predictor."""

    def gini(labels):
        _, counts = np.unique(labels, return_counts=True)
        return 1.0 - np.sum((counts / counts.sum()) ** 2) if len(labels) else 0.0

    n = len(y)
    best = (-np.inf, None, None)
    for j in range(x.shape[1]):
        present = ~np.isnan(x[:, j])
        values = np.unique(x[present, j])
        for lo, hi in itertools.pairwise(values):
            cut = (lo + hi) / 2
            left, right = present & (x[:, j] < cut), present & (x[:, j] >= cut)
            gain = (
                present.sum() * gini(y)
                - left.sum() * gini(y[left])
                - right.sum() * gini(y[right])
            ) / n
            if gain > best[0] + 1e-12:
                best = (gain, j, cut)
    return best[1], best[2]


def test_the_split_is_matlabs_documented_rule_with_missing_values():
    # x0 tells a from b but is missing for all of c and d (a switch that never
    # switched); x2 tells a from the rest. The node's impurity over all its rows, not
    # over x0's present ones, is what makes x0 the split here (over its present rows
    # only, x2 would win in these draws)
    rng = np.random.default_rng(7)
    for _ in range(5):
        y = rng.choice(np.array(["a", "b", "c", "d"]), 120)
        shift = (y == "a")[:, None] * [0.6, 0.0, 1.6] - (y == "b")[:, None] * [0.6, 0, 0]
        x = rng.normal(size=(120, 3)) + shift
        x[np.isin(y, ["c", "d"]), 0] = np.nan
        tree = MatlabTree(max_splits=1, min_parent=2).fit(x, y)
        feature, cut = _documented_best_split(x, y)
        assert tree.tree_["feature"][0] == feature == 0
        assert tree.tree_["cut"][0] == pytest.approx(cut)


def test_never_switched_cannot_be_split_off_as_a_zero_would_be():
    # class "never" misses x0 everywhere (a switch that never switched); imputing 0
    # separates it, MATLAB's rule cannot: only the noise in x1 is left to split on
    rng = np.random.default_rng(1)
    y = np.repeat(["switched", "never"], 150)
    x = np.column_stack([rng.uniform(1, 2, 300), rng.normal(size=300)])
    x[y == "never", 0] = np.nan
    train = rng.permutation(300)[:200]
    test = np.setdiff1d(np.arange(300), train)
    ours = MatlabBaggedTrees(n_estimators=10, random_state=0).fit(x[train], y[train])
    matlab_like = np.mean(ours.predict(x[test]) == y[test])
    zero = np.nan_to_num(x)
    imputed = BaggingClassifier(DecisionTreeClassifier(), n_estimators=10, random_state=0)
    imputed.fit(zero[train], y[train])
    assert np.mean(imputed.predict(zero[test]) == y[test]) == 1.0
    assert matlab_like < 0.75


def test_bagged_trees_are_reproducible_and_take_infinite_values(blobs):
    x, y = blobs
    x = x.copy()
    x[:20, 3] = np.inf
    x[20:40, 3] = -np.inf
    a = MatlabBaggedTrees(n_estimators=5, random_state=4).fit(x, y)
    b = MatlabBaggedTrees(n_estimators=5, random_state=4).fit(x, y)
    np.testing.assert_array_equal(a.predict_proba(x), b.predict_proba(x))
    np.testing.assert_allclose(a.predict_proba(x).sum(axis=1), 1.0)
    assert len(a.trees_) == 5 and set(a.predict(x)) <= set(a.classes_)
    assert np.mean(a.predict(x) == y) > 0.95


def test_wide_tables_are_scored_in_blocks_with_the_same_result(blobs, monkeypatch):
    import pdmkit.experiments._matlab_trees as mt

    x, y = blobs
    x = x.copy()
    x[::5, 1] = np.nan
    whole = MatlabTree(max_splits=None, min_parent=2).fit(x, y).tree_
    monkeypatch.setattr(mt, "_BLOCK_CELLS", 1)  # one predictor a block
    blocks = MatlabTree(max_splits=None, min_parent=2).fit(x, y).tree_
    for key in ("feature", "left", "right"):
        np.testing.assert_array_equal(whole[key], blocks[key])
    np.testing.assert_allclose(whole["cut"], blocks["cut"])


def test_bad_shapes_are_named():
    from sklearn.exceptions import NotFittedError

    from pdmkit.errors import DataError

    with pytest.raises(DataError, match=r"MatlabTree: X must be .* got X \(3,\)"):
        MatlabTree().fit([1.0, 2.0, 3.0], ["a", "b", "a"])
    with pytest.raises(DataError, match="one label an observation"):
        MatlabBaggedTrees(n_estimators=2).fit(np.zeros((3, 2)), ["a", "b"])
    model = MatlabBaggedTrees(n_estimators=2).fit(np.eye(4), list("abab"))
    with pytest.raises(DataError, match="must have 4 predictors"):
        model.predict(np.zeros((2, 3)))
    with pytest.raises(NotFittedError):
        MatlabTree().predict(np.zeros((1, 2)))
