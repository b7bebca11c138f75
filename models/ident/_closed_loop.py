"""Identification in closed loop: direct, indirect (known controller removed), joint.

An unstable plant can only be measured under a stabilising controller, and then its
input is correlated with the output noise (the controller feeds the noise back). The
classical answers (Ljung 1999, sec. 13.5; Forssell & Ljung, *Closed-loop
identification revisited*, Automatica 1999) that the S-Mobile paper names in its
section 2.2:

- **direct** (:func:`direct_identification`): identify the plant from its measured
  input ``u`` and output ``y`` as if there were no loop. With a prediction-error
  method whose noise model can describe the real noise it is consistent, and an ARX
  predictor ``y_hat = (1 - A) y + B u`` stays stable for an unstable plant; with a
  wrong noise model the feedback biases it.
- **indirect** (:func:`indirect_identification`): identify the *closed loop* from the
  reference ``r`` (which the noise does not reach) to the outputs, a stable system,
  then remove the known controller: with ``u = F_r r - F_y y`` the closed loop's
  input sensitivity is ``T_u = F_r - F_y T_y`` and the plant ``G = T_y T_u^-1``
  (the S-Mobile paper's eqs. 5-8).
- **joint input-output** (:func:`joint_identification`): identify ``r -> (y, u)`` as
  one stable model and take ``G = T_y T_u^-1`` from its two parts; no controller
  knowledge needed.

All three return a :class:`ClosedLoopModel` (discrete state space of the plant, its
poles in z and s, frequency response). :func:`closed_loop_frf` is the nonparametric
counterpart: ``G = S_ry / S_ru`` from cross-spectra with the reference.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from scipy import signal

from pdmkit._checks import check_fs
from pdmkit.errors import ConvergenceWarning, DataError, ModelError
from pdmkit.models.frequency import FRF, frf_estimate
from pdmkit.models.ident._arx import arx
from pdmkit.models.ident._model import _as_signal
from pdmkit.models.ident._order import select_order
from pdmkit.models.ident._subspace import n4sid

if TYPE_CHECKING:
    from collections.abc import Iterable

    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = [
    "ClosedLoopModel",
    "KnownController",
    "closed_loop_frf",
    "direct_identification",
    "indirect_identification",
    "joint_identification",
]


@dataclass(frozen=True)
class KnownController:
    """A linear discrete controller ``u[k] = sum_j N_j r[k-j] - sum_i sum_j K_ij y_i[k-j]``.

    Parameters
    ----------
    feedback : array_like (n_outputs, n_taps) or (n_outputs,)
        FIR taps on each measured output (a 1-D array: static gains, no delay). A
        state feedback read one sample late is ``np.c_[np.zeros(4), K]``.
    feedforward : array_like (n_taps,) or float
        FIR taps on the reference (the set-point filter ``N``).

    Examples
    --------
    >>> import numpy as np
    >>> pd_ctl = KnownController(feedback=[[3.0, -1.0]], feedforward=2.0)
    >>> pd_ctl.apply(np.ones(4), np.zeros((4, 1))).tolist()
    [2.0, 2.0, 2.0, 2.0]
    """

    feedback: np.ndarray
    feedforward: np.ndarray = field(default_factory=lambda: np.ones(1))

    def __post_init__(self):
        fb = np.atleast_1d(np.asarray(self.feedback, dtype=float))
        fb = fb[:, None] if fb.ndim == 1 else fb
        ff = np.atleast_1d(np.asarray(self.feedforward, dtype=float))
        if (
            fb.ndim != 2
            or ff.ndim != 1
            or not (np.all(np.isfinite(fb)) and np.all(np.isfinite(ff)))
        ):
            raise ModelError(
                f"feedback must be (n_outputs, n_taps) and feedforward (n_taps,) finite; "
                f"got {fb.shape} and {ff.shape}."
            )
        if not np.any(ff):
            raise ModelError("feedforward is zero: the reference does not enter the loop.")
        object.__setattr__(self, "feedback", fb)
        object.__setattr__(self, "feedforward", ff)

    @property
    def n_outputs(self) -> int:
        """Measured outputs the controller feeds back."""
        return self.feedback.shape[0]

    def apply(self, r: ArrayLike, y: ArrayLike) -> np.ndarray:
        """The controller's output for a reference ``r`` (n,) and outputs ``y`` (n, n_y)."""
        r = np.asarray(r, dtype=float)
        y = np.asarray(y, dtype=float).reshape(r.size, -1)
        u = signal.lfilter(self.feedforward, [1.0], r)
        for i in range(self.n_outputs):
            u = u - signal.lfilter(self.feedback[i], [1.0], y[:, i])
        return u

    def _ss(self):
        """``(F_r, F_y)`` as discrete state spaces ``(A, B, C, D)`` (shift registers)."""
        return _fir_ss(self.feedforward[None, :]), _fir_ss(self.feedback)


