"""Symbolic-dynamics anomaly measure (D-Markov machines; Ray 2004, seed 002 section 6).

A signal is coarse-grained into symbols by a *maximum-entropy partition* of the nominal
signal's range (cells at its quantiles, so every symbol is equally likely in the nominal
condition); a D-Markov machine takes the last ``D`` symbols as its state. The
probability vector of the states summarises the dynamics; a slow change of the system
(a growing fatigue crack softening a beam) shifts it, and the *anomaly measure* is the
distance of the current state-probability vector from the nominal one. Seed 002 reports
this detecting the crack in its mass-beam rig earlier than PCA and neural networks,
with partitioning in wavelet space (WS) or by symbolic false nearest neighbours.

:class:`SymbolicAnomaly` implements the quantile partition (optionally in wavelet space:
the signal is replaced by its Ricker-wavelet coefficients at given scales before
partitioning), the D-Markov state probabilities and the distance (L2, L1 or the angle
between the vectors).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pdmkit.errors import DataError, ModelError, NotFittedError

__all__ = [
    "SymbolicAnomaly",
    "max_entropy_partition",
    "state_probabilities",
    "symbolize",
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


def max_entropy_partition(x, n_symbols: int) -> np.ndarray:
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


def symbolize(x, boundaries) -> np.ndarray:
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


def state_probabilities(symbols, n_symbols: int, depth: int = 1) -> np.ndarray:
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


class SymbolicAnomaly:
    """Anomaly measure from D-Markov state probabilities (seed 002, section 6).

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
        self, n_symbols: int = 8, depth: int = 1, *, metric: str = "l2", wavelet_scales=None
    ):
        self.n_symbols = n_symbols
        self.depth = depth
        self.metric = metric
        self.wavelet_scales = wavelet_scales

    def _prep(self, X):
        return X if self.wavelet_scales is None else _wavelet(X, self.wavelet_scales)

    def fit(self, x_nominal):
        """Learn the partition and the nominal state probabilities."""
        if self.metric not in ("l2", "l1", "angle"):
            raise ModelError(f"metric must be 'l2', 'l1' or 'angle'; got {self.metric!r}.")
        X = self._prep(_rows(x_nominal, "x_nominal"))
        self.boundaries_ = max_entropy_partition(X, self.n_symbols)
        self.p0_ = state_probabilities(
            symbolize(X, self.boundaries_), self.n_symbols, self.depth
        ).mean(axis=0)
        return self

    def state_probabilities(self, x) -> np.ndarray:
        """State probabilities of each member of ``x`` under the nominal partition."""
        if not hasattr(self, "p0_"):
            raise NotFittedError(
                "SymbolicAnomaly is not fitted; call fit(x_nominal) first."
            )
        X = self._prep(_rows(x, "x"))
        return state_probabilities(
            symbolize(X, self.boundaries_), self.n_symbols, self.depth
        )

    def score(self, x) -> np.ndarray:
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

    def plot(self, ax=None):
        """Bar chart of the nominal state probabilities; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        ax.bar(np.arange(self.p0_.size), self.p0_)
        ax.set_xlabel("state")
        ax.set_ylabel("nominal probability")
        return ax
