"""The anomaly measures set beside symbolic dynamics: PCA, RBF and MLP networks.

Khatkhate, Ray & Keller (2007, section 6, figure 7) measure the growth of a fatigue
crack from the displacement of one mass with five methods: symbolic dynamics with the
SFNN and the wavelet-space partitions
(:class:`~pdmkit.models.diagnosis.SymbolicAnomaly`), principal component analysis (PCA),
a radial-basis-function neural network (RBFNN) and a multilayer perceptron (MLPNN),
citing Chin, Ray & Rajagopalan (Signal Processing 85, 2005) for the details, which they
do not reprint. pdmkit's versions, each fitted on the nominal record and scoring
later records by how far they have moved from it:

- :class:`PCAAnomaly` - the record is cut into delay windows; the principal
  directions of their covariance (as many as explain ``variance`` of the nominal
  windows), weighted by their eigenvalues, form ``P = sum lambda_i v_i v_i^T``; the
  measure is ``||P - P0||_F / ||P0||_F`` (sign-free form of Chin et al.'s
  eigenvalue-weighted principal vectors).
- :class:`RBFAnomaly` - a Gaussian radial-basis-function network (centres by k-means,
  linear output by ridge least squares; Bishop 1995, their reference 12) trained on the
  nominal record to predict the next sample from the last ``n_lags``;
- :class:`MLPAnomaly` - a multilayer perceptron (scikit-learn's ``MLPRegressor``,
  ``tanh``; Haykin 1999, their reference 13) trained the same way.

The two networks' measure is the change of their prediction error,
``|rms(e) / rms(e0) - 1|``, with ``e0`` the error on held-out nominal data: the network
models the nominal dynamics, and a changed system is predicted worse. All three take
the signal in units of the nominal standard deviation, so a change of amplitude counts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError, ModelError, NotFittedError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["MLPAnomaly", "PCAAnomaly", "RBFAnomaly"]


def _rows(x, name: str, min_len: int) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2:
        raise DataError(
            f"{name} must be (n_samples,) or (members, n_samples); got {arr.shape}."
        )
    if arr.shape[1] < min_len:
        raise DataError(
            f"{name} has {arr.shape[1]} samples per member; this measure needs at least "
            f"{min_len}."
        )
    if not np.all(np.isfinite(arr)):
        raise DataError(f"{name} holds NaN/inf values; clean them first.")
    return arr


def _windows(x1d: np.ndarray, length: int, step: int) -> np.ndarray:
    """Delay windows ``x[i : i + length]`` every ``step`` samples, one per row."""
    view = np.lib.stride_tricks.sliding_window_view(x1d, length)
    return view[:: max(1, int(step))]


class _Measure(BaseEstimator):
    """Shared parts: nominal scaling, fitted check, table and plot."""

    _name = "anomaly"

    def _scale(self, X):
        return (X - self.mean_) / self.std_

    def _check(self):
        if not hasattr(self, "std_"):
            raise NotFittedError(
                f"{type(self).__name__} is not fitted; call fit(x_nominal) first."
            )

    def _fit_scale(self, X):
        self.mean_ = float(X.mean())
        self.std_ = float(X.std()) or 1.0

    def to_pandas(self) -> pd.Series:
        """The settings and the fitted nominal quantities as a Series."""
        self._check()
        out = {k: v for k, v in vars(self).items() if not k.endswith("_")}
        out.update({"nominal_mean": self.mean_, "nominal_std": self.std_})
        out.update(self._summary())
        return pd.Series(out, dtype=object)

    def plot(
        self, x: ArrayLike, ax: Axes | None = None, *, time: ArrayLike | None = None
    ) -> Axes:
        """The measure of each member of ``x`` (against ``time``); returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        m = self.score(x)
        t = np.arange(m.size) if time is None else np.asarray(time)
        ax.plot(t, m, "o-", label=self._name)
        ax.set_xlabel("record" if time is None else "time")
        ax.set_ylabel("anomaly measure")
        ax.legend()
        return ax


