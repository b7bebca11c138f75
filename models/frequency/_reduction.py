"""Square-root balanced truncation with scipy.linalg only (no slycot).

Laub, Heath, Paige & Ward 1987 (the square-root algorithm); Glover 1984 (the error
bound): python-control's ``balred`` needs slycot, this does not.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.linalg as sla

from pdmkit.errors import ModelError

if TYPE_CHECKING:
    import control
    import scipy.signal
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

    #: ``(A, B, C, D[, dt])``, a :class:`control.StateSpace` or a scipy one.
    StateSpaceLike = tuple | control.StateSpace | scipy.signal.StateSpace

__all__ = ["ReducedModel", "balanced_truncation", "hankel_singular_values"]


# ----------------------------------------------------------------------------- reduction
def _as_abcd(sys) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float | None]:
    """(A, B, C, D, dt) from a tuple, a python-control or a scipy.signal system."""
    dt = None
    if isinstance(sys, tuple | list):
        if len(sys) not in (4, 5):
            raise ModelError(f"sys must be (A, B, C, D[, dt]); got {len(sys)} items.")
        A, B, C, D = (np.atleast_2d(np.asarray(m, dtype=float)) for m in sys[:4])
        dt = sys[4] if len(sys) == 5 else None
    elif hasattr(sys, "A") and hasattr(sys, "B"):
        A, B, C, D = (np.atleast_2d(np.asarray(getattr(sys, k), float)) for k in "ABCD")
        dt = getattr(sys, "dt", None)
        if dt is True or dt == 0:
            dt = None if dt == 0 else dt
    else:
        try:
            import control

            s2 = control.ss(sys)
            return _as_abcd(s2)
        except Exception as exc:
            raise ModelError(
                "sys must be (A, B, C, D), a control.StateSpace/TransferFunction or a "
                f"scipy.signal StateSpace; got {type(sys).__name__}."
            ) from exc
    n = A.shape[0]
    if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n:
        raise ModelError(
            f"inconsistent state-space shapes A{A.shape}, B{B.shape}, C{C.shape}."
        )
    if dt is not None and dt is not False:
        dt = float(dt) if dt is not True else 1.0
    else:
        dt = None
    return A, B, C, D, dt


def _gramians(A, B, C, dt):
    if dt is None:
        if np.any(np.linalg.eigvals(A).real >= 0):
            raise ModelError(
                "balanced truncation needs a stable system; A has eigenvalues with "
                "real part >= 0. Split off the unstable part first."
            )
        P = sla.solve_continuous_lyapunov(A, -B @ B.T)
        Q = sla.solve_continuous_lyapunov(A.T, -C.T @ C)
    else:
        if np.any(np.abs(np.linalg.eigvals(A)) >= 1):
            raise ModelError(
                "balanced truncation needs a stable system; A has eigenvalues with "
                "|z| >= 1."
            )
        P = sla.solve_discrete_lyapunov(A, B @ B.T)
        Q = sla.solve_discrete_lyapunov(A.T, C.T @ C)
    return (P + P.T) / 2, (Q + Q.T) / 2


def _psd_factor(M):
    """L with M ~= L L^T for a symmetric positive semi-definite M."""
    w, V = np.linalg.eigh(M)
    return V * np.sqrt(np.clip(w, 0.0, None))[None, :]


def hankel_singular_values(sys: StateSpaceLike) -> np.ndarray:
    """Hankel singular values of a stable state-space system, largest first.

    ``sigma_i = sqrt(lambda_i(P Q))`` with the controllability and observability
    Gramians ``P``, ``Q`` (continuous or discrete Lyapunov equations).

    Parameters
    ----------
    sys : (A, B, C, D[, dt]) tuple, control.StateSpace or scipy.signal.StateSpace

    Returns
    -------
    ndarray

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import hankel_singular_values
    >>> # 1/(s+1): P = Q = 1/2, so sigma = 1/2
    >>> hankel_singular_values((np.array([[-1.0]]), [[1.0]], [[1.0]], [[0.0]]))
    array([0.5])
    """
    A, B, C, _, dt = _as_abcd(sys)
    P, Q = _gramians(A, B, C, dt)
    Lp, Lq = _psd_factor(P), _psd_factor(Q)
    return np.linalg.svd(Lq.T @ Lp, compute_uv=False)


@dataclass
class ReducedModel:
    """A balanced-truncation reduced model (:func:`balanced_truncation`).

    Attributes
    ----------
    A, B, C, D : ndarray
        Reduced state-space matrices (balanced coordinates).
    dt : float or None
        Sampling period of a discrete model.
    hsv : ndarray
        Hankel singular values of the full model.
    order : int
        Kept states.
    error_bound : float
        ``2 * sum(hsv[order:])``: bound on the H-infinity norm of the error (Glover
        1984; Enns 1984).


    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import balanced_truncation
    >>> A = np.diag([-1.0, -2.0, -100.0])
    >>> B, C = np.ones((3, 1)), np.array([[1.0, 1.0, 0.01]])
    >>> reduced = balanced_truncation((A, B, C, np.zeros((1, 1))), order=2)
    >>> reduced.order, reduced.A.shape, bool(reduced.error_bound < 1e-3)
    (2, (2, 2), True)
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float | None
    hsv: np.ndarray
    order: int
    error_bound: float

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of the reduced ``A``."""
        return np.linalg.eigvals(self.A)

    def frequency_response(self, freq: ArrayLike) -> np.ndarray:
        """Complex response, shape ``(n_out, n_in, n_freq)``, at ``freq`` (Hz)."""
        return _ss_freqresp(self.A, self.B, self.C, self.D, self.dt, freq)

    def to_control(self) -> control.StateSpace:
        """A :class:`control.StateSpace`."""
        import control

        return control.ss(self.A, self.B, self.C, self.D, 0 if self.dt is None else self.dt)

    def to_pandas(self) -> pd.DataFrame:
        """Hankel singular values with a flag for the kept states."""
        return pd.DataFrame(
            {"hsv": self.hsv, "kept": np.arange(self.hsv.size) < self.order}
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """Bar plot of the Hankel singular values; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        i = np.arange(1, self.hsv.size + 1)
        ax.semilogy(i, self.hsv, "o")
        ax.axvline(self.order + 0.5, color="k", ls="--")
        ax.set_xlabel("state")
        ax.set_ylabel("Hankel singular value")
        return ax


