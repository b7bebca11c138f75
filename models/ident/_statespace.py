"""Simulation and k-step prediction of discrete state-space models (with a Kalman gain)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import linalg, signal

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["ss_predict", "ss_simulate"]


def _states(A: np.ndarray, B: np.ndarray, u: np.ndarray, x0=None) -> np.ndarray:
    """States x(0..N-1) of x(t+1) = A x(t) + B u(t); modal filtering, loop fallback."""
    n = A.shape[0]
    N = u.shape[0]
    x0 = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float).ravel()
    if n == 0:
        return np.zeros((N, 0))
    lam, V = linalg.eig(A)
    if np.linalg.cond(V) < 1e8:
        Vi = np.linalg.inv(V)
        w = u @ (Vi @ B).T  # modal inputs (N, n)
        z0 = Vi @ x0
        Z = np.empty((N, n), dtype=complex)
        for i in range(n):
            # z(t+1) = lam z(t) + w(t), z(0) = z0  ->  z = filter of w delayed by one
            drive = np.r_[0.0, w[:-1, i]]
            zi = np.array([lam[i] * z0[i]])
            Z[:, i] = signal.lfilter([1.0], [1.0, -lam[i]], drive, zi=zi)[0]
            Z[0, i] = z0[i]
        return np.real(Z @ V.T)
    X = np.empty((N, n))
    x = x0.copy()
    Bu = u @ B.T
    for t in range(N):
        X[t] = x
        x = A @ x + Bu[t]
    return X


def ss_simulate(
    A: ArrayLike,
    B: ArrayLike,
    C: ArrayLike,
    D: ArrayLike,
    u: ArrayLike,
    x0: ArrayLike | None = None,
) -> np.ndarray:
    """Output of a discrete state-space model for the input ``u`` (N, m).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> A, B = np.array([[0.9]]), np.array([[1.0]])
    >>> C, D = np.array([[2.0]]), np.zeros((1, 1))
    >>> u = np.ones((5, 1))
    >>> ref = signal.dlsim((A, B, C, D, 1.0), u)[1]
    >>> np.allclose(ss_simulate(A, B, C, D, u), ref)
    True
    """
    u = np.asarray(u, dtype=float).reshape(len(u), -1)
    X = _states(np.asarray(A), np.asarray(B), u, x0)
    return X @ np.asarray(C).T + u @ np.asarray(D).T


def ss_predict(
    A: ArrayLike,
    B: ArrayLike,
    C: ArrayLike,
    D: ArrayLike,
    K: ArrayLike,
    u: ArrayLike,
    y: ArrayLike,
    horizon: int = 1,
) -> np.ndarray:
    """``horizon``-step-ahead prediction of the innovation-form model.

    ``x(t+1|t) = (A - K C) x + (B - K D) u + K y``; further steps propagate the
    deterministic part. ``K = None`` gives the simulation.

    Examples
    --------
    >>> import numpy as np
    >>> A, B, C, D = (np.array([[0.8]]), np.array([[0.0]]), np.array([[1.0]]),
    ...               np.zeros((1, 1)))
    >>> y = np.array([[1.0], [0.5], [2.0]])
    >>> ss_predict(A, B, C, D, np.array([[0.8]]), np.zeros((3, 1)), y, 1).ravel()
    array([0. , 0.8, 0.4])
    """
    A, B, C, D = (np.asarray(m, dtype=float) for m in (A, B, C, D))
    u = np.asarray(u, dtype=float).reshape(len(u), -1)
    y = np.asarray(y, dtype=float).reshape(len(y), -1)
    if K is None:
        return ss_simulate(A, B, C, D, u)
    K = np.asarray(K, dtype=float)
    Ap = A - K @ C
    Bp = np.hstack([B - K @ D, K])
    X = _states(Ap, Bp, np.hstack([u, y]))  # x(t | t-1)
    for _ in range(horizon - 1):
        Xn = np.zeros_like(X)
        Xn[1:] = X[:-1] @ A.T + u[:-1] @ B.T
        X = Xn
    return X @ C.T + u @ D.T