class PCAAnomaly(_Measure):
    """Change of the eigenvalue-weighted principal directions of delay windows.

    Parameters
    ----------
    window : int, default 16
        Delay-window length (samples).
    variance : float, default 0.9
        Share of the nominal windows' variance the kept principal directions explain.
    step : int, default 1
        Take a window every ``step`` samples.

    Attributes
    ----------
    n_components_ : int
    P0_ : ndarray, shape (window, window)
        Nominal ``sum lambda_i v_i v_i^T`` over the kept directions.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import PCAAnomaly
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(20000) / 200
    >>> nominal = np.sin(2 * np.pi * 11 * t) + 0.1 * rng.normal(size=t.size)
    >>> same = np.sin(2 * np.pi * 11 * t) + 0.1 * rng.normal(size=t.size)
    >>> louder = 1.2 * np.sin(2 * np.pi * 11 * t) + 0.1 * rng.normal(size=t.size)
    >>> pca = PCAAnomaly().fit(nominal)
    >>> bool(pca.score(louder)[0] > 10 * pca.score(same)[0])
    True
    """

    _name = "PCA"

    def __init__(self, window: int = 16, variance: float = 0.9, step: int = 1):
        self.window = window
        self.variance = variance
        self.step = step

    def _weighted(self, X1d):
        W = _windows(self._scale(X1d), int(self.window), self.step)
        C = np.cov(W, rowvar=False)
        lam, V = np.linalg.eigh(C)
        return lam[::-1], V[:, ::-1]

    def fit(self, x_nominal: ArrayLike) -> PCAAnomaly:
        """Learn the nominal scale, the number of directions and ``P0``."""
        if not 0 < float(self.variance) <= 1:
            raise ModelError(f"variance must be in (0, 1]; got {self.variance!r}.")
        if int(self.window) < 2:
            raise ModelError(f"window must be >= 2; got {self.window!r}.")
        X = _rows(x_nominal, "x_nominal", 4 * int(self.window))
        self._fit_scale(X)
        lam, V = self._weighted(X[0])
        share = np.cumsum(lam) / lam.sum()
        self.n_components_ = int(np.searchsorted(share, float(self.variance)) + 1)
        k = self.n_components_
        self.P0_ = (V[:, :k] * lam[:k]) @ V[:, :k].T
        return self

    def score(self, x: ArrayLike) -> np.ndarray:
        """The measure ``||P - P0|| / ||P0||`` of each member of ``x``."""
        self._check()
        X = _rows(x, "x", 4 * int(self.window))
        k = self.n_components_
        out = []
        for row in X:
            lam, V = self._weighted(row)
            P = (V[:, :k] * lam[:k]) @ V[:, :k].T
            out.append(np.linalg.norm(P - self.P0_) / np.linalg.norm(self.P0_))
        return np.array(out)

    def _summary(self):
        return {"n_components": self.n_components_}


class _Predictor(_Measure):
    """One-step-ahead predictor trained on nominal data; measure from its error."""

    def _pairs(self, x1d):
        L, h = int(self.n_lags), int(self.horizon)
        z = self._scale(x1d)
        X = _windows(z[: z.size - h], L, 1)
        y = z[L - 1 + h :]
        return X, y

    def fit(self, x_nominal: ArrayLike) -> _Predictor:
        """Train on the first 70 % of the nominal record, calibrate on the rest."""
        if int(self.n_lags) < 1 or int(self.horizon) < 1:
            raise ModelError(
                f"n_lags and horizon must be >= 1; got {self.n_lags!r}, {self.horizon!r}."
            )
        need = 20 * (int(self.n_lags) + int(self.horizon))
        X = _rows(x_nominal, "x_nominal", need)
        self._fit_scale(X)
        A, y = self._pairs(X[0])
        cut = int(0.7 * y.size)
        rng = np.random.default_rng(self.random_state)
        idx = np.arange(cut)
        if cut > int(self.max_train):
            idx = np.sort(rng.choice(cut, size=int(self.max_train), replace=False))
        self._train(A[idx], y[idx], rng)
        self.rms0_ = float(np.sqrt(np.mean((self._predict(A[cut:]) - y[cut:]) ** 2)))
        return self

    def prediction_error(self, x: ArrayLike) -> np.ndarray:
        """RMS one-step prediction error (nominal-std units) of each member."""
        self._check()
        X = _rows(x, "x", 2 * (int(self.n_lags) + int(self.horizon)))
        out = []
        for row in X:
            A, y = self._pairs(row)
            out.append(np.sqrt(np.mean((self._predict(A) - y) ** 2)))
        return np.array(out)

    def score(self, x: ArrayLike) -> np.ndarray:
        """The measure ``|rms(e) / rms(e0) - 1|`` of each member of ``x``."""
        return np.abs(self.prediction_error(x) / self.rms0_ - 1.0)

    def _summary(self):
        return {"nominal_rms_error": self.rms0_}


