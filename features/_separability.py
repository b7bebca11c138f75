"""Class-separability scores that keep telling features apart once classes separate.

Kruskal-Wallis H depends on the ranks only: once the classes no longer overlap, every
such feature gets the same H (its ceiling for the class sizes), and a ranking chart of
them is a row of equal bars. The scores here, for :func:`pdmkit.features.rank_features`,
are computed per column of a fully-finite block ``X`` (N x p) with class codes
``0..k-1`` (every code present, ``k >= 2``); higher is better:

- ``fisher``: Fisher's discriminant ratio, between-class over within-class variance,
  ``J = sum_c n_c (mu_c - mu)^2 / sum_c sum_{i in c} (x_i - mu_c)^2``. Dividing both
  sums by ``N`` gives the same ``J`` (the class-prior-weighted variance of the class
  means over the pooled within-class variance, both with ``ddof = 0``). It is the ANOVA
  F without its degrees of freedom, ``F = J (N - k) / (k - 1)`` (the p-value reported is
  that F test's); for two classes ``J = n_1 n_2 / N^2 (mu_1 - mu_2)^2 / s_w^2``, a
  quarter of the classic ``(mu_1 - mu_2)^2 / (s_1^2 + s_2^2)`` at equal class sizes and
  variances. Infinite when every class is constant and the classes differ.
- ``auc``: ROC AUC of each class against the rest (Mann-Whitney ``U / (n_c (N - n_c))``
  with mid-ranks for ties, as :func:`sklearn.metrics.roc_auc_score`), made
  direction-free with ``max(AUC, 1 - AUC)``, averaged over the classes; in
  ``[0.5, 1]``. It saturates too: once the classes do not overlap it depends on their
  order only (1.0 for two classes), the same for every feature that orders them alike.
- ``bhattacharyya``: the Bhattacharyya distance between Gaussians fitted to each class
  (sample variance, ``ddof = 1``), averaged over all class pairs:
  ``D = (mu_a - mu_b)^2 / (4 (v_a + v_b)) + ln((v_a + v_b) / (2 sqrt(v_a v_b))) / 2``.
  Each class variance is at least ``d^2 / 12``, ``d`` the smallest gap between two
  distinct values of the feature (its resolution: a value rounded to a grid of step
  ``d`` carries that much variance; gaps under ``1e-9`` of the feature's range are
  rounding noise, not distinct values): a class that is constant, or has a single
  member, on a discrete feature (a peak frequency on the FFT grid, a time on the
  sample grid) then gets a finite distance instead of an infinite one.

Fisher and Bhattacharyya keep growing with the gap between the classes relative to
their spread, so they rank fully-separated features by how far apart the classes are.
"""

from __future__ import annotations

import numpy as np
import scipy.stats

__all__ = ["SEPARABILITY", "class_ranges", "fully_separated", "separation_scores"]

SEPARABILITY = ("fisher", "auc", "bhattacharyya")

#: values closer than this share of a feature's range count as the same value
_SAME = 1e-9