def _ss_freqresp(A, B, C, D, dt, freq):
    w = 2 * np.pi * np.asarray(freq, dtype=float).reshape(-1)
    x = 1j * w if dt is None else np.exp(1j * w * dt)
    n = A.shape[0]
    out = np.empty((C.shape[0], B.shape[1], w.size), dtype=complex)
    eye = np.eye(n)
    for i, xi in enumerate(x):
        out[:, :, i] = C @ np.linalg.solve(xi * eye - A, B) + D
    return out


def balanced_truncation(
    sys: StateSpaceLike, order: int | None = None, *, tol: float | None = None
) -> ReducedModel:
    """Reduce a stable state-space model by square-root balanced truncation.

    The Gramians' factors ``P = Lp Lp^T`` and ``Q = Lq Lq^T`` give the Hankel singular
    values as the singular values of ``Lq^T Lp = U S V^T``; the projection
    ``T = Lp V_r S_r^-1/2``, ``T_i = S_r^-1/2 U_r^T Lq^T`` keeps the ``order`` most
    controllable-and-observable states (Laub, Heath, Paige & Ward 1987). The reduced
    model is stable and ``||G - G_r||_inf <= 2 sum(sigma_{r+1..n})`` (Glover 1984). This
    is what Khatkhate, Ray & Keller (2007) do with MATLAB's ``sysbal`` + ``modred``;
    python-control's ``balred`` needs slycot, which this function does not.

    Parameters
    ----------
    sys : (A, B, C, D[, dt]) tuple, control.StateSpace or scipy.signal.StateSpace
    order : int, optional
        States to keep.
    tol : float, optional
        Instead of ``order``: keep the smallest order whose error bound is below ``tol``.

    Returns
    -------
    ReducedModel

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import balanced_truncation
    >>> A = np.diag([-1.0, -50.0]); B = np.array([[1.0], [1.0]])
    >>> C = np.array([[1.0, 0.01]]); D = np.zeros((1, 1))
    >>> red = balanced_truncation((A, B, C, D), order=1)
    >>> np.round(red.poles.real, 2), bool(red.error_bound < 1e-3)
    (array([-1.]), True)
    """
    A, B, C, D, dt = _as_abcd(sys)
    n = A.shape[0]
    P, Q = _gramians(A, B, C, dt)
    Lp, Lq = _psd_factor(P), _psd_factor(Q)
    U, s, Vt = np.linalg.svd(Lq.T @ Lp)
    if order is None:
        if tol is None:
            raise ModelError("give order= (states to keep) or tol= (error bound).")
        tails = 2 * np.concatenate([np.cumsum(s[::-1])[::-1], [0.0]])
        order = int(np.argmax(tails <= tol))
    order = int(order)
    if not 1 <= order <= n:
        raise ModelError(f"order must be between 1 and {n}; got {order}.")
    if s[order - 1] <= 1e-14 * s[0]:
        raise ModelError(
            f"the model has only {int(np.sum(s > 1e-14 * s[0]))} states that are both "
            f"controllable and observable; order={order} is too high."
        )
    sr = s[:order] ** -0.5
    T = Lp @ Vt[:order].T * sr[None, :]
    Ti = (sr[:, None] * U[:, :order].T) @ Lq.T
    return ReducedModel(
        Ti @ A @ T, Ti @ B, C @ T, D.copy(), dt, s, order, float(2 * s[order:].sum())
    )