def _fir_ss(taps: np.ndarray):
    """Shift-register state space of ``sum_i sum_j taps[i, j] x_i[k - j]`` (MISO)."""
    n_in, m = taps.shape
    n = n_in * (m - 1)
    A, B, C = np.zeros((n, n)), np.zeros((n, n_in)), np.zeros((1, n))
    for i in range(n_in):
        o = i * (m - 1)
        if m > 1:
            B[o, i] = 1.0
            A[o + 1 : o + m - 1, o : o + m - 2] = np.eye(m - 2)
            C[0, o : o + m - 1] = taps[i, 1:]
    return A, B, C, taps[:, :1].T.copy()


@dataclass(eq=False)
class ClosedLoopModel:
    """A plant identified from closed-loop data.

    Attributes
    ----------
    method : str
        ``"direct"``, ``"indirect"`` or ``"joint"``.
    fs : float
    A, B, C, D : ndarray
        Discrete state space of the plant ``u -> y`` (outputs in the order given).
    info : dict
        The intermediate models (the closed loop for indirect and joint, the ARX for
        direct) and the orders.

    Examples
    --------
    >>> import numpy as np
    >>> m = ClosedLoopModel("direct", 10.0, np.array([[1.2]]), np.ones((1, 1)),
    ...                     np.ones((1, 1)), np.zeros((1, 1)))
    >>> round(float(m.unstable_poles[0]), 3)  # s = ln(1.2) * 10
    1.823
    """

    method: str
    fs: float
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    info: dict = field(default_factory=dict, repr=False)

    @property
    def poles(self) -> np.ndarray:
        """Poles in z."""
        return np.linalg.eigvals(self.A) if self.A.size else np.zeros(0, complex)

    @property
    def poles_s(self) -> np.ndarray:
        """Poles mapped to continuous time, ``s = ln(z) fs`` (rad/s); z = 0 is dropped."""
        z = self.poles
        z = z[np.abs(z) > 1e-8]
        return np.log(z.astype(complex)) * self.fs

    @property
    def unstable_poles(self) -> np.ndarray:
        """Real parts > 0 of the continuous poles that are real (rad/s), descending."""
        s = self.poles_s
        real = s[(np.abs(s.imag) < 1e-6 * np.maximum(1.0, np.abs(s))) & (s.real > 0)]
        return np.sort(real.real)[::-1]

    def frequency_response(self, f: ArrayLike) -> np.ndarray:
        """``C (zI - A)^-1 B + D`` at ``f`` (Hz), shape ``(len(f), n_outputs)``."""
        f = np.atleast_1d(np.asarray(f, dtype=float))
        z = np.exp(2j * np.pi * f / self.fs)
        eye = np.eye(self.A.shape[0])
        out = [self.C @ np.linalg.solve(zz * eye - self.A, self.B) + self.D for zz in z]
        return np.stack(out)[:, :, 0]

    def to_pandas(self) -> pd.DataFrame:
        """Continuous poles with natural frequency (rad/s) and damping."""
        s = self.poles_s
        wn = np.abs(s)
        with np.errstate(invalid="ignore", divide="ignore"):
            zeta = np.where(wn > 0, -s.real / wn, np.nan)
        return pd.DataFrame({"real": s.real, "imag": s.imag, "wn_rad_s": wn, "zeta": zeta})

    def plot(self, ax: Axes | None = None) -> Axes:
        """Continuous pole map; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(4.5, 3.5))
        s = self.poles_s
        ax.plot(s.real, s.imag, "x", label=self.method)
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel("real [1/s]")
        ax.set_ylabel("imag [rad/s]")
        ax.legend(fontsize="small")
        return ax


def _outputs(y, n: int) -> np.ndarray:
    y = np.asarray(y, dtype=float)
    y = y[:, None] if y.ndim == 1 else y
    if y.ndim != 2 or y.shape[0] != n:
        raise DataError(
            f"y must be (n_samples, n_outputs) with {n} samples; got {y.shape}."
        )
    if not np.all(np.isfinite(y)):
        raise DataError("y holds NaN or inf values.")
    return y


def direct_identification(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    order: int | None = None,
    nk: int = 1,
    criterion: str = "mdl",
    orders: Iterable[int] = range(1, 11),
) -> ClosedLoopModel:
    """Plant from its input and output as if the loop were open (ARX, SISO).

    Parameters
    ----------
    u, y : array_like (n,)
        Plant input (the controller's output) and one measured output.
    fs : float
    order : int, optional
        ``na = nb = order``; None selects it by ``criterion`` from ``orders``.
    nk : int, default 1
        Input delay (a zero-order hold plant: 1).

    Returns
    -------
    ClosedLoopModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> n, fs = 4000, 10.0
    >>> r, e = rng.normal(size=n), 0.01 * rng.normal(size=n)
    >>> y, u = np.zeros(n), np.zeros(n)
    >>> for k in range(1, n):  # y[k] = 1.1 y[k-1] + u[k-1], u = r - 0.5 y (stable loop)
    ...     y[k] = 1.1 * y[k - 1] + u[k - 1] + e[k]
    ...     u[k] = r[k] - 0.5 * y[k]
    >>> m = direct_identification(u, y, fs, order=1)
    >>> round(float(m.poles[0].real), 3)
    1.1
    """
    fs = check_fs(fs)
    u = _as_signal(u, "u")
    y = _as_signal(y, "y")
    # an unstable plant's simulation (the fit on the estimation data) overflows: quiet
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.simplefilter("ignore", signal.BadCoefficients)
        if order is None:
            cands = [{"na": int(n), "nb": int(n), "nk": int(nk)} for n in orders]
            sel = select_order(u, y, "arx", cands, criterion, fs=fs)
            model = sel.best_model
        else:
            model, sel = arx(u, y, int(order), int(order), int(nk), fs=fs), None
        A, B, C, D = model.to_state_space()
    return ClosedLoopModel(
        "direct", fs, *map(np.atleast_2d, (A, B, C, D)), {"model": model, "selection": sel}
    )


def _orth_krylov(A: np.ndarray, B: np.ndarray, tol: float) -> np.ndarray:
    """Orthonormal basis of the Krylov space ``span{B, AB, A^2 B, ...}`` (staircase)."""
    n = A.shape[0]
    scale = max(np.linalg.norm(B), 1e-300)
    U, sv, _ = np.linalg.svd(B, full_matrices=False)
    V = U[:, sv > tol * scale]
    new = V
    while new.shape[1] and V.shape[1] < n:
        W = A @ new
        W = W - V @ (V.T @ W)
        U, sv, _ = np.linalg.svd(W, full_matrices=False)
        new = U[:, sv > tol * scale * max(1.0, np.linalg.norm(A))]
        V = np.hstack([V, new])
    return V


def _minimal(A, B, C, D, tol: float = 1e-8):
    """Remove the uncontrollable, then the unobservable part (orthogonal projections)."""
    if A.size == 0:
        return A, B, C, D
    Q = _orth_krylov(A, B, tol)
    A, B, C = Q.T @ A @ Q, Q.T @ B, C @ Q
    if A.size == 0:
        return A, B, C, D
    W = _orth_krylov(A.T, C.T, tol)
    return W.T @ A @ W, W.T @ B, C @ W, D


def _plant_from_loop(A, B, Cy, Dy, Cu, Du, fs: float, method: str, info: dict):
    """``G = T_y T_u^-1`` for a closed loop ``r -> (y, u)`` on one state.

    With ``x+ = A x + B r``, ``u = Cu x + Du r``: ``r = (u - Cu x) / Du``, so the plant
    is ``x+ = (A - B Cu / Du) x + (B / Du) u``, ``y = (Cy - Dy Cu / Du) x + (Dy / Du) u``;
    its poles are the zeros of ``T_u``.
    """
    d = float(np.squeeze(Du))
    if abs(d) < 1e-12:
        raise ModelError(
            "the closed loop's input sensitivity T_u has no direct term, so it cannot be "
            "inverted: the reference must reach the plant input without delay."
        )
    Ag = A - B @ Cu / d
    Bg = B / d
    Cg = Cy - Dy @ Cu / d
    Dg = Dy / d
    Ag, Bg, Cg, Dg = _minimal(Ag, Bg, Cg, Dg)
    return ClosedLoopModel(method, fs, Ag, Bg, Cg, Dg, info)


def _fit_loop(r, Y, fs, nx, max_order, horizon):
    """Closed loop ``r -> Y`` by N4SID (output-error type: the reference is noise-free).

    Without ``nx`` the order is where the subspace singular values drop most (the
    largest ratio between neighbours among the first ``max_order``).
    """
    Y = Y[:, 0] if Y.shape[1] == 1 else Y
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        if nx is None:
            first = n4sid(r, Y, int(max_order), fs=fs, noise_model=False, horizon=horizon)
            sv = np.asarray(first.info["singular_values"], dtype=float)[
                : int(max_order) + 1
            ]
            sv = np.maximum(sv, np.finfo(float).tiny)
            nx = int(np.argmax(sv[:-1] / sv[1:])) + 1
            if nx == int(max_order):
                return first
        return n4sid(r, Y, int(nx), fs=fs, noise_model=False, horizon=horizon)


def indirect_identification(
    r: ArrayLike,
    y: ArrayLike,
    fs: float,
    controller: KnownController,
    *,
    order: int | None = None,
    max_order: int = 12,
    horizon: int = 15,
) -> ClosedLoopModel:
    """Closed loop from the reference, then the known controller removed.

    The closed loop ``T_y: r -> y`` is identified (N4SID; stable, and the reference is
    not correlated with the noise); the controller gives ``u = F_r r - F_y y``, so
    ``T_u = F_r - F_y T_y`` on the same state, and the plant is ``T_y T_u^-1``.

    Parameters
    ----------
    r : array_like (n,)
        Reference (set-point) signal.
    y : array_like (n,) or (n, n_outputs)
        The outputs the controller feeds back (all of them, in its order).
    fs : float
    controller : KnownController
    order : int, optional
        State dimension of the closed-loop model (N4SID); None takes it from the largest
        drop of the subspace singular values among the first ``max_order``.
    max_order : int, default 12
    horizon : int, default 15
        N4SID block rows (past and future).

    Returns
    -------
    ClosedLoopModel
        The plant ``u -> y``; ``info["loop"]`` is the closed-loop model.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> n, fs = 3000, 10.0
    >>> r, e = rng.normal(size=n), 0.01 * rng.normal(size=n)
    >>> y, u = np.zeros(n), np.zeros(n)
    >>> for k in range(1, n):
    ...     y[k] = 1.1 * y[k - 1] + u[k - 1] + e[k]
    ...     u[k] = r[k] - 0.5 * y[k]
    >>> ctl = KnownController(feedback=[0.5], feedforward=1.0)
    >>> m = indirect_identification(r, y, fs, ctl, order=1)
    >>> round(float(np.max(m.poles.real)), 2)
    1.1
    """
    fs = check_fs(fs)
    r = _as_signal(r, "r")
    Y = _outputs(y, r.size)
    if Y.shape[1] != controller.n_outputs:
        raise DataError(
            f"the controller feeds back {controller.n_outputs} outputs; y has {Y.shape[1]}."
        )
    loop = _fit_loop(r, Y, fs, order, max_order, horizon)
    At, Bt, Ct, Dt = (np.atleast_2d(m) for m in loop.ss)
    (Ar, Br, Cr, Dr), (Af, Bf, Cf, Df) = controller._ss()
    nt, nfy, nfr = At.shape[0], Af.shape[0], Ar.shape[0]
    # one state [closed loop, F_y, F_r]; u = F_r r - F_y (Ct x + Dt r)
    A = np.block(
        [
            [At, np.zeros((nt, nfy)), np.zeros((nt, nfr))],
            [Bf @ Ct, Af, np.zeros((nfy, nfr))],
            [np.zeros((nfr, nt)), np.zeros((nfr, nfy)), Ar],
        ]
    )
    B = np.vstack([Bt, Bf @ Dt, Br])
    Cy = np.hstack([Ct, np.zeros((Ct.shape[0], nfy + nfr))])
    Cu = np.hstack([-Df @ Ct, -Cf, Cr])
    Du = Dr - Df @ Dt
    return _plant_from_loop(A, B, Cy, Dt, Cu, Du, fs, "indirect", {"loop": loop})


def joint_identification(
    r: ArrayLike,
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    order: int | None = None,
    max_order: int = 12,
    horizon: int = 15,
) -> ClosedLoopModel:
    """Joint input-output: ``r -> (y, u)`` as one model, ``G = T_y T_u^-1``.

    Needs no knowledge of the controller, only a reference the noise does not reach.
    ``order``, ``max_order`` and ``horizon`` as in :func:`indirect_identification`.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(2)
    >>> n, fs = 3000, 10.0
    >>> r, e = rng.normal(size=n), 0.01 * rng.normal(size=n)
    >>> y, u = np.zeros(n), np.zeros(n)
    >>> for k in range(1, n):
    ...     y[k] = 1.1 * y[k - 1] + u[k - 1] + e[k]
    ...     u[k] = r[k] - 0.5 * y[k]
    >>> m = joint_identification(r, u, y, fs, order=1)
    >>> round(float(np.max(m.poles.real)), 2)
    1.1
    """
    fs = check_fs(fs)
    r = _as_signal(r, "r")
    u = _as_signal(u, "u")
    Y = _outputs(y, r.size)
    if u.size != r.size:
        raise DataError(f"u has {u.size} samples, r {r.size}; they must match.")
    loop = _fit_loop(r, np.column_stack([Y, u]), fs, order, max_order, horizon)
    A, B, C, D = (np.atleast_2d(m) for m in loop.ss)
    ny = Y.shape[1]
    return _plant_from_loop(
        A, B, C[:ny], D[:ny], C[ny:], D[ny:], fs, "joint", {"loop": loop}
    )


def closed_loop_frf(
    r: ArrayLike, u: ArrayLike, y: ArrayLike, fs: float, **welch: Any
) -> FRF:
    """Nonparametric plant FRF from closed-loop data: ``G = S_ry / S_ru``.

    Both cross-spectra are taken with the reference, which the noise fed back by the
    controller does not reach, so the estimate is consistent where the direct
    ``S_uy / S_uu`` is biased towards the inverse of the controller. The coherence is
    that of ``r -> y``.

    Parameters
    ----------
    r, u, y : array_like (n,) or (n_runs, n)
    fs : float
    **welch
        ``nperseg``, ``noverlap``, ``fmin``, ``fmax``, ``amplitudes`` as in
        :func:`pdmkit.models.frequency.frf_estimate`.

    Returns
    -------
    pdmkit.models.frequency.FRF

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(3)
    >>> n, fs = 20000, 10.0
    >>> r, e = rng.normal(size=n), 0.05 * rng.normal(size=n)
    >>> y, u = np.zeros(n), np.zeros(n)
    >>> for k in range(1, n):
    ...     y[k] = 1.1 * y[k - 1] + u[k - 1] + e[k]
    ...     u[k] = r[k] - 0.5 * y[k]
    >>> frf = closed_loop_frf(r, u, y, fs, nperseg=256)
    >>> z = np.exp(2j * np.pi * frf.freq[10] / fs)
    >>> bool(abs(frf.H[10] - 1 / (z - 1.1)) < 0.05 * abs(1 / (z - 1.1)))
    True
    """
    ty = frf_estimate(r, y, fs, **welch)
    tu = frf_estimate(r, u, fs, **welch)
    return FRF(ty.freq, ty.H / tu.H, ty.coherence, ty.amplitudes, ty.n_averages)
