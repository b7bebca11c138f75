"""Condition classification from fractional-order fits of frequency responses."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.validation import check_is_fitted

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._fractional import model_distance
from pdmkit.models.frequency._fractional_fit import fit_fractional_frf
from pdmkit.models.frequency._fractional_simplex import fit_fractional_simplex

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["FractionalConditionClassifier"]


class FractionalConditionClassifier(ClassifierMixin, BaseEstimator):
    """The fractional-calculus paper's diagnosis: a model per condition, distances, kNN.

    ``fit`` fits the paper's model ``1/(a s^alpha + b s^beta + c)`` to the empirical
    transfer functions of each class (:func:`fit_fractional_frf`, or the paper's simplex
    :func:`fit_fractional_simplex` with ``fit_method="simplex"``), computes every
    training member's distance to each class model (:func:`model_distance`; the
    paper's failure indices, its figure 5) and trains a k-nearest-neighbour classifier
    on those distances (the paper's algorithm 1; k = 3 as its table 2).

    A scikit-learn classifier: ``get_params`` / ``set_params`` / ``clone`` work, ``fit``
    returns ``self``, learned attributes end in ``_``, ``predict`` on an unfitted
    classifier raises scikit-learn's ``NotFittedError`` (a ``ValueError`` and an
    ``AttributeError``), and ``score`` is the accuracy (``ClassifierMixin``). The
    input is complex (ETFEs at ``freq``), so scikit-learn's generic
    ``check_estimator`` (real random matrices of any width) does not apply.

    Parameters
    ----------
    freq : array_like
        Frequencies (Hz) of the ETFE columns.
    n_neighbors : int, default 3
    den_terms : int, default 2
        Terms of the least-squares fit (``fit_method="lsq"``; the simplex fits the
        paper's two).
    relative : bool, default True
        Relative distances (log-scaled features for the kNN).
    fit_method : {"lsq", "simplex"}, default "lsq"
        How each class model is fitted: all the class's members at once by the
        paper's simplex on ``|G_EETF - G|``, or the least-squares fit of their mean.

    Attributes
    ----------
    classes_ : ndarray
    models_ : dict of class -> FractionalFit
    knn_ : sklearn.neighbors.KNeighborsClassifier

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF, FractionalConditionClassifier
    >>> f = np.logspace(-1, 1, 30)
    >>> rng = np.random.default_rng(0)
    >>> H, y = [], []
    >>> for lab, alpha in [("ok", 1.2), ("worn", 1.6)]:
    ...     g = FractionalTF.seed004(0.1, alpha, 0.5, 0.5, 1.0)
    ...     g = g.frequency_response(2 * np.pi * f)
    ...     for _ in range(6):
    ...         H.append(g * (1 + 0.02 * rng.normal(size=f.size)))
    ...         y.append(lab)
    >>> clf = FractionalConditionClassifier(f).fit(np.array(H), y)
    >>> float(np.mean(clf.predict(np.array(H)) == np.array(y)))
    1.0
    """

    def __init__(
        self,
        freq: ArrayLike | None = None,
        *,
        n_neighbors: int = 3,
        den_terms: int = 2,
        relative: bool = True,
        fit_method: str = "lsq",
    ):
        self.freq = freq
        self.n_neighbors = n_neighbors
        self.den_terms = den_terms
        self.relative = relative
        self.fit_method = fit_method

    def _check_H(self, H) -> np.ndarray:
        freq = np.asarray(self.freq, dtype=float).reshape(-1)
        H = np.asarray(H, dtype=complex)
        if H.ndim != 2 or H.shape[1] != freq.size:
            raise DataError(
                f"H must be (n_members, {freq.size}) complex ETFEs matching freq; got "
                f"{H.shape}."
            )
        return H

    def fit(self, H: ArrayLike, y: ArrayLike) -> FractionalConditionClassifier:
        """Fit one model per class and the kNN on the training distances."""
        from sklearn.neighbors import KNeighborsClassifier

        if self.freq is None:
            raise ModelError("freq (Hz of the ETFE columns) is required; got None.")
        if self.fit_method not in ("lsq", "simplex"):
            raise ModelError(
                f"fit_method must be 'lsq' or 'simplex'; got {self.fit_method!r}."
            )
        H = self._check_H(H)
        y = np.asarray(y)
        freq = np.asarray(self.freq, dtype=float).reshape(-1)
        if y.shape[0] != H.shape[0]:
            raise DataError(f"y has {y.shape[0]} labels for {H.shape[0]} members.")
        classes = np.unique(y)
        if classes.size < 2:
            raise DataError("y must hold at least two conditions.")
        if self.fit_method == "simplex":
            models = {c: fit_fractional_simplex(freq, H[y == c]) for c in classes}
        else:
            models = {
                c: fit_fractional_frf(
                    freq, H[y == c].mean(axis=0), den_terms=self.den_terms
                )
                for c in classes
            }
        self.classes_, self.models_ = classes, models
        k = min(int(self.n_neighbors), H.shape[0])
        self.knn_ = KNeighborsClassifier(n_neighbors=k).fit(self.transform(H), y)
        return self

    def transform(self, H: ArrayLike) -> np.ndarray:
        """Distances (log10) of each member to each class model, ``(n, n_classes)``."""
        check_is_fitted(self, "models_")
        H = self._check_H(H)
        d = np.column_stack(
            [
                model_distance(H, self.models_[c].model, self.freq, relative=self.relative)
                for c in self.classes_
            ]
        )
        return np.log10(d + 1e-300)

    def predict(self, H: ArrayLike) -> np.ndarray:
        """Predicted condition of each member."""
        check_is_fitted(self, "knn_")
        return self.knn_.predict(self.transform(H))
