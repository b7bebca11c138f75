"""MATLAB's classification trees and their bagged ensemble, missing values included.

The seed's classifiers are MATLAB Classification Learner's "Fine Tree" (``fitctree``)
and "Bagged Trees" (``fitcensemble(..., "Method", "Bag")``: 30 full-depth trees on
bootstrap samples, every predictor considered at every split, class posteriors
averaged). scikit-learn's trees grow the same Gini CART, but a missing value is another
matter, and the seed's proximity-switch indicators are missing wherever a switch never
switched (MATLAB's crest factor of an all-zero signal is 0/0): 1237 of the rig's 4840
recordings for the upper switch.

MATLAB (surrogate splits off, its default) handles a missing value thus (``fitctree``
documentation, "Node Splitting Rules", and ``predict``):

* a split of predictor ``j`` at a node ``t`` is scored by the impurity gain
  ``P(T - T_U) i(t) - P(T_L) i(t_L) - P(T_R) i(t_R)``: ``i`` the Gini index, ``i(t)``
  over all the node's observations, ``T_U`` those missing ``x_j``, the children holding
  the others (``P`` the share of the tree's observations), so a predictor missing in
  many observations scores lower;
* an observation missing the chosen split's predictor goes to neither child: it stays
  in the node, counted in the node's class posterior;
* at prediction an observation missing the split's predictor stops at that node and
  takes its posterior.

Imputing a number instead (pdmkit did: 0) lets the trees split "never switched" off
cleanly, which MATLAB's cannot. On the rig's own proximity table
(``sb/sensor_proximity/ProximityAllFeatures.mat`` of github.com/xvoron/thesis, 30 %
holdouts, seeds 0-2) imputed zeros give 97.6 %; this rule gives 86.3, 87.1 and 86.0 %,
where the author's own runs of the same script printed 80.5, 87.3 and 90.9 %.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.validation import check_is_fitted

from pdmkit.errors import DataError

__all__ = ["MatlabBaggedTrees", "MatlabTree"]


class _Grown:
    """The arrays of one fitted tree: split predictor (-1 at leaves), cut, children."""

    def __init__(self) -> None:
        self.feature: list[int] = []
        self.cut: list[float] = []
        self.left: list[int] = []
        self.right: list[int] = []
        self.posterior: list[np.ndarray] = []

    def node(self, counts: np.ndarray) -> int:
        self.feature.append(-1)
        self.cut.append(np.nan)
        self.left.append(-1)
        self.right.append(-1)
        self.posterior.append(counts / counts.sum())
        return len(self.feature) - 1


def _cut_between(lower: float, upper: float) -> float:
    """MATLAB's cut between two sorted distinct values: their midpoint (inf-safe)."""
    if np.isneginf(lower):
        return upper
    if np.isposinf(upper):
        return np.inf
    cut = lower / 2 + upper / 2
    return upper if cut <= lower else cut


#: Most (observation, predictor, class) counts held at once while scoring a node's
#: splits: 2**22 doubles, 32 MB an array, whatever the table's width.
_BLOCK_CELLS = 1 << 22