def class_ranges(X: np.ndarray, codes: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Per class and column the smallest and largest value, two ``(k, p)`` arrays."""
    mins = np.stack([X[codes == c].min(axis=0) for c in range(k)])
    maxs = np.stack([X[codes == c].max(axis=0) for c in range(k)])
    return mins, maxs


def fully_separated(mins: np.ndarray, maxs: np.ndarray) -> np.ndarray:
    """Per column whether the classes' value ranges are disjoint (no shared value)."""
    order = np.argsort(mins, axis=0, kind="stable")
    lo = np.take_along_axis(mins, order, axis=0)
    hi = np.take_along_axis(maxs, order, axis=0)
    return (hi[:-1] < lo[1:]).all(axis=0)


def _moments(X: np.ndarray, codes: np.ndarray, k: int):
    """Class sizes ``(k,)``, means and within-class sums of squares ``(k, p)``."""
    onehot = np.zeros((len(codes), k))
    onehot[np.arange(len(codes)), codes] = 1.0
    counts = onehot.sum(axis=0)
    means = (onehot.T @ X) / counts[:, None]
    within = onehot.T @ (X - means[codes]) ** 2
    return counts, means, within


def _fisher(X, codes, k, flat):
    n = len(codes)
    counts, means, within = _moments(X, codes, k)
    between = counts @ (means - X.mean(axis=0)) ** 2
    ss_w = np.where(flat, 0.0, within.sum(axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = between / ss_w
        f = ratio * (n - k) / (k - 1)
    pvals = scipy.stats.f.sf(f, k - 1, n - k)
    notes = np.where(
        np.isinf(ratio), "no spread within classes (the ratio is infinite)", ""
    )
    return ratio, np.where(np.isinf(ratio), 0.0, pvals), notes.astype(object)


def _auc(X, codes, k, separated):
    n = len(codes)
    ranks = scipy.stats.rankdata(X, axis=0)  # mid-ranks for ties
    onehot = np.zeros((n, k))
    onehot[np.arange(n), codes] = 1.0
    counts = onehot.sum(axis=0)[:, None]
    u = onehot.T @ ranks - counts * (counts + 1) / 2
    auc = u / (counts * (n - counts))
    scores = np.maximum(auc, 1.0 - auc).mean(axis=0)
    notes = np.where(
        separated,
        "classes fully separated: the AUC depends on their order only (1 for two "
        "classes); method='fisher' or 'bhattacharyya' tells such features apart",
        "",
    ).astype(object)
    return scores, np.full(X.shape[1], np.nan), notes


def _resolution(X: np.ndarray) -> np.ndarray:
    """Per column the smallest gap between two distinct values (inf if there is none).

    Gaps of at most ``1e-9`` of the column's range are rounding noise (0.588 computed
    two ways), not distinct values.
    """
    gaps = np.diff(np.sort(X, axis=0), axis=0)
    gaps[gaps <= _SAME * np.ptp(X, axis=0)] = np.inf
    return gaps.min(axis=0, initial=np.inf)


def _bhattacharyya(X, codes, k, flat):
    p = X.shape[1]
    counts, means, within = _moments(X, codes, k)
    dof = np.maximum(counts - 1, 1)[:, None]
    var = np.where(flat | (counts[:, None] < 2), 0.0, within / dof)
    floor = _resolution(X) ** 2 / 12  # a value on a grid of step d: variance d^2 / 12
    var = np.maximum(var, np.where(np.isfinite(floor), floor, 0.0))
    a, b = np.triu_indices(k, 1)
    gap = (means[a] - means[b]) ** 2
    total = var[a] + var[b]
    with np.errstate(divide="ignore", invalid="ignore"):
        d = gap / (4 * total) + 0.5 * np.log(total / (2 * np.sqrt(var[a] * var[b])))
    return d.mean(axis=0), np.full(p, np.nan), np.full(p, "", dtype=object)


def separation_scores(
    X: np.ndarray, codes: np.ndarray, k: int, method: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scores, p-values (NaN where the method has none) and notes of the columns of X.

    ``X`` is fully finite, ``codes`` run over ``0..k-1`` with every class present and
    ``k >= 2``. Constant columns come out NaN or meaningless: the caller blanks them.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.array([[0.0, 0.0], [1.0, 2.0], [10.0, 5.0], [11.0, 7.0]])
    >>> scores, _, _ = separation_scores(X, np.array([0, 0, 1, 1]), 2, "fisher")
    >>> scores.tolist()  # between / within sums of squares: 100 / 1 and 25 / 4
    [100.0, 6.25]
    """
    mins, maxs = class_ranges(X, codes, k)
    if method == "auc":
        return _auc(X, codes, k, fully_separated(mins, maxs))
    flat = mins == maxs  # exactly constant within the class (no rounding residue)
    if method == "fisher":
        return _fisher(X, codes, k, flat.all(axis=0))
    if method == "bhattacharyya":
        return _bhattacharyya(X, codes, k, flat)
    raise ValueError(f"unknown separability method {method!r}; one of {SEPARABILITY}")