class RBFAnomaly(_Predictor):
    """Prediction-error measure of a Gaussian radial-basis-function network.

    Parameters
    ----------
    n_lags : int, default 8
        Past samples the network sees.
    horizon : int, default 1
        Samples ahead it predicts.
    n_centers : int, default 40
        Gaussian units (centres by k-means on the nominal inputs).
    width : float, default 3.0
        Unit width as a multiple of the mean distance between nearest centres (wide,
        overlapping units fit smooth maps; 1 leaves gaps between them).
    ridge : float, default 1e-6
        Ridge penalty of the output layer.
    max_train : int, default 20000
    random_state : int, default 0

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import RBFAnomaly
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(20000) / 200
    >>> nominal = np.sin(2 * np.pi * 11 * t) + 0.05 * rng.normal(size=t.size)
    >>> louder = 1.5 * np.sin(2 * np.pi * 11 * t) + 0.05 * rng.normal(size=t.size)
    >>> rbf = RBFAnomaly(n_centers=20).fit(nominal)
    >>> bool(rbf.score(louder)[0] > 0.5)
    True
    """

    _name = "RBF"

    def __init__(
        self,
        n_lags: int = 8,
        horizon: int = 1,
        n_centers: int = 40,
        width: float = 3.0,
        ridge: float = 1e-6,
        max_train: int = 20000,
        random_state: int = 0,
    ):
        self.n_lags = n_lags
        self.horizon = horizon
        self.n_centers = n_centers
        self.width = width
        self.ridge = ridge
        self.max_train = max_train
        self.random_state = random_state

    def _phi(self, A):
        d2 = (
            np.sum(A**2, axis=1)[:, None]
            - 2 * A @ self.centers_.T
            + np.sum(self.centers_**2, axis=1)[None, :]
        )
        G = np.exp(-np.maximum(d2, 0) / (2 * self.sigma_**2))
        return np.column_stack([G, np.ones(A.shape[0])])

    def _train(self, A, y, rng):
        from scipy.cluster.vq import kmeans2

        k = min(int(self.n_centers), A.shape[0])
        self.centers_, _ = kmeans2(A, k, minit="++", seed=rng)
        d = np.linalg.norm(self.centers_[:, None] - self.centers_[None], axis=-1)
        np.fill_diagonal(d, np.inf)
        self.sigma_ = float(self.width) * float(np.mean(d.min(axis=1)))
        Phi = self._phi(A)
        reg = float(self.ridge) * np.eye(Phi.shape[1])
        self.weights_ = np.linalg.solve(Phi.T @ Phi + reg, Phi.T @ y)

    def _predict(self, A):
        return self._phi(A) @ self.weights_


class MLPAnomaly(_Predictor):
    """Prediction-error measure of a multilayer perceptron (``MLPRegressor``, tanh).

    Parameters
    ----------
    n_lags : int, default 8
    horizon : int, default 1
    hidden : tuple of int, default (16,)
        Hidden layer sizes.
    max_iter : int, default 200
    max_train : int, default 20000
    random_state : int, default 0

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import MLPAnomaly
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(8000) / 200
    >>> nominal = np.sin(2 * np.pi * 11 * t) + 0.05 * rng.normal(size=t.size)
    >>> mlp = MLPAnomaly(max_iter=50).fit(nominal)
    >>> bool(mlp.prediction_error(nominal)[0] < 0.2)   # it has learnt the dynamics
    True
    """

    _name = "MLP"

    def __init__(
        self,
        n_lags: int = 8,
        horizon: int = 1,
        hidden: tuple = (16,),
        max_iter: int = 200,
        max_train: int = 20000,
        random_state: int = 0,
    ):
        self.n_lags = n_lags
        self.horizon = horizon
        self.hidden = hidden
        self.max_iter = max_iter
        self.max_train = max_train
        self.random_state = random_state

    def _train(self, A, y, rng):
        import warnings

        from sklearn.exceptions import ConvergenceWarning as SkConvergence
        from sklearn.neural_network import MLPRegressor

        self.net_ = MLPRegressor(
            hidden_layer_sizes=tuple(self.hidden),
            activation="tanh",
            max_iter=int(self.max_iter),
            random_state=int(self.random_state),
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SkConvergence)
            self.net_.fit(A, y)

    def _predict(self, A):
        return self.net_.predict(A)
