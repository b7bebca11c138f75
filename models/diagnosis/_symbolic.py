"""Symbolic-dynamics anomaly measure (D-Markov machines; Ray 2004).

A signal is coarse-grained into symbols by a *maximum-entropy partition* of the nominal
signal's range (cells at its quantiles, so every symbol is equally likely in the nominal
condition); a D-Markov machine takes the last ``D`` symbols as its state. The
probability vector of the states summarises the dynamics; a slow change of the system (a
growing fatigue crack softening a beam) shifts it, and the *anomaly measure* is the
distance of the current state-probability vector from the nominal one. Khatkhate, Ray &
Keller (2007, section 6) report this detecting the crack in its mass-beam rig earlier
than PCA and neural networks, with partitioning in wavelet space (WS) or by symbolic
false nearest neighbours.

:class:`SymbolicAnomaly` implements three partitions of the nominal signal's range:
``"uniform"`` (cells of equal width), ``"max_entropy"`` (cells at its quantiles) and
``"sfnn"`` (:func:`sfnn_partition`: boundaries moved to minimise the fraction of
symbolic false nearest neighbours, Kennel & Buhl, Phys. Rev. Lett. 91, 084102, 2003,
Khatkhate et al.'s reference 15), each optionally in wavelet space (the signal replaced
by its Ricker-wavelet coefficients at given scales before partitioning; Rajagopalan &
Ray 2006), the D-Markov state probabilities and the distance (L2, L1 or the angle
between the vectors).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError, ModelError, NotFittedError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = [
    "SymbolicAnomaly",
    "max_entropy_partition",
    "sfnn_fraction",
    "sfnn_partition",
    "state_probabilities",
    "symbolize",
    "uniform_partition",
]


def _rows(x, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] < 2:
        raise DataError(
            f"{name} must be (n_samples,) or (members, n_samples); got {np.shape(x)}."
        )
    if not np.all(np.isfinite(arr)):
        raise DataError(f"{name} holds NaN/inf values; clean them first.")
    return arr


def max_entropy_partition(x: ArrayLike, n_symbols: int) -> np.ndarray:
    """Interior cell boundaries at the quantiles of ``x`` (equal-probability cells).

    Parameters
    ----------
    x : array_like
        Nominal data (all samples pooled).
    n_symbols : int
        Alphabet size (>= 2).

    Returns
    -------
    ndarray, shape (n_symbols - 1,)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis._symbolic import max_entropy_partition
    >>> max_entropy_partition(np.arange(100.0), 4)
    array([24.75, 49.5 , 74.25])
    """
    n = int(n_symbols)
    if n < 2:
        raise ModelError(f"n_symbols must be >= 2; got {n_symbols!r}.")
    x = np.asarray(x, dtype=float).ravel()
    return np.quantile(x, np.arange(1, n) / n)


def uniform_partition(x: ArrayLike, n_symbols: int) -> np.ndarray:
    """Interior boundaries of ``n_symbols`` cells of equal width over the range of ``x``.

    Parameters
    ----------
    x : array_like
        Nominal data (all samples pooled).
    n_symbols : int
        Alphabet size (>= 2).

    Returns
    -------
    ndarray, shape (n_symbols - 1,)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import uniform_partition
    >>> uniform_partition(np.array([0.0, 1.0, 8.0]), 4)
    array([2., 4., 6.])
    """
    n = int(n_symbols)
    if n < 2:
        raise ModelError(f"n_symbols must be >= 2; got {n_symbols!r}.")
    x = np.asarray(x, dtype=float).ravel()
    lo, hi = float(np.min(x)), float(np.max(x))
    return lo + (hi - lo) * np.arange(1, n) / n


def _first_zero_lag(x: np.ndarray, max_lag: int) -> int:
    """First lag at which the autocorrelation of ``x`` drops to zero (>= 1)."""
    x = x - x.mean()
    n = x.size
    spec = np.fft.rfft(x, 2 * n)
    ac = np.fft.irfft(np.abs(spec) ** 2)[: max_lag + 1]
    below = np.nonzero(ac[1:] <= 0)[0]
    return int(below[0] + 1) if below.size else 1


class _SFNN:
    """The SFNN statistic of one signal, with its sample and tie-breaking fixed."""

    def __init__(self, x, word_length, dim, delay, theiler, r_tol, n_points, seed):
        x = np.asarray(x, dtype=float).ravel()
        if int(word_length) < 1 or int(word_length) % 2 == 0:
            raise ModelError(f"word_length must be odd and >= 1; got {word_length!r}.")
        self.x = x
        self.delay = int(delay) if delay else _first_zero_lag(x, max(1, x.size // 10))
        self.dim, self.h = int(dim), int(word_length) // 2
        span = max((self.dim - 1) * self.delay, 2 * self.h * self.delay)
        if x.size < span + 20:
            raise DataError(
                f"x has {x.size} samples; the SFNN statistic needs more than "
                f"{span + 20} (word_length, dim and delay span {span})."
            )
        self.theiler = int(theiler) if theiler is not None else span
        rng = np.random.default_rng(seed)
        first, last = self.h * self.delay, x.size - span - 1
        m = min(int(n_points), last - first)
        self.idx = np.sort(rng.choice(np.arange(first, last), size=m, replace=False))
        scale = np.std(x) or 1.0
        self.X = np.column_stack(
            [x[self.idx + k * self.delay] / scale for k in range(self.dim)]
        )
        self.r = float(r_tol) * np.sqrt(self.dim)
        self.jitter = 1e-9 * rng.standard_normal((m, 2 * self.h + 1))
        self.weights = 2.0 ** -np.abs(np.arange(-self.h, self.h + 1))
        self.scale = scale

    def __call__(self, boundaries) -> float:
        from scipy.spatial import cKDTree

        b = np.sort(np.asarray(boundaries, dtype=float))
        sym = symbolize(self.x, b)
        n_cells = b.size + 1
        sums = np.bincount(sym, weights=self.x, minlength=n_cells)
        counts = np.bincount(sym, minlength=n_cells)
        edges = np.r_[self.x.min(), b, self.x.max()]
        centre = np.where(
            counts > 0, sums / np.maximum(counts, 1), (edges[:-1] + edges[1:]) / 2
        )
        offsets = np.arange(-self.h, self.h + 1) * self.delay
        W = centre[sym[self.idx[:, None] + offsets[None, :]]] / self.scale
        W = W * self.weights + self.jitter
        k = min(12, len(self.idx))
        dist, nb = cKDTree(W).query(W, k=k)
        far = (np.abs(self.idx[nb] - self.idx[:, None]) > self.theiler) & (dist < 1e-6)
        has = far.any(axis=1)
        j = nb[np.arange(nb.shape[0]), np.argmax(far, axis=1)]
        d = np.linalg.norm(self.X - self.X[j], axis=1)
        return float(np.mean(d[has] > self.r)) if has.any() else 1.0


def sfnn_fraction(
    x: ArrayLike,
    boundaries: ArrayLike,
    *,
    word_length: int = 5,
    dim: int = 3,
    delay: int | None = None,
    theiler: int | None = None,
    r_tol: float = 0.2,
    n_points: int = 2000,
    seed: int = 0,
) -> float:
    """Fraction of symbolic false nearest neighbours of a partition (Kennel & Buhl 2003).

    A partition is *generating* when the symbol sequence determines the state: points
    whose symbolic words agree are then close in the state space. For each of
    ``n_points`` samples (a fixed random subset) the word of ``word_length`` symbols
    centred on it (every ``delay`` samples, each symbol replaced by its cell's mean
    value, weighted ``2^-|k|`` away from the centre) is compared with all others; its
    nearest symbolic neighbour (outside ``theiler`` samples in time) is *false* when
    their delay vectors ``(x_i, x_{i+delay}, ..., x_{i+(dim-1) delay})`` lie farther
    apart than ``r_tol * sqrt(dim)`` standard deviations of ``x``.

    Parameters
    ----------
    x : array_like, shape (n,)
    boundaries : array_like
        Interior cell boundaries.
    word_length : int, default 5
        Odd.
    dim : int, default 3
        Embedding dimension of the state-space reconstruction.
    delay : int, optional
        Embedding (and word) delay in samples; default the first zero of the
        autocorrelation.
    theiler : int, optional
        Temporal neighbours excluded (default the span of a word or a delay vector).
    r_tol : float, default 0.2
    n_points : int, default 2000
    seed : int, default 0

    Returns
    -------
    float in [0, 1]

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import sfnn_fraction
    >>> x = np.empty(4000); x[0] = 0.1234
    >>> for i in range(1, x.size):   # logistic map: generating at the critical point 0.5
    ...     x[i] = 3.9 * x[i-1] * (1 - x[i-1])
    >>> opts = dict(dim=1, delay=1, word_length=9, r_tol=0.2)
    >>> sfnn_fraction(x, [0.5], **opts) < 0.01 < sfnn_fraction(x, [np.median(x)], **opts)
    True
    """
    return _SFNN(x, word_length, dim, delay, theiler, r_tol, n_points, seed)(boundaries)


def sfnn_partition(
    x: ArrayLike,
    n_symbols: int,
    *,
    word_length: int = 5,
    dim: int = 3,
    delay: int | None = None,
    theiler: int | None = None,
    r_tol: float = 0.2,
    n_points: int = 2000,
    grid: int = 12,
    sweeps: int = 3,
    seed: int = 0,
) -> np.ndarray:
    """Partition boundaries that minimise the SFNN fraction (Kennel & Buhl 2003).

    Starts from the maximum-entropy partition and moves one boundary at a time to the
    best of ``grid`` positions between its neighbours (in quantile coordinates of
    ``x``), for up to ``sweeps`` rounds or until no boundary moves; the statistic is
    :func:`sfnn_fraction` with its sample fixed. Khatkhate et al. (2007, figure 7) use
    this SFNN partition for its symbolic-dynamics anomaly measure.

    Parameters
    ----------
    x : array_like, shape (n,)
        Nominal signal.
    n_symbols : int
        Alphabet size (>= 2).
    word_length, dim, delay, theiler, r_tol, n_points, seed
        As in :func:`sfnn_fraction`.
    grid : int, default 12
    sweeps : int, default 3

    Returns
    -------
    ndarray, shape (n_symbols - 1,)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis import sfnn_partition
    >>> x = np.empty(4000); x[0] = 0.1234
    >>> for i in range(1, x.size):   # logistic map: median 0.59, critical point 0.5
    ...     x[i] = 3.9 * x[i-1] * (1 - x[i-1])
    >>> b = sfnn_partition(x, 2, dim=1, delay=1, word_length=9, r_tol=0.2, n_points=1500)
    >>> bool(abs(b[0] - 0.5) < 0.04)   # the generating partition, not the median
    True
    """
    q = max_entropy_partition(x, n_symbols)  # validates n_symbols
    x = np.asarray(x, dtype=float).ravel()
    stat = _SFNN(x, word_length, dim, delay, theiler, r_tol, n_points, seed)
    xs = np.sort(x)
    n = int(n_symbols)
    u = np.arange(1, n) / n

    def at(uu):
        return np.interp(uu, np.linspace(0, 1, xs.size), xs)

    best = stat(q)
    for _ in range(int(sweeps)):
        moved = False
        for k in range(n - 1):
            lo = u[k - 1] if k else 0.0
            hi = u[k + 1] if k < n - 2 else 1.0
            for cand in np.linspace(lo, hi, int(grid) + 2)[1:-1]:
                trial = u.copy()
                trial[k] = cand
                val = stat(at(trial))
                if val < best - 1e-12:
                    best, u, moved = val, trial, True
        if not moved:
            break
    return at(u)


def symbolize(x: ArrayLike, boundaries: ArrayLike) -> np.ndarray:
    """Symbols ``0..len(boundaries)`` of the samples of ``x`` (cell index).

    Examples
    --------
    >>> from pdmkit.models.diagnosis._symbolic import symbolize
    >>> symbolize([-1.0, 0.5, 3.0], [0.0, 1.0]).tolist()
    [0, 1, 2]
    """
    return np.searchsorted(
        np.asarray(boundaries, float), np.asarray(x, float), side="right"
    )


def state_probabilities(symbols: ArrayLike, n_symbols: int, depth: int = 1) -> np.ndarray:
    """Probabilities of the states (last ``depth`` symbols) of a D-Markov machine.

    Parameters
    ----------
    symbols : array_like of int, shape (..., n)
    n_symbols : int
    depth : int
        ``D``; the machine has ``n_symbols ** depth`` states.

    Returns
    -------
    ndarray, shape (..., n_symbols ** depth)

    Examples
    --------
    >>> from pdmkit.models.diagnosis._symbolic import state_probabilities
    >>> state_probabilities([0, 1, 0, 1, 1], 2, depth=2).tolist()   # 01, 10, 01, 11
    [0.0, 0.5, 0.25, 0.25]
    """
    s = np.asarray(symbols, dtype=np.int64)
    D = int(depth)
    if D < 1:
        raise ModelError(f"depth must be >= 1; got {depth!r}.")
    if s.shape[-1] < D:
        raise DataError(f"need at least depth={D} symbols; got {s.shape[-1]}.")
    n = s.shape[-1] - D + 1
    code = np.zeros((*s.shape[:-1], n), dtype=np.int64)
    for k in range(D):
        code = code * n_symbols + s[..., k : k + n]
    n_states = n_symbols**D
    flat = code.reshape(-1, n)
    counts = np.stack([np.bincount(r, minlength=n_states) for r in flat])
    return (counts / n).reshape((*s.shape[:-1], n_states))


def _ricker(points: int, a: float) -> np.ndarray:
    t = np.arange(points) - (points - 1) / 2.0
    A = 2 / (np.sqrt(3 * a) * np.pi**0.25)
    return A * (1 - (t / a) ** 2) * np.exp(-0.5 * (t / a) ** 2)


def _wavelet(x2d: np.ndarray, scales) -> np.ndarray:
    """Concatenated Ricker-wavelet coefficients of each row at ``scales`` (samples)."""
    from scipy.signal import fftconvolve

    out = []
    for a in scales:
        w = _ricker(int(min(10 * a, x2d.shape[1])), float(a))
        out.append(fftconvolve(x2d, w[None, :], mode="same", axes=1))
    return np.concatenate(out, axis=1)


class SymbolicAnomaly(BaseEstimator):
    """Anomaly measure from D-Markov state probabilities (Khatkhate et al. 2007, section 6).

    Parameters
    ----------
    n_symbols : int, default 8
        Alphabet size of the maximum-entropy partition.
    depth : int, default 1
        D-Markov depth (states are words of ``depth`` symbols).
    metric : {"l2", "l1", "angle"}, default "l2"
        Distance of a state-probability vector from the nominal one; ``"angle"`` is
        ``arccos`` of their cosine similarity (radians).
    wavelet_scales : sequence of float, optional
        Partition in wavelet space: replace the signal by its Ricker-wavelet
        coefficients at these scales (in samples) first.
    partition : {"max_entropy", "uniform", "sfnn"}, default "max_entropy"
        How the nominal range is cut into cells: at its quantiles
        (:func:`max_entropy_partition`), in equal widths (:func:`uniform_partition`),
        or where symbolic false nearest neighbours are fewest (:func:`sfnn_partition`,
        on the first nominal member; ``sfnn_options`` are passed on).
    sfnn_options : dict, optional
        Keyword arguments of :func:`sfnn_partition`.

    Attributes
    ----------
    boundaries_ : ndarray
        Partition boundaries learned from the nominal data.
    p0_ : ndarray
        Nominal state probabilities.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.diagnosis._symbolic import SymbolicAnomaly
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(20000) / 100
    >>> nominal = np.sin(2 * np.pi * t) + 0.1 * rng.normal(size=t.size)
    >>> changed = np.sin(2 * np.pi * t) ** 3 + 0.1 * rng.normal(size=t.size)
    >>> det = SymbolicAnomaly(n_symbols=6, depth=2).fit(nominal)
    >>> bool(det.score(changed)[0] > 10 * det.score(nominal)[0])
    True
    """

    def __init__(
        self,
        n_symbols: int = 8,
        depth: int = 1,
        *,
        metric: str = "l2",
        wavelet_scales: Sequence[float] | None = None,
        partition: str = "max_entropy",
        sfnn_options: dict | None = None,
    ):
        self.n_symbols = n_symbols
        self.depth = depth
        self.metric = metric
        self.wavelet_scales = wavelet_scales
        self.partition = partition
        self.sfnn_options = sfnn_options

    def _prep(self, X):
        return X if self.wavelet_scales is None else _wavelet(X, self.wavelet_scales)

    def fit(self, x_nominal: ArrayLike) -> SymbolicAnomaly:
        """Learn the partition and the nominal state probabilities."""
        if self.metric not in ("l2", "l1", "angle"):
            raise ModelError(f"metric must be 'l2', 'l1' or 'angle'; got {self.metric!r}.")
        if self.partition not in ("max_entropy", "uniform", "sfnn"):
            raise ModelError(
                "partition must be 'max_entropy', 'uniform' or 'sfnn'; got "
                f"{self.partition!r}."
            )
        X = self._prep(_rows(x_nominal, "x_nominal"))
        if self.partition == "uniform":
            self.boundaries_ = uniform_partition(X, self.n_symbols)
        elif self.partition == "sfnn":
            opts = dict(self.sfnn_options or {})
            self.boundaries_ = sfnn_partition(X[0], self.n_symbols, **opts)
        else:
            self.boundaries_ = max_entropy_partition(X, self.n_symbols)
        self.p0_ = state_probabilities(
            symbolize(X, self.boundaries_), self.n_symbols, self.depth
        ).mean(axis=0)
        return self

    def state_probabilities(self, x: ArrayLike) -> np.ndarray:
        """State probabilities of each member of ``x`` under the nominal partition."""
        if not hasattr(self, "p0_"):
            raise NotFittedError(
                "SymbolicAnomaly is not fitted; call fit(x_nominal) first."
            )
        X = self._prep(_rows(x, "x"))
        return state_probabilities(
            symbolize(X, self.boundaries_), self.n_symbols, self.depth
        )

    def score(self, x: ArrayLike) -> np.ndarray:
        """Anomaly measure of each member of ``x`` (one value per row)."""
        P = self.state_probabilities(x)
        d = P - self.p0_
        if self.metric == "l2":
            return np.linalg.norm(d, axis=-1)
        if self.metric == "l1":
            return np.abs(d).sum(axis=-1)
        cos = (P @ self.p0_) / (np.linalg.norm(P, axis=-1) * np.linalg.norm(self.p0_))
        return np.arccos(np.clip(cos, -1.0, 1.0))

    def to_pandas(self) -> pd.DataFrame:
        """Nominal state probabilities, one row per state."""
        if not hasattr(self, "p0_"):
            raise NotFittedError(
                "SymbolicAnomaly is not fitted; call fit(x_nominal) first."
            )
        return pd.DataFrame({"state": np.arange(self.p0_.size), "p_nominal": self.p0_})

    def plot(self, ax: Axes | None = None) -> Axes:
        """Bar chart of the nominal state probabilities; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        ax.bar(np.arange(self.p0_.size), self.p0_)
        ax.set_xlabel("state")
        ax.set_ylabel("nominal probability")
        return ax