def _best_split(
    xs: np.ndarray, ys: np.ndarray, n_classes: int, n_total: int, min_leaf: int
) -> tuple[int, float]:
    """Best (predictor, cut) of a node; predictor -1 when no split gains.

    ``xs`` holds the node's observations (rows) by predictor (columns); ``ys`` their
    class codes. The predictors are scored a block at a time, so memory stays bounded
    for wide tables; on a tie the first predictor wins.
    """
    n, p = xs.shape
    counts = np.bincount(ys, minlength=n_classes).astype(float)
    node_gini = 1.0 - ((counts / n) ** 2).sum()
    step = max(1, _BLOCK_CELLS // (n * n_classes))
    best_gain, best = 1e-12, (-1, np.nan)
    for start in range(0, p, step):
        gain, j, cut = _block_split(
            xs[:, start : start + step], ys, n_classes, node_gini, min_leaf
        )
        if gain / n_total > best_gain:
            best_gain, best = gain / n_total, (start + j, cut)
    return best


def _block_split(
    xs: np.ndarray, ys: np.ndarray, n_classes: int, node_gini: float, min_leaf: int
) -> tuple[float, int, float]:
    """Largest ``n_total`` x gain over the predictors of ``xs``: (gain, column, cut)."""
    n, p = xs.shape
    order = np.argsort(xs, axis=0, kind="stable")  # NaN sorts last
    sorted_x = np.take_along_axis(xs, order, axis=0)
    onehot = np.zeros((n, p, n_classes))
    onehot[np.arange(n)[:, None], np.arange(p)[None, :], ys[order]] = 1.0
    present = ~np.isnan(sorted_x)
    onehot *= present[:, :, None]
    left = np.cumsum(onehot, axis=0)[:-1]  # (n-1, p, K): counts left of each gap
    total = left[-1] + onehot[-1]  # (p, K): the predictor's present observations
    right = total[None] - left
    n_left = np.arange(1, n, dtype=float)[:, None]
    m = present.sum(axis=0).astype(float)  # (p,)
    n_right = m[None, :] - n_left
    valid = (
        present[1:]
        & (sorted_x[1:] > sorted_x[:-1])
        & (n_left >= min_leaf)
        & (n_right >= min_leaf)
    )
    if not valid.any():
        return -np.inf, -1, np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        # MATLAB's gain with missing values: P(T - T_U) i(t) - P(T_L) i(t_L) - P(T_R)
        # i(t_R), the node's impurity i(t) over all its observations, weighed by the
        # share that has the predictor
        left_term = n_left - (left**2).sum(axis=2) / n_left
        right_term = n_right - (right**2).sum(axis=2) / np.where(n_right > 0, n_right, 1)
        gain = m[None, :] * node_gini - left_term - right_term
    gain = np.where(valid, gain, -np.inf)
    flat = int(np.argmax(gain))  # ties: the first gap, then the first predictor
    i, j = divmod(flat, p)
    return float(gain[i, j]), j, _cut_between(sorted_x[i, j], sorted_x[i + 1, j])


def _grow(
    x: np.ndarray,
    y: np.ndarray,
    n_classes: int,
    min_leaf: int,
    min_parent: int,
    max_splits: int,
) -> _Grown:
    tree = _Grown()
    n_total = len(y)
    # breadth first, as MATLAB grows (its MaxNumSplits counts splits level by level)
    root = tree.node(np.bincount(y, minlength=n_classes).astype(float))
    queue = [(root, np.arange(n_total))]
    splits = 0
    while queue and splits < max_splits:
        next_queue = []
        for node, rows in queue:
            if splits >= max_splits:
                break
            small = len(rows) < max(min_parent, 2 * min_leaf)
            if small or np.count_nonzero(tree.posterior[node]) <= 1:
                continue
            j, cut = _best_split(x[rows], y[rows], n_classes, n_total, min_leaf)
            if j < 0:
                continue
            values = x[rows, j]
            go_left, go_right = values < cut, values >= cut  # NaN: neither, it stays
            tree.feature[node], tree.cut[node] = j, cut
            for side, chosen in (("left", go_left), ("right", go_right)):
                child_rows = rows[chosen]
                child = tree.node(
                    np.bincount(y[child_rows], minlength=n_classes).astype(float)
                )
                getattr(tree, side)[node] = child
                next_queue.append((child, child_rows))
            splits += 1
        queue = next_queue
    return tree


def _tree_posterior(tree: dict[str, np.ndarray], x: np.ndarray) -> np.ndarray:
    """Class posteriors of the rows of ``x``.

    Each row descends until a leaf, or a split whose value it misses, stops it.
    """
    node = np.zeros(len(x), dtype=int)
    moving = tree["feature"][node] >= 0
    rows = np.arange(len(x))
    while moving.any():
        at = node[moving]
        values = x[rows[moving], tree["feature"][at]]
        known = ~np.isnan(values)
        step = np.where(values < tree["cut"][at], tree["left"][at], tree["right"][at])
        moved = rows[moving][known]
        node[moved] = step[known]
        still = np.zeros(len(x), dtype=bool)
        still[moved] = tree["feature"][node[moved]] >= 0
        moving = still
    return tree["posterior"][node]


def _as_arrays(tree: _Grown) -> dict[str, np.ndarray]:
    return {
        "feature": np.asarray(tree.feature, dtype=int),
        "cut": np.asarray(tree.cut, dtype=float),
        "left": np.asarray(tree.left, dtype=int),
        "right": np.asarray(tree.right, dtype=int),
        "posterior": np.asarray(tree.posterior, dtype=float),
    }


class _MatlabClassifier(ClassifierMixin, BaseEstimator):
    """What the two share: class codes on fitting, the largest posterior on predicting."""

    def _codes(self, X, y) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(X, dtype=float)
        labels = np.asarray(y)
        if x.ndim != 2 or labels.ndim != 1 or len(x) != len(labels) or not len(x):
            raise DataError(
                f"{type(self).__name__}: X must be (observations, predictors) and y one "
                f"label an observation; got X {x.shape} and y {labels.shape}"
            )
        self.classes_, codes = np.unique(labels, return_inverse=True)
        self.n_features_in_ = x.shape[1]
        return x, codes

    def _rows(self, X) -> np.ndarray:
        x = np.asarray(X, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.n_features_in_:
            raise DataError(
                f"{type(self).__name__}: X must have {self.n_features_in_} predictors a "
                f"row, as in fitting; got {x.shape}"
            )
        return x

    def predict_proba(self, X) -> np.ndarray:
        """Class posteriors, columns in the order of ``classes_``."""
        check_is_fitted(self, "trees_")
        x = self._rows(X)
        return np.mean([_tree_posterior(tree, x) for tree in self.trees_], axis=0)

    def predict(self, X) -> np.ndarray:
        """The class of the largest posterior (the first of ``classes_`` on a tie)."""
        posterior = self.predict_proba(X)
        return self.classes_[np.argmax(posterior, axis=1)]


class MatlabTree(_MatlabClassifier):
    """MATLAB's ``fitctree`` classification tree, missing values as MATLAB treats them.

    Gini splits, MATLAB's cut points (midpoints), a missing split value keeping the
    observation in its node (see the module notes). The defaults are Classification
    Learner's "Fine Tree": at most 100 splits, ``fitctree``'s branch nodes of at least
    10 observations and leaves of at least 1.

    Parameters
    ----------
    max_splits : int or None, default 100
        Most splits (branch nodes); None: ``n - 1``.
    min_parent : int, default 10
        Fewest observations of a node that is split.
    min_leaf : int, default 1
        Fewest observations in a leaf.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.experiments._matlab_trees import MatlabTree
    >>> x = np.array([[0.0], [1.0], [2.0], [3.0], [np.nan]])
    >>> tree = MatlabTree(min_parent=2).fit(x, ["a", "a", "b", "b", "b"])
    >>> tree.predict([[0.5], [2.5], [np.nan]]).tolist()  # NaN: the root's posterior
    ['a', 'b', 'b']
    """

    def __init__(
        self, max_splits: int | None = 100, min_parent: int = 10, min_leaf: int = 1
    ) -> None:
        self.max_splits = max_splits
        self.min_parent = min_parent
        self.min_leaf = min_leaf

    def fit(self, X, y):
        """Grow the tree on ``X`` (rows, predictors; NaN missing) and labels ``y``."""
        x, codes = self._codes(X, y)
        limit = len(codes) - 1 if self.max_splits is None else int(self.max_splits)
        grown = _grow(
            x, codes, len(self.classes_), int(self.min_leaf), int(self.min_parent), limit
        )
        self.trees_ = [_as_arrays(grown)]
        return self

    @property
    def tree_(self) -> dict[str, np.ndarray]:
        """The fitted tree: split predictor (-1 at leaves), cut, children, posteriors."""
        check_is_fitted(self, "trees_")
        return self.trees_[0]


class MatlabBaggedTrees(_MatlabClassifier):
    """MATLAB Classification Learner's "Bagged Trees": ``fitcensemble`` with "Bag".

    ``n_estimators`` full-depth :class:`MatlabTree` s (``n - 1`` splits, any node of
    two observations split, leaves of one), each on a bootstrap sample of the training
    rows, all predictors considered at each split; the prediction is the
    class of the largest mean posterior. Missing values (NaN) are MATLAB's (see the
    module notes); infinite values are ordinary values, as in MATLAB.

    Parameters
    ----------
    n_estimators : int, default 30
        Trees (the Learner's 30).
    random_state : int, default 0
        Seed of the bootstrap samples.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.experiments._matlab_trees import MatlabBaggedTrees
    >>> rng = np.random.default_rng(0)
    >>> x = rng.standard_normal((200, 3))
    >>> y = np.where(x[:, 0] > 0, "up", "down")
    >>> x[::7, 0] = np.nan  # missing in 29 rows
    >>> model = MatlabBaggedTrees(n_estimators=10).fit(x[:150], y[:150])
    >>> float(np.mean(model.predict(x[150:]) == y[150:])) > 0.8
    True
    """

    def __init__(self, n_estimators: int = 30, random_state: int = 0) -> None:
        self.n_estimators = n_estimators
        self.random_state = random_state

    def fit(self, X, y):
        """Grow the trees on bootstrap samples of ``X`` (NaN missing) and ``y``."""
        x, codes = self._codes(X, y)
        rng = np.random.default_rng(self.random_state)
        n = len(codes)
        self.trees_ = []
        for _ in range(int(self.n_estimators)):
            pick = rng.integers(0, n, n)
            grown = _grow(x[pick], codes[pick], len(self.classes_), 1, 2, n - 1)
            self.trees_.append(_as_arrays(grown))
        return self
